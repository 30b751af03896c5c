// The YAML parameter source: the nodelets' Config functions filled from YAML without a master,
// typed as rosparam types them, wrong types refused naming the parameter.
#include <gtest/gtest.h>

#include <cmath>

#include "grid_vision_fusion/offline/pipeline.h"
#include "grid_vision_fusion/ros/node_params.h"
#include "grid_vision_fusion/ros/params.h"

namespace grid_vision_fusion
{
namespace
{
const std::string kConfigDir = std::string(GVF_SOURCE_DIR) + "/config";

/// The message of the std::invalid_argument `f` throws ("" when it throws nothing).
template <typename F>
std::string invalidArgument(F f)
{
  try
  {
    f();
  }
  catch (const std::invalid_argument& e)
  {
    return e.what();
  }
  return "";
}

TEST(YamlParamSource, ScalarsAreTypedAsRosparamTypesThem)
{
  const YamlParamSource p = YamlParamSource::fromString(
      "a_bool: yes\nb_bool: False\nan_int: -42\nhex: 0x1F\na_double: 2.5\nexp: 1.0e-3\ninf: .inf\n"
      "quoted_int: '7'\ntext: hello world\n",
      "test.yaml");
  bool b = false;
  readParam(p, "a_bool", b);
  EXPECT_TRUE(b);
  readParam(p, "b_bool", b);
  EXPECT_FALSE(b);
  int i = 0;
  readParam(p, "an_int", i);
  EXPECT_EQ(i, -42);
  readParam(p, "hex", i);
  EXPECT_EQ(i, 31);
  double d = 0.0;
  readParam(p, "a_double", d);
  EXPECT_EQ(d, 2.5);
  readParam(p, "exp", d);
  EXPECT_DOUBLE_EQ(d, 1e-3);
  readParam(p, "inf", d);
  EXPECT_TRUE(std::isinf(d) && d > 0);
  std::string s;
  readParam(p, "quoted_int", s);  // quoted: a string, not an int
  EXPECT_EQ(s, "7");
  readParam(p, "text", s);
  EXPECT_EQ(s, "hello world");
}

TEST(YamlParamSource, UnsetKeepsTheDefaultAndIntIsAcceptedForDouble)
{
  const YamlParamSource p = YamlParamSource::fromString("count: 3\n", "test.yaml");
  double d = 1.5;
  readParam(p, "missing", d);
  EXPECT_EQ(d, 1.5);
  readParam(p, "count", d);  // an int where a double is wanted: 3.0, as on the parameter server
  EXPECT_EQ(d, 3.0);
}

TEST(YamlParamSource, WrongTypesAreRefusedNamingTheParameter)
{
  const YamlParamSource p = YamlParamSource::fromString(
      "word: fast\nhalf: 2.5\nwhole: 4.0\nflag: 1\nnested: {inner: {leaf: [1, 2]}}\nempty:\n", "my.yaml");
  double d = 0.0;
  EXPECT_EQ(invalidArgument([&] { readParam(p, "word", d); }), "parameter my.yaml:word has the wrong type");
  int i = 0;
  EXPECT_NE(invalidArgument([&] { readParam(p, "half", i); }), "");  // 2.5 is not an int
  readParam(p, "whole", i);                                          // 4.0 is
  EXPECT_EQ(i, 4);
  bool b = false;
  EXPECT_NE(invalidArgument([&] { readParam(p, "flag", b); }), "");  // 1 is not a bool
  std::string s;
  EXPECT_EQ(invalidArgument([&] { readParam(p, "nested/inner/leaf", s); }),
            "parameter my.yaml:nested/inner/leaf has the wrong type");
  EXPECT_NE(invalidArgument([&] { readParam(p, "empty", d); }), "");  // null: no type fits
  std::map<std::string, std::string> map;
  EXPECT_NE(invalidArgument([&] { readParam(p, "nested", map); }), "");  // values are not strings
}

TEST(YamlParamSource, NestedKeysAndOverrides)
{
  YamlParamSource p = YamlParamSource::fromString(
      "replay:\n  file_pattern: \"%06d.txt\"\n  class_map:\n    Car: car\n    Van: van\n", "det.yaml");
  std::map<std::string, std::string> map;
  readParam(p, "replay/class_map", map);
  ASSERT_EQ(map.size(), 2U);
  EXPECT_EQ(map.at("Car"), "car");
  EXPECT_EQ(map.at("Van"), "van");
  std::string pattern;
  readParam(p, "~replay/file_pattern", pattern);
  EXPECT_EQ(pattern, "%06d.txt");
  p.set("replay/file_pattern", XmlRpc::XmlRpcValue(std::string("%010d.txt")));
  p.set("replay/directory", XmlRpc::XmlRpcValue(std::string("/data/label_2")));
  p.set("new/deep/value", XmlRpc::XmlRpcValue(3));
  readParam(p, "replay/file_pattern", pattern);
  EXPECT_EQ(pattern, "%010d.txt");
  map.clear();
  readParam(p, "replay/class_map", map);  // siblings survive the override
  EXPECT_EQ(map.size(), 2U);
  int i = 0;
  readParam(p, "new/deep/value", i);
  EXPECT_EQ(i, 3);
}

TEST(YamlParamSource, AMapOfNumbers)
{
  const YamlParamSource p =
      YamlParamSource::fromString("speeds: {pedestrian: 1.5, cyclist: 4}\nwords: {car: fast}\n", "m.yaml");
  std::map<std::string, double> speeds;
  readParam(p, "speeds", speeds);
  EXPECT_EQ(speeds,
            (std::map<std::string, double>{{"cyclist", 4.0}, {"pedestrian", 1.5}}));  // an int is a double
  EXPECT_EQ(invalidArgument([&] { readParam(p, "words", speeds); }),
            "parameter m.yaml:words has the wrong type");
  EXPECT_EQ(speeds.size(), 2U);  // kept when refused
  std::map<std::string, double> back;
  ASSERT_TRUE(paramValueAs(toParamValue(speeds), back));
  EXPECT_EQ(back, speeds);
}

TEST(YamlParamSource, FileErrorsNameTheFile)
{
  try
  {
    YamlParamSource::fromFile("/nonexistent/params.yaml");
    FAIL() << "no exception";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/params.yaml"), std::string::npos) << e.what();
  }
  EXPECT_THROW(YamlParamSource::fromString("[1, 2]", "list.yaml"), std::runtime_error);
  EXPECT_THROW(YamlParamSource::fromString("a: [1, 2", "broken.yaml"), std::runtime_error);
}

TEST(YamlParamSource, ThePackageConfigFilesGiveTheConfigsTheyDocument)
{
  const YamlParamSource grid = YamlParamSource::fromFile(kConfigDir + "/dynamic_grid.yaml");
  const DynamicGridConfig g = DynamicGridParams::fromParams(grid).filter;
  EXPECT_EQ(g.particle_count, 131072);
  EXPECT_EQ(g.seed, 42U);
  EXPECT_DOUBLE_EQ(g.resolution, 0.2);
  // The motion-evidence keys document the core defaults.
  const DynamicGridConfig defaults;
  EXPECT_EQ(g.vacated_to_dynamic, defaults.vacated_to_dynamic);
  EXPECT_DOUBLE_EQ(g.motion_window, defaults.motion_window);
  EXPECT_DOUBLE_EQ(g.motion_radius, defaults.motion_radius);
  EXPECT_DOUBLE_EQ(g.motion_memory, defaults.motion_memory);
  EXPECT_DOUBLE_EQ(g.unknown_to_dynamic_by_motion, defaults.unknown_to_dynamic_by_motion);
  EXPECT_DOUBLE_EQ(g.static_to_dynamic_by_motion, defaults.static_to_dynamic_by_motion);
  EXPECT_EQ(g.inherit_birth_velocity, defaults.inherit_birth_velocity);
  EXPECT_DOUBLE_EQ(g.propagation_rate, defaults.propagation_rate);
  EXPECT_DOUBLE_EQ(g.propagation_length, defaults.propagation_length);
  EXPECT_EQ(g.sensor_model.hit_neighbours_not_free, defaults.sensor_model.hit_neighbours_not_free);
  const YamlParamSource previous = YamlParamSource::fromString(
      "vacated_to_dynamic: false\nmotion_window: 0\npropagation_rate: 0.1\ninherit_birth_velocity: false\n"
      "hit_neighbours_not_free: false\nstatic_to_dynamic_by_motion: 0.05\n",
      "previous.yaml");
  const DynamicGridConfig p = DynamicGridParams::fromParams(previous).filter;
  EXPECT_FALSE(p.vacated_to_dynamic);
  EXPECT_DOUBLE_EQ(p.motion_window, 0.0);
  EXPECT_DOUBLE_EQ(p.propagation_rate, 0.1);
  EXPECT_FALSE(p.inherit_birth_velocity);
  EXPECT_FALSE(p.sensor_model.hit_neighbours_not_free);
  EXPECT_DOUBLE_EQ(p.static_to_dynamic_by_motion, 0.05);
  const DynamicGridParams gn = DynamicGridParams::fromParams(grid);
  EXPECT_EQ(gn.fixed_frame, "odom");

  YamlParamSource detector = YamlParamSource::fromFile(kConfigDir + "/yolo_detector.yaml");
  detector.set("backend", XmlRpc::XmlRpcValue(std::string("replay")));
  detector.set("replay/directory", XmlRpc::XmlRpcValue(std::string("/tmp")));
  const DetectionReplayConfig r = DetectorParams::fromParams(detector).replay;
  EXPECT_EQ(r.class_map.at("Person_sitting"), "pedestrian");
  EXPECT_EQ(r.file_pattern, "%06d.txt");

  const YamlParamSource projection = YamlParamSource::fromFile(kConfigDir + "/grid_projection.yaml");
  EXPECT_DOUBLE_EQ(GridProjectionParams::fromParams(projection).projection.occupied_threshold, 0.4);
  EXPECT_DOUBLE_EQ(GridProjectionParams::fromParams(projection).projection.min_dynamic_speed,
                   GridProjectionConfig{}.min_dynamic_speed);
  EXPECT_DOUBLE_EQ(GridProjectionParams::fromParams(projection).projection.mahalanobis_threshold,
                   GridProjectionConfig{}.mahalanobis_threshold);
  const GridProjectionParams pn = GridProjectionParams::fromParams(projection);
  EXPECT_EQ(pn.ground_frame, "velo_link");
  EXPECT_DOUBLE_EQ(pn.ground_height, -1.73);

  const YamlParamSource fusion = YamlParamSource::fromFile(kConfigDir + "/fusion.yaml");
  EXPECT_EQ(FusionParams::fromParams(fusion).fusion.min_points, 1);
}

TEST(YamlParamSource, ConfigFunctionsRefuseBadValuesNamingTheParameter)
{
  const YamlParamSource grid = YamlParamSource::fromString("seed: -1\n", "grid.yaml");
  EXPECT_NE(invalidArgument([&] { DynamicGridParams::fromParams(grid); }).find("grid.yaml:seed"),
            std::string::npos);
  const YamlParamSource wrong = YamlParamSource::fromString("particle_count: many\n", "grid.yaml");
  EXPECT_NE(invalidArgument([&] { DynamicGridParams::fromParams(wrong); }).find("grid.yaml:particle_count"),
            std::string::npos);
  const YamlParamSource frame = YamlParamSource::fromString("fixed_frame: ''\n", "grid.yaml");
  EXPECT_NE(invalidArgument([&] { DynamicGridParams::fromParams(frame); }).find("grid.yaml:fixed_frame"),
            std::string::npos);
  const YamlParamSource age = YamlParamSource::fromString("max_grid_age: 0\n", "proj.yaml");
  EXPECT_NE(invalidArgument([&] { GridProjectionParams::fromParams(age); }).find("proj.yaml:max_grid_age"),
            std::string::npos);
  const YamlParamSource det = YamlParamSource::fromString("backend: magic\n", "det.yaml");
  const YamlParamSource empty("empty.yaml");
  EXPECT_NE(
      invalidArgument([&] { pipelineConfigFromParams(empty, det, empty, empty); }).find("det.yaml:backend"),
      std::string::npos);
}

}  // namespace
}  // namespace grid_vision_fusion
