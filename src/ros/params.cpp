#include "grid_vision_fusion/ros/params.h"

#include <ros/param.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <vector>

namespace grid_vision_fusion
{
namespace
{
/// "~a/b//c" → {"a", "b", "c"}.
std::vector<std::string> splitName(const std::string& name)
{
  std::vector<std::string> parts;
  std::string part;
  for (const char c : name)
  {
    if (c == '/')
    {
      if (!part.empty())
      {
        parts.push_back(part);
      }
      part.clear();
    }
    else if (!(c == '~' && parts.empty() && part.empty()))
    {
      part += c;
    }
  }
  if (!part.empty())
  {
    parts.push_back(part);
  }
  return parts;
}

bool isYamlBool(const std::string& text, bool& value)
{
  static const char* const kTrue[] = {"true", "True", "TRUE", "yes", "Yes", "YES", "on", "On", "ON"};
  static const char* const kFalse[] = {"false", "False", "FALSE", "no", "No", "NO", "off", "Off", "OFF"};
  for (const char* t : kTrue)
  {
    if (text == t)
    {
      value = true;
      return true;
    }
  }
  for (const char* f : kFalse)
  {
    if (text == f)
    {
      value = false;
      return true;
    }
  }
  return false;
}

bool isYamlInt(const std::string& text, int& value)
{
  if (text.empty())
  {
    return false;
  }
  const bool hex = text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X');
  for (std::size_t i = hex ? 2 : 0; i < text.size(); ++i)
  {
    const char c = text[i];
    const bool sign = i == 0 && (c == '-' || c == '+');
    if (!sign &&
        !(hex ? std::isxdigit(static_cast<unsigned char>(c)) : std::isdigit(static_cast<unsigned char>(c))))
    {
      return false;
    }
  }
  errno = 0;
  char* end = nullptr;
  const long long parsed = std::strtoll(text.c_str(), &end, hex ? 16 : 10);
  if (errno != 0 || *end != '\0' || parsed < std::numeric_limits<int>::min() ||
      parsed > std::numeric_limits<int>::max())
  {
    return false;
  }
  value = static_cast<int>(parsed);
  return true;
}

bool isYamlDouble(const std::string& text, double& value)
{
  static const char* const kInf[] = {".inf", ".Inf", ".INF", "+.inf", "+.Inf", "+.INF"};
  static const char* const kMinusInf[] = {"-.inf", "-.Inf", "-.INF"};
  static const char* const kNan[] = {".nan", ".NaN", ".NAN"};
  for (const char* t : kInf)
  {
    if (text == t)
    {
      value = std::numeric_limits<double>::infinity();
      return true;
    }
  }
  for (const char* t : kMinusInf)
  {
    if (text == t)
    {
      value = -std::numeric_limits<double>::infinity();
      return true;
    }
  }
  for (const char* t : kNan)
  {
    if (text == t)
    {
      value = std::numeric_limits<double>::quiet_NaN();
      return true;
    }
  }
  // Digits, one sign, '.', exponent: no "inf"/"nan"/hex floats spelled the C way.
  bool digit = false;
  for (const char c : text)
  {
    if (std::isdigit(static_cast<unsigned char>(c)))
    {
      digit = true;
    }
    else if (c != '.' && c != '-' && c != '+' && c != 'e' && c != 'E')
    {
      return false;
    }
  }
  if (!digit)
  {
    return false;
  }
  char* end = nullptr;
  value = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0';
}

/// A YAML node as the XmlRpc value `rosparam load` would set. `where` names it for errors.
XmlRpc::XmlRpcValue toXmlRpc(const YAML::Node& node, const std::string& where)
{
  switch (node.Type())
  {
    case YAML::NodeType::Map:
    {
      XmlRpc::XmlRpcValue out;
      out.begin();  // makes it an (empty) struct
      for (const auto& entry : node)
      {
        const std::string key = entry.first.as<std::string>();
        out[key] = toXmlRpc(entry.second, where + "/" + key);
      }
      return out;
    }
    case YAML::NodeType::Sequence:
    {
      XmlRpc::XmlRpcValue out;
      out.setSize(static_cast<int>(node.size()));
      for (std::size_t i = 0; i < node.size(); ++i)
      {
        out[static_cast<int>(i)] = toXmlRpc(node[i], where + "[" + std::to_string(i) + "]");
      }
      return out;
    }
    case YAML::NodeType::Scalar:
    {
      const std::string& text = node.Scalar();
      if (node.Tag() == "!")  // quoted: always a string
      {
        return XmlRpc::XmlRpcValue(text);
      }
      bool b = false;
      int i = 0;
      double d = 0.0;
      if (isYamlBool(text, b))
      {
        return XmlRpc::XmlRpcValue(b);
      }
      if (isYamlInt(text, i))
      {
        return XmlRpc::XmlRpcValue(i);
      }
      if (isYamlDouble(text, d))
      {
        return XmlRpc::XmlRpcValue(d);
      }
      return XmlRpc::XmlRpcValue(text);
    }
    case YAML::NodeType::Null:
    case YAML::NodeType::Undefined:
    default:
      return XmlRpc::XmlRpcValue();  // TypeInvalid: no parameter type fits it
  }
}
}  // namespace

// --- NodeHandleParamSource -------------------------------------------------------------------

bool NodeHandleParamSource::get(const std::string& name, XmlRpc::XmlRpcValue& value) const
{
  return nh_.hasParam(name) && nh_.getParam(name, value);
}

std::string NodeHandleParamSource::describe(const std::string& name) const
{
  return nh_.resolveName(name);
}

std::vector<std::string> NodeHandleParamSource::names() const
{
  std::vector<std::string> all;
  ros::param::getParamNames(all);
  const std::string prefix = nh_.getNamespace() + "/";
  std::vector<std::string> out;
  for (const std::string& name : all)
  {
    if (name.rfind(prefix, 0) == 0)
    {
      out.push_back(name.substr(prefix.size()));
    }
  }
  return out;
}

// --- YamlParamSource -------------------------------------------------------------------------

YamlParamSource::YamlParamSource(std::string origin) : origin_(std::move(origin))
{
  root_.begin();
}

YamlParamSource YamlParamSource::fromFile(const std::string& path)
{
  YAML::Node node;
  try
  {
    node = YAML::LoadFile(path);
  }
  catch (const YAML::BadFile&)
  {
    throw std::runtime_error("cannot read the parameter file " + path);
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error("parameter file " + path + " is not valid YAML: " + e.what());
  }
  YamlParamSource source(path);
  if (node.IsNull())
  {
    return source;  // an empty file: every parameter at its default
  }
  if (!node.IsMap())
  {
    throw std::runtime_error("parameter file " + path + " must hold a map of parameters at its top level");
  }
  source.root_ = toXmlRpc(node, "");
  return source;
}

YamlParamSource YamlParamSource::fromString(const std::string& text, const std::string& origin)
{
  YAML::Node node;
  try
  {
    node = YAML::Load(text);
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error("parameters " + origin + " are not valid YAML: " + e.what());
  }
  YamlParamSource source(origin);
  if (node.IsNull())
  {
    return source;
  }
  if (!node.IsMap())
  {
    throw std::runtime_error("parameters " + origin + " must be a map at the top level");
  }
  source.root_ = toXmlRpc(node, "");
  return source;
}

bool YamlParamSource::get(const std::string& name, XmlRpc::XmlRpcValue& value) const
{
  const std::vector<std::string> parts = splitName(name);
  if (parts.empty())
  {
    return false;
  }
  // XmlRpcValue's const accessors are few; walk a copy-free chain of pointers.
  const XmlRpc::XmlRpcValue* node = &root_;
  for (const std::string& part : parts)
  {
    if (node->getType() != XmlRpc::XmlRpcValue::TypeStruct || !node->hasMember(part))
    {
      return false;
    }
    node = &(*const_cast<XmlRpc::XmlRpcValue*>(node))[part];
  }
  value = *node;
  return true;
}

namespace
{
void collectNames(const XmlRpc::XmlRpcValue& node, const std::string& prefix, std::vector<std::string>& out)
{
  auto& struct_node = const_cast<XmlRpc::XmlRpcValue&>(node);
  for (auto it = struct_node.begin(); it != struct_node.end(); ++it)
  {
    const std::string name = prefix + it->first;
    if (it->second.getType() == XmlRpc::XmlRpcValue::TypeStruct && it->second.size() > 0)
    {
      collectNames(it->second, name + "/", out);
    }
    else
    {
      out.push_back(name);
    }
  }
}
}  // namespace

std::vector<std::string> YamlParamSource::names() const
{
  std::vector<std::string> out;
  collectNames(root_, "", out);
  return out;
}

std::string YamlParamSource::describe(const std::string& name) const
{
  const std::vector<std::string> parts = splitName(name);
  std::string joined;
  for (const std::string& part : parts)
  {
    joined += (joined.empty() ? "" : "/") + part;
  }
  return origin_ + ":" + joined;
}

void YamlParamSource::set(const std::string& name, const XmlRpc::XmlRpcValue& value)
{
  const std::vector<std::string> parts = splitName(name);
  if (parts.empty())
  {
    throw std::invalid_argument("cannot set a parameter with an empty name in " + origin_);
  }
  XmlRpc::XmlRpcValue* node = &root_;
  for (std::size_t i = 0; i + 1 < parts.size(); ++i)
  {
    XmlRpc::XmlRpcValue& child = (*node)[parts[i]];
    if (child.getType() != XmlRpc::XmlRpcValue::TypeStruct)
    {
      child = XmlRpc::XmlRpcValue();
      child.begin();
    }
    node = &child;
  }
  (*node)[parts.back()] = value;
}

// --- conversions -----------------------------------------------------------------------------

bool paramValueAs(const XmlRpc::XmlRpcValue& value, bool& out)
{
  if (value.getType() != XmlRpc::XmlRpcValue::TypeBoolean)
  {
    return false;
  }
  out = static_cast<bool>(const_cast<XmlRpc::XmlRpcValue&>(value));
  return true;
}

bool paramValueAs(const XmlRpc::XmlRpcValue& value, int& out)
{
  auto& v = const_cast<XmlRpc::XmlRpcValue&>(value);
  if (v.getType() == XmlRpc::XmlRpcValue::TypeInt)
  {
    out = static_cast<int>(v);
    return true;
  }
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble)
  {
    const double d = static_cast<double>(v);
    if (std::isfinite(d) && d == std::floor(d) && d >= std::numeric_limits<int>::min() &&
        d <= std::numeric_limits<int>::max())
    {
      out = static_cast<int>(d);
      return true;
    }
  }
  return false;
}

bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::uint32_t& out)
{
  int read = 0;
  if (!paramValueAs(value, read) || read < 0)
  {
    return false;
  }
  out = static_cast<std::uint32_t>(read);
  return true;
}

bool paramValueAs(const XmlRpc::XmlRpcValue& value, double& out)
{
  auto& v = const_cast<XmlRpc::XmlRpcValue&>(value);
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble)
  {
    out = static_cast<double>(v);
    return true;
  }
  if (v.getType() == XmlRpc::XmlRpcValue::TypeInt)
  {
    out = static_cast<int>(v);
    return true;
  }
  return false;
}

bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::string& out)
{
  if (value.getType() != XmlRpc::XmlRpcValue::TypeString)
  {
    return false;
  }
  out = static_cast<std::string>(const_cast<XmlRpc::XmlRpcValue&>(value));
  return true;
}

namespace
{
/// A struct whose every entry converts to T, as a map; false (and `out` untouched) otherwise.
template <typename T>
bool paramValueAsMap(const XmlRpc::XmlRpcValue& value, std::map<std::string, T>& out)
{
  if (value.getType() != XmlRpc::XmlRpcValue::TypeStruct)
  {
    return false;
  }
  auto& v = const_cast<XmlRpc::XmlRpcValue&>(value);
  std::map<std::string, T> read;
  for (auto it = v.begin(); it != v.end(); ++it)
  {
    if (!paramValueAs(it->second, read[it->first]))
    {
      return false;
    }
  }
  out = std::move(read);
  return true;
}

template <typename T>
XmlRpc::XmlRpcValue toParamValueMap(const std::map<std::string, T>& value)
{
  XmlRpc::XmlRpcValue out;
  out.begin();  // an (empty) struct
  for (const auto& [key, entry] : value)
  {
    out[key] = toParamValue(entry);
  }
  return out;
}
}  // namespace

bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::map<std::string, std::string>& out)
{
  return paramValueAsMap(value, out);
}

bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::map<std::string, double>& out)
{
  return paramValueAsMap(value, out);
}

XmlRpc::XmlRpcValue toParamValue(bool value)
{
  return XmlRpc::XmlRpcValue(value);
}
XmlRpc::XmlRpcValue toParamValue(int value)
{
  return XmlRpc::XmlRpcValue(value);
}
XmlRpc::XmlRpcValue toParamValue(std::uint32_t value)
{
  return XmlRpc::XmlRpcValue(static_cast<int>(value));
}
XmlRpc::XmlRpcValue toParamValue(double value)
{
  return XmlRpc::XmlRpcValue(value);
}
XmlRpc::XmlRpcValue toParamValue(const std::string& value)
{
  return XmlRpc::XmlRpcValue(value);
}

XmlRpc::XmlRpcValue toParamValue(const std::map<std::string, std::string>& value)
{
  return toParamValueMap(value);
}

XmlRpc::XmlRpcValue toParamValue(const std::map<std::string, double>& value)
{
  return toParamValueMap(value);
}

// --- unknown parameters ----------------------------------------------------------------------

std::string nearestName(const std::string& name, const std::vector<std::string>& candidates)
{
  std::string best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> row;
  for (const std::string& candidate : candidates)
  {
    // Levenshtein distance, one row at a time.
    row.resize(candidate.size() + 1);
    for (std::size_t j = 0; j <= candidate.size(); ++j)
    {
      row[j] = j;
    }
    for (std::size_t i = 1; i <= name.size(); ++i)
    {
      std::size_t diagonal = row[0];
      row[0] = i;
      for (std::size_t j = 1; j <= candidate.size(); ++j)
      {
        const std::size_t above = row[j];
        row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (name[i - 1] == candidate[j - 1] ? 0 : 1)});
        diagonal = above;
      }
    }
    if (row.back() < best_distance)
    {
      best_distance = row.back();
      best = candidate;
    }
  }
  return best;
}

std::vector<std::string> ParamReader::unknownParams() const
{
  std::vector<std::string> warnings;
  for (const std::string& name : source_.names())
  {
    const bool known =
        std::any_of(known_.begin(), known_.end(),
                    [&](const std::string& k) { return name == k || name.rfind(k + "/", 0) == 0; });
    if (!known)
    {
      warnings.push_back("unknown parameter " + source_.describe(name) + " ignored (did you mean " +
                         nearestName(name, known_) + "?)");
    }
  }
  return warnings;
}

}  // namespace grid_vision_fusion
