// The parameter machinery: where parameters come from (the parameter server on line, the very
// same YAML files off line), typed reading that refuses wrong types, the reader that a node's
// parameter table (node_params.h) is visited with, and the warning for a misspelt key.
#pragma once

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace grid_vision_fusion
{
/// Where parameters come from. Names are relative ("band_above") and may be nested with '/'
/// ("replay/class_map"); a leading '~' is ignored.
class ParamSource
{
public:
  virtual ~ParamSource() = default;
  /// The value of `name` when it is set (false when it is not).
  virtual bool get(const std::string& name, XmlRpc::XmlRpcValue& value) const = 0;
  /// `name` as the user sees it in an error message: the resolved name on the parameter server
  /// ("/fusion/band_above"), or "<file>:band_above" for a YAML file.
  virtual std::string describe(const std::string& name) const = 0;
  /// The names of every parameter set, relative and '/'-separated ("replay/class_map/Car").
  virtual std::vector<std::string> names() const = 0;
};

/// The private parameters of a node handle (the parameter server).
class NodeHandleParamSource : public ParamSource
{
public:
  explicit NodeHandleParamSource(const ros::NodeHandle& nh) : nh_(nh) {}
  bool get(const std::string& name, XmlRpc::XmlRpcValue& value) const override;
  std::string describe(const std::string& name) const override;
  std::vector<std::string> names() const override;

private:
  const ros::NodeHandle& nh_;
};

/// The parameters of a YAML file such as config/fusion.yaml, typed as `rosparam load` types
/// them: true/false/yes/no/on/off → bool, integers → int, other numbers (with .inf, .nan) →
/// double, quoted scalars and everything else → string, sequences → arrays, maps → structs.
class YamlParamSource : public ParamSource
{
public:
  /// An empty source (every parameter unset); `origin` names it in error messages.
  explicit YamlParamSource(std::string origin = "<yaml>");
  /// @throws std::runtime_error naming the file when it cannot be read or parsed, or when its
  /// top level is not a map.
  static YamlParamSource fromFile(const std::string& path);
  /// @throws std::runtime_error naming `origin` when `text` is not YAML or not a map.
  static YamlParamSource fromString(const std::string& text, const std::string& origin = "<yaml>");

  bool get(const std::string& name, XmlRpc::XmlRpcValue& value) const override;
  std::string describe(const std::string& name) const override;
  std::vector<std::string> names() const override;
  /// Sets (or overrides) `name`, creating the nested maps on the way, as a `<param>` after a
  /// `<rosparam command="load">` does in a launch file.
  void set(const std::string& name, const XmlRpc::XmlRpcValue& value);

private:
  std::string origin_;
  XmlRpc::XmlRpcValue root_;
};

/// Conversions of a parameter value, shared by every source: bool from a bool only; int from an
/// int or an integral double (2.0; 2.5 is refused); uint32 likewise and >= 0; double from a
/// double or an int; string from a string only; a map of strings or of doubles from a struct
/// whose every entry converts so. False when the type does not fit. (Enumerations convert from
/// their names, see node_params.h; such a conversion throws std::invalid_argument listing the
/// valid names.)
bool paramValueAs(const XmlRpc::XmlRpcValue& value, bool& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, int& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::uint32_t& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, double& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::string& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::map<std::string, std::string>& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::map<std::string, double>& out);

/// The value of a parameter as the parameter server holds it (the inverse of paramValueAs()).
XmlRpc::XmlRpcValue toParamValue(bool value);
XmlRpc::XmlRpcValue toParamValue(int value);
XmlRpc::XmlRpcValue toParamValue(std::uint32_t value);
XmlRpc::XmlRpcValue toParamValue(double value);
XmlRpc::XmlRpcValue toParamValue(const std::string& value);
XmlRpc::XmlRpcValue toParamValue(const std::map<std::string, std::string>& value);
XmlRpc::XmlRpcValue toParamValue(const std::map<std::string, double>& value);

/// Reads parameter `name` of `source` into `value` when it is set; leaves `value` (the default)
/// untouched when it is not. @throws std::invalid_argument when it is set with a type that
/// does not convert to T (e.g. a string for a double, an unknown name for an enumeration),
/// naming the parameter.
template <typename T>
void readParam(const ParamSource& source, const std::string& name, T& value)
{
  XmlRpc::XmlRpcValue raw;
  if (!source.get(name, raw))
  {
    return;
  }
  T read{};
  bool converted = false;
  try
  {
    converted = paramValueAs(raw, read);
  }
  catch (const std::invalid_argument& e)
  {
    throw std::invalid_argument("parameter " + source.describe(name) + ": " + e.what());
  }
  if (!converted)
  {
    throw std::invalid_argument("parameter " + source.describe(name) + " has the wrong type");
  }
  value = read;
}

/// The visitor that reads a parameter table (visitParams() of node_params.h) from a source and
/// remembers the names it was asked for, to find the source's parameters that nothing reads.
class ParamReader
{
public:
  explicit ParamReader(const ParamSource& source) : source_(source) {}

  /// Reads `name` into `value` when it is set (readParam()).
  template <typename T>
  void operator()(const std::string& name, T& value)
  {
    known_.push_back(name);
    readParam(source_, name, value);
  }
  /// A parameter of the node that a ROS library reads itself (e.g. image_transport): known, not read.
  void foreign(const std::string& name) { known_.push_back(name); }

  const ParamSource& source() const { return source_; }
  /// One warning per parameter of the source that no operator() or foreign() named (a map
  /// parameter's entries belong to it), with the nearest known name: "unknown parameter
  /// /fusion/band_abvoe ignored (did you mean band_above?)".
  std::vector<std::string> unknownParams() const;

private:
  const ParamSource& source_;
  std::vector<std::string> known_;
};

/// The visitor that collects the values of a parameter table (its defaults, when visited on a
/// default-constructed table) as parameter values, by name.
class ParamValues
{
public:
  template <typename T>
  void operator()(const std::string& name, const T& value)
  {
    values[name] = toParamValue(value);
  }
  void foreign(const std::string& /*name*/) {}

  std::map<std::string, XmlRpc::XmlRpcValue> values;
};

/// The name of `candidates` nearest to `name` by edit distance ("" when there is none).
std::string nearestName(const std::string& name, const std::vector<std::string>& candidates);

}  // namespace grid_vision_fusion
