// Reading parameters into the core Config structs, refusing wrong types: from the parameter
// server (a ros::NodeHandle) on line, or from the very same YAML files off line (run_pipeline).
#pragma once

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <map>
#include <stdexcept>
#include <string>

#include "grid_vision_fusion/fusion/fusion.h"

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
};

/// The private parameters of a node handle (the parameter server).
class NodeHandleParamSource : public ParamSource
{
public:
  explicit NodeHandleParamSource(const ros::NodeHandle& nh) : nh_(nh) {}
  bool get(const std::string& name, XmlRpc::XmlRpcValue& value) const override;
  std::string describe(const std::string& name) const override;

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
  /// Sets (or overrides) `name`, creating the nested maps on the way, as a `<param>` after a
  /// `<rosparam command="load">` does in a launch file.
  void set(const std::string& name, const XmlRpc::XmlRpcValue& value);

private:
  std::string origin_;
  XmlRpc::XmlRpcValue root_;
};

/// Conversions of a parameter value, shared by every source: bool from a bool only; int from an
/// int or an integral double (2.0; 2.5 is refused); double from a double or an int; string from
/// a string only; map of strings from a struct of strings. False when the type does not fit.
bool paramValueAs(const XmlRpc::XmlRpcValue& value, bool& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, int& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, double& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::string& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::map<std::string, std::string>& out);

/// Reads parameter `name` of `source` into `value` when it is set; leaves `value` (the default)
/// untouched when it is not. @throws std::invalid_argument when it is set with a type that
/// does not convert to T (e.g. a string for a double), naming the parameter.
template <typename T>
void readParam(const ParamSource& source, const std::string& name, T& value)
{
  XmlRpc::XmlRpcValue raw;
  if (!source.get(name, raw))
  {
    return;
  }
  T read{};
  if (!paramValueAs(raw, read))
  {
    throw std::invalid_argument("parameter " + source.describe(name) + " has the wrong type");
  }
  value = read;
}

/// readParam() from the private parameters of `nh`.
template <typename T>
void readParam(const ros::NodeHandle& nh, const std::string& name, T& value)
{
  readParam(NodeHandleParamSource(nh), name, value);
}

/// FusionConfig from the parameters band_above, band_below, min_points, tie_rule,
/// exclusive_assignment. @throws std::invalid_argument on a wrong type or a value that
/// FusionConfig::validate() rejects.
FusionConfig fusionConfigFromParams(const ParamSource& params);
FusionConfig fusionConfigFromParams(const ros::NodeHandle& nh);

}  // namespace grid_vision_fusion
