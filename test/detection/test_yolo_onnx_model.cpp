// YoloDetector on the real YOLOv5s that scripts/fetch_model.sh converts to ONNX (onnx_layout
// pixels, 640x192 and 640x640), on the KITTI object samples: the labelled cars and the truck are
// found. The weights are fetched at use time (GPL/AGPL): when the model is absent the tests are
// skipped with the command that fetches it (GVF_MODEL_DIR names another folder than
// ~/.cache/grid_vision_fusion/models).
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "grid_vision_fusion/detection/kitti_labels.h"
#include "grid_vision_fusion/detection/yolo_detector.h"

namespace grid_vision_fusion
{
namespace
{
namespace fs = std::filesystem;

const std::string kClassNames = std::string(GVF_MODEL_DIR) + "/coco.names";
const std::string kSamples = std::string(GVF_TEST_DATA_DIR) + "/kitti_object_samples";

/// The folder scripts/fetch_model.sh writes to: $GVF_MODEL_DIR, else the XDG cache.
fs::path fetchedModelDir()
{
  if (const char* dir = std::getenv("GVF_MODEL_DIR"); dir != nullptr && *dir != '\0')
  {
    return dir;
  }
  const char* cache = std::getenv("XDG_CACHE_HOME");
  const char* home = std::getenv("HOME");
  const fs::path base =
      cache != nullptr && *cache != '\0' ? fs::path(cache) : fs::path(home ? home : "") / ".cache";
  return base / "grid_vision_fusion" / "models";
}

double intersectionOverUnion(const BoundingBox& a, const BoundingBox& b)
{
  const double w = std::max(0.0, double(std::min(a.x_max, b.x_max)) - std::max(a.x_min, b.x_min));
  const double h = std::max(0.0, double(std::min(a.y_max, b.y_max)) - std::max(a.y_min, b.y_min));
  const double inter = w * h;
  const double uni = double(a.x_max - a.x_min) * (a.y_max - a.y_min) +
                     double(b.x_max - b.x_min) * (b.y_max - b.y_min) - inter;
  return uni > 0.0 ? inter / uni : 0.0;
}

class YoloOnnxModelTest : public ::testing::TestWithParam<cv::Size>
{
};

TEST_P(YoloOnnxModelTest, FindsTheLabelledKittiObjects)
{
  const cv::Size size = GetParam();
  const fs::path model = fetchedModelDir() / ("yolov5s-" + std::to_string(size.width) + "x" +
                                              std::to_string(size.height) + ".onnx");
  if (!fs::exists(model))
  {
    GTEST_SKIP() << model.string() << " is not there: fetch it with scripts/fetch_model.sh "
                 << (size == cv::Size(640, 192) ? "" : "--input 640x640 ") << "yolov5s";
  }
  YoloDetectorConfig config;
  config.model_path = model.string();
  config.class_names_path = kClassNames;
  config.onnx_layout = YoloOutputLayout::kPixels;
  config.score_threshold = 0.25;
  // No size given: the one the file declares ([1, 3, H, W]); the same given is accepted too.
  ASSERT_EQ(readOnnxInput(model.string()).shape, (std::vector<long long>{1, 3, size.height, size.width}));
  YoloDetector detector(config);
  ASSERT_EQ(detector.inputSize(), size);
  ASSERT_EQ(detector.classNames().size(), 80U);
  config.input_width = size.width;
  config.input_height = size.height;
  EXPECT_EQ(YoloDetector(config).inputSize(), size);

  // KITTI type -> the COCO classes that find it (a KITTI truck is often a "bus" to COCO).
  const std::map<std::string, std::set<std::string>> matching = {{"Car", {"car"}},
                                                                 {"Truck", {"truck", "bus"}},
                                                                 {"Pedestrian", {"person"}},
                                                                 {"Cyclist", {"person", "bicycle"}}};
  int checked = 0;
  for (const char* frame : {"000001", "000002"})
  {
    const cv::Mat image = cv::imread(kSamples + "/image_2/" + frame + ".png");
    ASSERT_FALSE(image.empty()) << frame;
    const std::vector<Detection> detections = detector.detect(image, PixelFormat::kBgr8);
    for (const KittiObjectLabel& label : readKittiLabels(kSamples + "/label_2/" + frame + ".txt"))
    {
      const auto classes = matching.find(label.type);
      if (classes == matching.end() || label.occluded >= 3)
      {
        continue;  // DontCare, Misc, and the cyclist of 000001 whose occlusion is unknown
      }
      const BoundingBox truth{label.left, label.top, label.right, label.bottom};
      double best = 0.0;
      for (const Detection& d : detections)
      {
        if (classes->second.count(d.label) > 0)
        {
          best = std::max(best, intersectionOverUnion(truth, d.box));
        }
      }
      EXPECT_GT(best, 0.5) << frame << " " << label.type << " at " << label.left << ", " << label.top;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 3);  // the truck and the car of 000001, the car of 000002
}

INSTANTIATE_TEST_SUITE_P(InputSizes, YoloOnnxModelTest,
                         ::testing::Values(cv::Size(640, 192), cv::Size(640, 640)),
                         [](const ::testing::TestParamInfo<cv::Size>& info) {
                           return "Input" + std::to_string(info.param.width) + "x" +
                                  std::to_string(info.param.height);
                         });

}  // namespace
}  // namespace grid_vision_fusion
