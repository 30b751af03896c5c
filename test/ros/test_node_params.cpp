// The parameter tables of the four nodes against the files that repeat them: every key of the
// config/*.yaml files is known and holds the struct's default (or is one of the few settings the
// file makes on purpose), every parameter is in its file, the dynamic_reconfigure .cfg defaults
// equal the struct defaults; a misspelt key is reported with the nearest valid one.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "grid_vision_fusion/ros/node_params.h"

namespace grid_vision_fusion
{
namespace
{
const std::string kSource = GVF_SOURCE_DIR;

std::string readFile(const std::string& path)
{
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << "cannot read " << path;
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// Whether two parameter values are equal, an int equal to a double of the same value included
/// (YAML "10" for a double parameter).
bool sameValue(XmlRpc::XmlRpcValue a, XmlRpc::XmlRpcValue b)
{
  double x = 0.0;
  double y = 0.0;
  if (paramValueAs(a, x) && paramValueAs(b, y))
  {
    return x == y || std::abs(x - y) <= 1e-12 * std::max(std::abs(x), std::abs(y));
  }
  return a.toXml() == b.toXml();
}

/// The leaf names of a table: its parameters without the foreign ones.
template <typename Params>
std::set<std::string> tableNames()
{
  std::set<std::string> names;
  for (const auto& entry : paramValuesOf(Params{}))
  {
    names.insert(entry.first);
  }
  return names;
}

/// Checks config/<file> against the table Params: no unknown key, every parameter but `absent`
/// present, every value the default but those of `configured`, which must differ from it.
template <typename Params>
void expectYamlMatchesTable(const std::string& file, const std::set<std::string>& configured,
                            const std::set<std::string>& absent)
{
  SCOPED_TRACE(file);
  const YamlParamSource yaml = YamlParamSource::fromFile(kSource + "/config/" + file);
  Params read;
  ParamReader reader(yaml);
  visitParams(read, reader);
  EXPECT_EQ(reader.unknownParams(), std::vector<std::string>{});

  const auto defaults = paramValuesOf(Params{});
  for (const auto& [name, default_value] : defaults)
  {
    XmlRpc::XmlRpcValue in_file;
    const bool present = yaml.get(name, in_file);
    if (absent.count(name))
    {
      EXPECT_FALSE(present) << name << " is listed as absent from " << file;
      continue;
    }
    ASSERT_TRUE(present) << name << " (default " << XmlRpc::XmlRpcValue(default_value).toXml()
                         << ") is not documented in " << file;
    if (configured.count(name))
    {
      EXPECT_FALSE(sameValue(in_file, default_value))
          << name << " is listed as configured but holds the default";
    }
    else
    {
      EXPECT_TRUE(sameValue(in_file, default_value))
          << name << ": " << file << " says " << in_file.toXml() << ", the struct default is "
          << XmlRpc::XmlRpcValue(default_value).toXml();
    }
  }
}

TEST(NodeParams, TheYamlFilesHoldTheStructDefaults)
{
  expectYamlMatchesTable<DynamicGridParams>("dynamic_grid.yaml", {}, {});
  // The detector's file configures the COCO and KITTI class maps and the COCO riders; the model
  // files have no default.
  expectYamlMatchesTable<DetectorParams>("yolo_detector.yaml",
                                         {"class_map", "rider_merge", "replay/class_map"},
                                         {"model", "weights", "class_names", "replay/directory"});
  expectYamlMatchesTable<GridProjectionParams>("grid_projection.yaml", {}, {});
  expectYamlMatchesTable<FusionParams>("fusion.yaml", {}, {});
}

TEST(NodeParams, TheDetectorYamlPublishesCyclistsOnlyWithTheirRiders)
{
  // doc/nodelets/yolo_detector.md's rider_merge: with the package's configuration a rider over
  // a bicycle is one cyclist, a bicycle alone is dropped, a person alone is a pedestrian.
  YamlParamSource source = YamlParamSource::fromFile(kSource + "/config/yolo_detector.yaml");
  source.set("model", std::string("m.onnx"));  // the launch file's
  source.set("class_names", std::string("coco.names"));
  const YoloDetectorConfig config = DetectorParams::fromParams(source).yolo;
  const auto detection = [](const std::string& label, float score, BoundingBox box)
  {
    Detection d;
    d.label = label;
    d.score = score;
    d.box = box;
    return d;
  };
  const std::vector<Detection> published = publishedDetections(
      {detection("bicycle", 0.6F, {90, 100, 160, 170}), detection("person", 0.8F, {100, 40, 140, 150}),
       detection("bicycle", 0.9F, {400, 100, 460, 170}), detection("person", 0.5F, {300, 40, 340, 170}),
       detection("motorbike", 0.7F, {600, 100, 700, 170}), detection("person", 0.7F, {620, 30, 680, 140})},
      config);
  ASSERT_EQ(published.size(), 3U);
  EXPECT_EQ(published[0].label, "cyclist");
  EXPECT_FLOAT_EQ(published[0].box.y_min, 40.F);
  EXPECT_EQ(published[1].label, "cyclist");
  EXPECT_FLOAT_EQ(published[1].box.x_min, 600.F);
  EXPECT_EQ(published[2].label, "pedestrian");
  EXPECT_FLOAT_EQ(published[2].box.x_min, 300.F);
}

/// The gen.add() entries of a dynamic_reconfigure .cfg: name -> default.
std::map<std::string, XmlRpc::XmlRpcValue> reconfigureDefaults(const std::string& file)
{
  const std::string text = readFile(kSource + "/cfg/" + file);
  // gen.add("name", type, level, "description", default, min, max)
  const std::regex add(R"re(gen\.add\(\s*"(\w+)"\s*,\s*(\w+)\s*,\s*\d+\s*,\s*"[^"]*"\s*,\s*([^,\s]+))re");
  std::map<std::string, XmlRpc::XmlRpcValue> out;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), add); it != std::sregex_iterator(); ++it)
  {
    const std::string type = (*it)[2];
    const std::string value = (*it)[3];
    if (type == "double_t")
    {
      out[(*it)[1]] = XmlRpc::XmlRpcValue(std::stod(value));
    }
    else if (type == "int_t")
    {
      out[(*it)[1]] = XmlRpc::XmlRpcValue(std::stoi(value));
    }
    else if (type == "bool_t")
    {
      out[(*it)[1]] = XmlRpc::XmlRpcValue(value == "True");
    }
    else
    {
      out[(*it)[1]] = XmlRpc::XmlRpcValue(value);
    }
  }
  return out;
}

template <typename Params>
void expectReconfigureMatchesTable(const std::string& file, std::size_t expected_entries)
{
  SCOPED_TRACE(file);
  const auto entries = reconfigureDefaults(file);
  EXPECT_EQ(entries.size(), expected_entries) << "gen.add() entries parsed";
  const auto defaults = paramValuesOf(Params{});
  for (const auto& [name, value] : entries)
  {
    const auto found = defaults.find(name);
    ASSERT_NE(found, defaults.end()) << name << " is not a parameter of the node";
    EXPECT_TRUE(sameValue(value, found->second)) << name << ": the .cfg default differs from the struct's";
  }
}

TEST(NodeParams, ThePerFrameVerdictsOptionsAreCalledIgnoredWithTracking)
{
  FusionParams params;
  EXPECT_TRUE(params.perFrameOptionsIgnored().empty());  // defaults
  params.fusion.min_points = 3;
  params.fusion.tie_rule = TieRule::kUnknown;
  const std::vector<std::string> warnings = params.perFrameOptionsIgnored();
  ASSERT_EQ(warnings.size(), 2U);
  EXPECT_NE(warnings[0].find("~min_points is 3"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("~tracking: false"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[1].find("~tie_rule is unknown"), std::string::npos) << warnings[1];
  params.tracking = false;  // the paper's mode: they decide the verdict
  EXPECT_TRUE(params.perFrameOptionsIgnored().empty());
}

TEST(NodeParams, TheReconfigureDefaultsAreTheStructDefaults)
{
  expectReconfigureMatchesTable<DynamicGridParams>("DynamicGridReconfigure.cfg", 4);
  expectReconfigureMatchesTable<DetectorParams>("YoloDetectorReconfigure.cfg", 2);
  expectReconfigureMatchesTable<FusionParams>("FusionReconfigure.cfg", 2);
}

TEST(NodeParams, OneScoreThresholdForBothDetectorBackends)
{
  EXPECT_EQ(DetectorParams{}.yolo.score_threshold, DetectorParams{}.replay.score_threshold);
  YamlParamSource source = YamlParamSource::fromString("backend: replay\nscore_threshold: 0.3\n", "det.yaml");
  source.set("replay/directory", XmlRpc::XmlRpcValue(std::string("/tmp")));
  EXPECT_DOUBLE_EQ(DetectorParams::fromParams(source).replay.score_threshold, 0.3);
  const YamlParamSource unset =
      YamlParamSource::fromString("backend: replay\nreplay: {directory: /tmp}\n", "det.yaml");
  EXPECT_DOUBLE_EQ(DetectorParams::fromParams(unset).replay.score_threshold, kDefaultScoreThreshold);
}

TEST(NodeParams, AMisspeltKeyIsReportedWithTheNearestValidOne)
{
  const YamlParamSource source = YamlParamSource::fromString(
      "band_abvoe: 0.3\nmin_points: 2\nimage_transport: compressed\nfoo: {bar: 1}\n", "fusion.yaml");
  std::vector<std::string> unknown;
  const FusionParams params = FusionParams::fromParams(source, &unknown);
  EXPECT_EQ(params.fusion.min_points, 2);
  EXPECT_DOUBLE_EQ(params.fusion.band_above, FusionConfig{}.band_above);  // the misspelt key is not read
  ASSERT_EQ(unknown.size(), 2U) << "band_abvoe and foo/bar; image_transport belongs to image_transport";
  EXPECT_NE(unknown[0].find("fusion.yaml:band_abvoe"), std::string::npos) << unknown[0];
  EXPECT_NE(unknown[0].find("did you mean band_above?"), std::string::npos) << unknown[0];
  EXPECT_NE(unknown[1].find("fusion.yaml:foo/bar"), std::string::npos) << unknown[1];
}

TEST(NodeParams, MapEntriesBelongToTheirMapParameter)
{
  const YamlParamSource source = YamlParamSource::fromString(
      "backend: replay\nreplay: {directory: /tmp, class_map: {Car: car, Van: van}, first_idx: 3}\n",
      "det.yaml");
  std::vector<std::string> unknown;
  DetectorParams::fromParams(source, &unknown);
  ASSERT_EQ(unknown.size(), 1U);
  EXPECT_NE(unknown[0].find("replay/first_idx"), std::string::npos) << unknown[0];
  EXPECT_NE(unknown[0].find("did you mean replay/first_index?"), std::string::npos) << unknown[0];
}

TEST(NodeParams, NearestNameByEditDistance)
{
  EXPECT_EQ(nearestName("quue_size", {"lazy", "queue_size", "image_cache_size"}), "queue_size");
  EXPECT_EQ(nearestName("x", {}), "");
}

TEST(NodeParams, EnumerationsAreReadByNameAndRefusedNamingTheChoices)
{
  const YamlParamSource good = YamlParamSource::fromString("tie_rule: dynamic\n", "fusion.yaml");
  EXPECT_EQ(FusionParams::fromParams(good).fusion.tie_rule, TieRule::kDynamic);
  const YamlParamSource bad = YamlParamSource::fromString("tie_rule: maybe\n", "fusion.yaml");
  try
  {
    FusionParams::fromParams(bad);
    FAIL() << "tie_rule: maybe accepted";
  }
  catch (const std::invalid_argument& e)
  {
    const std::string what = e.what();
    EXPECT_NE(what.find("fusion.yaml:tie_rule"), std::string::npos) << what;
    EXPECT_NE(what.find("\"static\", \"dynamic\" or \"unknown\""), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace grid_vision_fusion
