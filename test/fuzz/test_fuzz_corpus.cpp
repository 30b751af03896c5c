// The fuzz harnesses of fuzz/ (built here with the project's compiler, without libFuzzer) over
// every input of test/data/fuzz/<harness>/: the inputs that once crashed a parser, made a
// sanitizer report or hung it stay fixed, and no exception other than the parser's own error
// escapes a harness.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#define GVF_FUZZ_HARNESS(name) extern "C" int gvfFuzz_##name(const std::uint8_t* data, std::size_t size);
#define GVF_FUZZ_HARNESSES                   \
  GVF_FUZZ_HARNESS(class_names)              \
  GVF_FUZZ_HARNESS(darknet_cfg)              \
  GVF_FUZZ_HARNESS(darknet_weights)          \
  GVF_FUZZ_HARNESS(image_view)               \
  GVF_FUZZ_HARNESS(kitti_labels)             \
  GVF_FUZZ_HARNESS(kitti_object_calibration) \
  GVF_FUZZ_HARNESS(kitti_raw_calibration)    \
  GVF_FUZZ_HARNESS(onnx_input)               \
  GVF_FUZZ_HARNESS(oxts)                     \
  GVF_FUZZ_HARNESS(point_cloud_view)         \
  GVF_FUZZ_HARNESS(replay_labels)            \
  GVF_FUZZ_HARNESS(scenario)                 \
  GVF_FUZZ_HARNESS(timestamps)               \
  GVF_FUZZ_HARNESS(tracking_labels)          \
  GVF_FUZZ_HARNESS(tracklets)
GVF_FUZZ_HARNESSES
#undef GVF_FUZZ_HARNESS

namespace
{
namespace fs = std::filesystem;

struct Harness
{
  std::string name;
  int (*entry)(const std::uint8_t*, std::size_t);
};

const std::vector<Harness>& harnesses()
{
#define GVF_FUZZ_HARNESS(name) {#name, &gvfFuzz_##name},
  static const std::vector<Harness> kHarnesses{GVF_FUZZ_HARNESSES};
#undef GVF_FUZZ_HARNESS
  return kHarnesses;
}

std::vector<std::uint8_t> readBytes(const fs::path& path)
{
  std::ifstream file(path, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
}

TEST(FuzzCorpus, EveryHarnessOfFuzzIsRun)
{
  std::set<std::string> run;
  for (const Harness& harness : harnesses())
  {
    run.insert(harness.name);
  }
  std::size_t found = 0;
  for (const auto& entry : fs::recursive_directory_iterator(fs::path(GVF_SOURCE_DIR) / "fuzz"))
  {
    const std::string name = entry.path().filename().string();
    if (name.rfind("fuzz_", 0) == 0 && entry.path().extension() == ".cpp")
    {
      ++found;
      EXPECT_EQ(run.count(name.substr(5, name.size() - 9)), 1U) << name << " is not in this test's list";
    }
  }
  EXPECT_EQ(found, run.size());
}

TEST(FuzzCorpus, EveryInputPassesItsHarness)
{
  for (const Harness& harness : harnesses())
  {
    const fs::path directory = fs::path(GVF_TEST_DATA_DIR) / "fuzz" / harness.name;
    std::size_t inputs = 0;
    for (const auto& entry : fs::directory_iterator(directory))
    {
      const std::vector<std::uint8_t> input = readBytes(entry.path());
      ++inputs;
      try
      {
        EXPECT_EQ(harness.entry(input.data(), input.size()), 0) << entry.path();
      }
      catch (const std::exception& e)
      {
        ADD_FAILURE() << entry.path() << ": " << e.what();
      }
    }
    EXPECT_GT(inputs, 0U) << directory << " holds no input";
  }
}

}  // namespace
