#include "grid_vision_fusion/detection/kitti_labels.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "grid_vision_fusion/cli/temporary_output.h"

namespace grid_vision_fusion
{
namespace
{
constexpr std::size_t kLabelFields = 15;

const char* const kFieldNames[] = {"type",  "truncated", "occluded",   "alpha", "left",   "top",
                                   "right", "bottom",    "height",     "width", "length", "x",
                                   "y",     "z",         "rotation_y", "score"};

[[noreturn]] void fail(const std::string& source, std::size_t line, const std::string& what)
{
  throw KittiLabelError(source + ":" + std::to_string(line) + ": " + what);
}

float toFloat(const std::string& token, std::size_t field, const std::string& source, std::size_t line)
{
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(token.c_str(), &end);
  if (end == token.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(value))
  {
    fail(source, line,
         std::string("field ") + std::to_string(field + 1) + " (" + kFieldNames[field] +
             ") is not a finite number: '" + token + "'");
  }
  return static_cast<float>(value);
}

int toInt(const std::string& token, std::size_t field, const std::string& source, std::size_t line)
{
  errno = 0;
  char* end = nullptr;
  const long value = std::strtol(token.c_str(), &end, 10);
  if (end == token.c_str() || *end != '\0' || errno == ERANGE || value < std::numeric_limits<int>::min() ||
      value > std::numeric_limits<int>::max())
  {
    fail(source, line,
         std::string("field ") + std::to_string(field + 1) + " (" + kFieldNames[field] +
             ") is not an integer: '" + token + "'");
  }
  return static_cast<int>(value);
}

}  // namespace

std::string lowerCase(std::string text)
{
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

std::vector<std::string> splitFields(const std::string& line)
{
  std::istringstream fields(line);
  std::vector<std::string> tokens;
  for (std::string token; fields >> token;)
  {
    tokens.push_back(token);
  }
  return tokens;
}

std::vector<KittiObjectLabel> parseKittiLabels(std::istream& input, const std::string& source_name)
{
  std::vector<KittiObjectLabel> labels;
  std::string text;
  std::size_t line = 0;
  while (std::getline(input, text))
  {
    ++line;
    const std::vector<std::string> tokens = splitFields(text);
    if (tokens.empty())
    {
      continue;
    }
    if (tokens.size() != kLabelFields && tokens.size() != kLabelFields + 1)
    {
      fail(source_name, line,
           "expected 15 fields (type truncated occluded alpha left top right bottom h w l x y z ry) "
           "or 16 with a score, got " +
               std::to_string(tokens.size()));
    }
    KittiObjectLabel label;
    label.type = tokens[0];
    label.truncated = toFloat(tokens[1], 1, source_name, line);
    label.occluded = toInt(tokens[2], 2, source_name, line);
    float* const numbers[] = {&label.alpha,  &label.left,   &label.top,   &label.right,
                              &label.bottom, &label.height, &label.width, &label.length,
                              &label.x,      &label.y,      &label.z,     &label.rotation_y};
    for (std::size_t i = 0; i < 12; ++i)
    {
      *numbers[i] = toFloat(tokens[3 + i], 3 + i, source_name, line);
    }
    if (tokens.size() == kLabelFields + 1)
    {
      label.score = toFloat(tokens[15], 15, source_name, line);
    }
    if (label.right < label.left || label.bottom < label.top)
    {
      std::ostringstream what;
      what << "box (left " << label.left << ", top " << label.top << ", right " << label.right << ", bottom "
           << label.bottom << ") has right < left or bottom < top";
      fail(source_name, line, what.str());
    }
    labels.push_back(std::move(label));
  }
  if (input.bad())
  {
    throw KittiLabelError(source_name + ": read error after line " + std::to_string(line));
  }
  return labels;
}

std::vector<KittiObjectLabel> readKittiLabels(const std::string& path)
{
  std::ifstream file(path);
  if (!file)
  {
    throw KittiLabelError(path + ": cannot open the KITTI label file");
  }
  return parseKittiLabels(file, path);
}

namespace
{
/// `value` in the shortest decimal form that reads back to the same float ("712.4", "-1000").
void appendNumber(std::string& line, float value, const char* field)
{
  if (!std::isfinite(value))
  {
    throw std::invalid_argument(std::string("KITTI label field ") + field + " is not finite");
  }
  char text[32];
  const std::to_chars_result written = std::to_chars(text, text + sizeof(text), value);
  line += ' ';
  line.append(text, written.ptr);
}

}  // namespace

std::string formatKittiLabel(const KittiObjectLabel& label)
{
  if (label.type.empty() ||
      std::any_of(label.type.begin(), label.type.end(), [](unsigned char c) { return std::isspace(c) != 0; }))
  {
    throw std::invalid_argument("KITTI label type must be one word, got \"" + label.type + "\"");
  }
  std::string line = label.type;
  appendNumber(line, label.truncated, "truncated");
  line += ' ' + std::to_string(label.occluded);
  const float numbers[] = {label.alpha, label.left,   label.top, label.right, label.bottom, label.height,
                           label.width, label.length, label.x,   label.y,     label.z,      label.rotation_y};
  for (std::size_t i = 0; i < 12; ++i)
  {
    appendNumber(line, numbers[i], kFieldNames[3 + i]);
  }
  if (label.score)
  {
    appendNumber(line, *label.score, "score");
  }
  return line;
}

void writeKittiLabels(const std::string& path, const std::vector<KittiObjectLabel>& labels)
{
  std::string text;
  for (const KittiObjectLabel& label : labels)
  {
    text += formatKittiLabel(label);
    text += '\n';
  }
  TemporaryOutput output(path);
  {
    std::ofstream file(output.temporary(), std::ios::binary);
    file << text;
    file.close();
    if (!file)
    {
      throw KittiLabelError(path + ": cannot write the KITTI label file");
    }
  }
  try
  {
    output.commit();
  }
  catch (const std::runtime_error& e)
  {
    throw KittiLabelError(path + ": cannot write the KITTI label file (" + e.what() + ")");
  }
}

}  // namespace grid_vision_fusion
