// Shared by the fuzz harnesses of fuzz/: the entry point, the input as text or in parts, and a
// reader of the fields a message harness builds from the input bytes.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

// Under libFuzzer (scripts/fuzz.sh) every harness is LLVMFuzzerTestOneInput. The corpus
// regression test (test/fuzz/test_fuzz_corpus.cpp) links all harnesses into one program and
// defines GVF_FUZZ_CORPUS_TEST, which gives each its own name, gvfFuzz_<name>.
#ifdef GVF_FUZZ_CORPUS_TEST
#define GVF_FUZZ_TARGET(name) extern "C" int gvfFuzz_##name(const std::uint8_t* data, std::size_t size)
#else
#define GVF_FUZZ_TARGET(name) \
  extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
#endif

namespace gvf_fuzz
{
/// Separates the parts of an input that holds several files (e.g. a cfg and its weights).
constexpr const char* kPartSeparator = "\n----\n";

inline std::string text(const std::uint8_t* data, std::size_t size)
{
  return std::string(reinterpret_cast<const char*>(data), size);
}

/// The input cut at the first `count - 1` separators into `count` parts (missing ones empty).
inline std::vector<std::string> parts(const std::uint8_t* data, std::size_t size, std::size_t count)
{
  std::vector<std::string> result;
  std::string rest = text(data, size);
  while (result.size() + 1 < count)
  {
    const auto at = rest.find(kPartSeparator);
    if (at == std::string::npos)
    {
      break;
    }
    result.push_back(rest.substr(0, at));
    rest = rest.substr(at + std::strlen(kPartSeparator));
  }
  result.push_back(rest);
  result.resize(count);
  return result;
}

/// Keeps `value`, and so the reads that made it, from being optimised away.
template <typename T>
void keep(const T& value)
{
  asm volatile("" : : "g"(value) : "memory");
}

/// Takes fixed-size values from the front of the input (zero once it is used up).
class ByteReader
{
public:
  ByteReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  template <typename T>
  T take()
  {
    T value{};
    const std::size_t n = std::min(sizeof(T), size_);
    std::memcpy(&value, data_, n);
    data_ += n;
    size_ -= n;
    return value;
  }

  /// A string of at most `max_length` bytes, its length taken first.
  std::string takeString(std::size_t max_length)
  {
    const std::size_t n = std::min<std::size_t>(take<std::uint8_t>() % (max_length + 1), size_);
    std::string value(reinterpret_cast<const char*>(data_), n);
    data_ += n;
    size_ -= n;
    return value;
  }

  /// What is left.
  std::vector<std::uint8_t> rest() const { return std::vector<std::uint8_t>(data_, data_ + size_); }

private:
  const std::uint8_t* data_;
  std::size_t size_;
};

}  // namespace gvf_fuzz
