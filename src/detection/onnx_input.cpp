// The declared input of an ONNX model, read from its protobuf wire format (the few fields of
// onnx.proto that lead to the graph's input shapes; every other field is skipped by its length).
#include <cstdint>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "grid_vision_fusion/detection/yolo_detector.h"

namespace grid_vision_fusion
{
namespace
{
// onnx.proto field numbers.
constexpr std::uint32_t kModelGraph = 7;        // ModelProto.graph
constexpr std::uint32_t kGraphInitializer = 5;  // GraphProto.initializer (TensorProto)
constexpr std::uint32_t kGraphInput = 11;       // GraphProto.input (ValueInfoProto)
constexpr std::uint32_t kTensorName = 8;        // TensorProto.name
constexpr std::uint32_t kValueInfoName = 1;     // ValueInfoProto.name
constexpr std::uint32_t kValueInfoType = 2;     // ValueInfoProto.type (TypeProto)
constexpr std::uint32_t kTypeTensor = 1;        // TypeProto.tensor_type
constexpr std::uint32_t kTensorTypeShape = 2;   // TypeProto.Tensor.shape
constexpr std::uint32_t kShapeDim = 1;          // TensorShapeProto.dim
constexpr std::uint32_t kDimValue = 1;          // TensorShapeProto.Dimension.dim_value

// Protobuf wire types.
constexpr int kVarint = 0;
constexpr int kFixed64 = 1;
constexpr int kLengthDelimited = 2;
constexpr int kFixed32 = 5;

struct Field
{
  std::uint32_t number = 0;
  int wire_type = 0;
  std::uint64_t value = 0;  ///< a varint field's value
  std::string_view bytes;   ///< a length-delimited field's content
};

/// The fields of one protobuf message, one after the other.
class FieldReader
{
public:
  FieldReader(std::string_view message, const std::string& source) : rest_(message), source_(source) {}

  /// The next field; false at the end of the message.
  bool next(Field& field)
  {
    if (rest_.empty())
    {
      return false;
    }
    const std::uint64_t tag = varint();
    field.number = static_cast<std::uint32_t>(tag >> 3U);
    field.wire_type = static_cast<int>(tag & 7U);
    switch (field.wire_type)
    {
      case kVarint:
        field.value = varint();
        break;
      case kFixed64:
        skip(8);
        break;
      case kLengthDelimited:
      {
        const std::uint64_t length = varint();
        if (length > rest_.size())
        {
          fail("a field of " + std::to_string(length) + " bytes runs past the end of its message");
        }
        field.bytes = rest_.substr(0, length);
        rest_.remove_prefix(length);
        break;
      }
      case kFixed32:
        skip(4);
        break;
      default:
        fail("unknown protobuf wire type " + std::to_string(field.wire_type));
    }
    return true;
  }

  [[noreturn]] void fail(const std::string& what) const
  {
    throw YoloModelError(source_ + ": not a well-formed ONNX model (" + what + ")");
  }

private:
  std::uint64_t varint()
  {
    std::uint64_t value = 0;
    for (unsigned shift = 0; shift < 64; shift += 7)
    {
      if (rest_.empty())
      {
        fail("truncated varint");
      }
      const auto byte = static_cast<std::uint8_t>(rest_.front());
      rest_.remove_prefix(1);
      value |= static_cast<std::uint64_t>(byte & 0x7FU) << shift;
      if ((byte & 0x80U) == 0)
      {
        return value;
      }
    }
    fail("varint longer than 10 bytes");
  }

  void skip(std::size_t bytes)
  {
    if (rest_.size() < bytes)
    {
      fail("truncated fixed-size field");
    }
    rest_.remove_prefix(bytes);
  }

  std::string_view rest_;
  const std::string& source_;
};

/// The content of the first length-delimited field `number` of `message` (empty when absent).
std::string_view firstMessage(std::string_view message, std::uint32_t number, const std::string& source)
{
  FieldReader reader(message, source);
  Field field;
  while (reader.next(field))
  {
    if (field.number == number && field.wire_type == kLengthDelimited)
    {
      return field.bytes;
    }
  }
  return {};
}

/// Every length-delimited field `number` of `message`.
std::vector<std::string_view> allMessages(std::string_view message, std::uint32_t number,
                                          const std::string& source)
{
  std::vector<std::string_view> found;
  FieldReader reader(message, source);
  Field field;
  while (reader.next(field))
  {
    if (field.number == number && field.wire_type == kLengthDelimited)
    {
      found.push_back(field.bytes);
    }
  }
  return found;
}

/// The dimensions of a TensorShapeProto: dim_value, or -1 where it is named (dim_param) or absent.
std::vector<long long> shapeOf(std::string_view shape, const std::string& source)
{
  std::vector<long long> dims;
  for (const std::string_view dim : allMessages(shape, kShapeDim, source))
  {
    long long value = -1;
    FieldReader reader(dim, source);
    Field field;
    while (reader.next(field))
    {
      if (field.number == kDimValue && field.wire_type == kVarint)
      {
        const auto signed_value = static_cast<long long>(field.value);
        value = signed_value > 0 ? signed_value : -1;
      }
    }
    dims.push_back(value);
  }
  return dims;
}

}  // namespace

cv::Size OnnxInputInfo::imageSize() const
{
  constexpr long long kMaxSide = 1 << 20;
  if (shape.size() != 4 || shape[2] <= 0 || shape[3] <= 0 || shape[2] > kMaxSide || shape[3] > kMaxSide)
  {
    return {};
  }
  return {static_cast<int>(shape[3]), static_cast<int>(shape[2])};
}

OnnxInputInfo parseOnnxInput(const std::string& bytes, const std::string& source)
{
  const std::string_view graph = firstMessage(bytes, kModelGraph, source);
  if (graph.empty())
  {
    throw YoloModelError(source + ": not an ONNX model (no graph)");
  }
  std::set<std::string_view> initializers;  // weights some exporters also list as inputs
  for (const std::string_view tensor : allMessages(graph, kGraphInitializer, source))
  {
    initializers.insert(firstMessage(tensor, kTensorName, source));
  }
  for (const std::string_view input : allMessages(graph, kGraphInput, source))
  {
    const std::string_view name = firstMessage(input, kValueInfoName, source);
    if (initializers.count(name) != 0)
    {
      continue;
    }
    const std::string_view tensor_type =
        firstMessage(firstMessage(input, kValueInfoType, source), kTypeTensor, source);
    OnnxInputInfo info;
    info.name = std::string(name);
    info.shape = shapeOf(firstMessage(tensor_type, kTensorTypeShape, source), source);
    return info;
  }
  throw YoloModelError(source + ": the ONNX graph declares no input");
}

OnnxInputInfo readOnnxInput(const std::string& onnx_path)
{
  std::ifstream file(onnx_path, std::ios::binary);
  if (!file)
  {
    throw YoloModelError(onnx_path + ": cannot open the ONNX model file");
  }
  std::ostringstream bytes;
  bytes << file.rdbuf();
  if (file.bad())
  {
    throw YoloModelError(onnx_path + ": cannot read the ONNX model file");
  }
  return parseOnnxInput(bytes.str(), onnx_path);
}

}  // namespace grid_vision_fusion
