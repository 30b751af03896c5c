// YOLO object detection (YOLOv3, YOLOv3-tiny, YOLOv4 Darknet models and ONNX exports) through
// OpenCV's DNN module: model loading with file checks, letterbox/resize preprocessing, decoding
// of every YOLO output layer, per-class non-maximum suppression, mapping back to the image.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include <cstddef>
#include <istream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "grid_vision_fusion/detection/detector.h"

namespace grid_vision_fusion
{
/// A model file that is missing, unreadable, truncated or does not match the other files;
/// what() names the file.
class YoloModelError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// How an image is fitted to the network input.
enum class ResizeMode
{
  kLetterbox,  ///< aspect ratio kept, centred, borders filled with grey 0.5 (as Darknet does)
  kStretch,    ///< plain resize to the input size (aspect ratio not kept)
};

/// Parses "letterbox" or "resize". @throws std::invalid_argument otherwise.
ResizeMode resizeModeFromString(const std::string& name);
/// The name parsed by resizeModeFromString().
std::string toString(ResizeMode mode);

/// Layout of the rows of a YOLO output blob: [cx, cy, w, h, objectness, class 0, class 1, ...].
enum class YoloOutputLayout
{
  /// OpenCV's Darknet region layer: box normalised to the network input (cx, cy, w, h in
  /// [0, 1]); class columns already equal objectness × class probability (and are zeroed below
  /// the [yolo] layer's `thresh`, 0.2 by default in OpenCV's importer).
  kOpenCvRegion,
  /// Common ONNX exports (e.g. ultralytics): box in network-input pixels; class columns are the
  /// class probabilities alone, the score is objectness × class probability.
  kPixels,
};

/// Parses "opencv_region" or "pixels". @throws std::invalid_argument otherwise.
YoloOutputLayout yoloOutputLayoutFromString(const std::string& name);
/// The name parsed by yoloOutputLayoutFromString().
std::string toString(YoloOutputLayout layout);

/// The kind of model a file is, by its name: a Darknet cfg (".cfg"), an ONNX model (".onnx").
enum class ModelFormat
{
  kDarknet,
  kOnnx,
  kUnknown,
};
ModelFormat modelFormat(const std::string& model_path);

/// Parameters of the detector.
struct YoloDetectorConfig
{
  /// Darknet `.cfg` or ONNX `.onnx` file (chosen by the extension).
  std::string model_path;
  /// Darknet `.weights` file; must be empty for an ONNX model.
  std::string weights_path;
  /// Class names, one per line (e.g. coco.names); their number must match the model.
  std::string class_names_path;
  /// Network input size [px]; 0 takes the model's own: the Darknet cfg's [net] size, the input
  /// an ONNX file declares (readOnnxInput()). An ONNX model with a fixed input runs at that size
  /// only: another size given is an error naming both. Darknet sizes must be multiples of 32 for
  /// YOLOv3/v4 (checked by OpenCV at the first forward pass). Range [0, 4096].
  int input_width = 0;
  int input_height = 0;
  /// How the image is fitted to the input size.
  ResizeMode resize_mode = ResizeMode::kLetterbox;
  /// Whether the network expects RGB channel order (Darknet models do; OpenCV images are BGR).
  bool network_rgb = true;
  /// Row layout of ONNX outputs (Darknet models always give kOpenCvRegion).
  YoloOutputLayout onnx_layout = YoloOutputLayout::kPixels;
  /// Detections with a score (objectness × class probability) below this are dropped. [0, 1].
  double score_threshold = kDefaultScoreThreshold;
  /// IoU above which the lower-scored of two boxes of the same class is suppressed. [0, 1].
  double nms_threshold = 0.45;
  /// OpenCV DNN backend: "opencv" (default), "cuda" or "inference_engine".
  std::string backend = "opencv";
  /// OpenCV DNN target: "cpu" (default), "opencl", "opencl_fp16", "cuda", "cuda_fp16".
  /// A backend/target that this OpenCV build lacks falls back to opencv/cpu with a warning.
  std::string target = "cpu";
  /// Class filter and renaming: model class name → published label (e.g. "truck" → "truck",
  /// "bus" → "van"). Empty: every class kept under its own name. Otherwise classes not in the
  /// map are dropped.
  std::map<std::string, std::string> class_map;
  /// Riders: model class of a vehicle that is ridden → label of the vehicle and its rider as one
  /// box (e.g. "bicycle" → "cyclist"). A box of such a class with a `rider_class` box over it
  /// (mergeRiders()) becomes one box of that label, published as it is (class_map does not
  /// apply to it); without a rider it stays a box of its own class, which class_map drops or
  /// renames like any other. Empty: no merging.
  std::map<std::string, std::string> rider_merge;
  /// Model class of the riders of rider_merge (COCO: "person").
  std::string rider_class = "person";

  /// @throws std::invalid_argument naming the first bad field.
  void validate() const;
};

/// The parameters of one weighted Darknet layer, in the order of the weights file: biases
/// (`outputs`), if batch-normalised scales, rolling means and rolling variances (`outputs`
/// each), then `weights` kernel values.
struct DarknetParamBlock
{
  int outputs = 0;
  std::size_t weights = 0;
  bool batch_normalize = false;
};

/// What a Darknet cfg describes, as far as loading needs it.
struct DarknetCfgInfo
{
  int input_width = 0;   ///< [net] width [px]
  int input_height = 0;  ///< [net] height [px]
  int input_channels = 0;
  int num_classes = -1;                   ///< `classes` of the [yolo]/[region] layers (-1: none)
  int yolo_layers = 0;                    ///< number of [yolo]/[region] sections
  std::size_t parameters = 0;             ///< float32 values the weights file must hold after its header
  std::vector<DarknetParamBlock> blocks;  ///< the weighted layers, in file order
};

/// Parses a Darknet cfg and counts the parameters of its layers (convolutional with optional
/// batch normalisation and groups, connected; shape-only layers: maxpool, avgpool, route with
/// groups, shortcut, upsample, reorg, yolo, region, dropout, softmax, sam, scale_channels).
/// @throws YoloModelError naming the file (and line) when it cannot be read, has no [net]
///         section, an unknown section, an inconsistent layer reference or [yolo] layers with
///         different class counts.
DarknetCfgInfo parseDarknetCfg(const std::string& cfg_path);
/// parseDarknetCfg() of a cfg read from `input`; errors name `source`.
DarknetCfgInfo parseDarknetCfg(std::istream& input, const std::string& source);

/// Size in bytes a Darknet weights file for `info` must have: its header (major, minor,
/// revision as int32, then `seen` as int64 from version 0.2 on, int32 before) and
/// 4 × info.parameters.
/// @throws YoloModelError naming `weights_path` when it is missing, unreadable, shorter than its
///         header, or its size differs from what `cfg_path` needs ("truncated" / "too long").
std::size_t checkDarknetWeights(const std::string& weights_path, const std::string& cfg_path,
                                const DarknetCfgInfo& info);
/// checkDarknetWeights() of a weights file open in `weights` (binary, seekable); errors name
/// `weights_source`.
std::size_t checkDarknetWeights(std::istream& weights, const std::string& weights_source,
                                const std::string& cfg_path, const DarknetCfgInfo& info);

/// The input an ONNX model declares: the first graph input that is not an initializer.
struct OnnxInputInfo
{
  std::string name;
  /// Its dimensions, outermost first ([1, 3, 192, 640] for yolov5s-640x192.onnx); -1 for a
  /// dimension left open (a named or absent dim_value).
  std::vector<long long> shape;

  /// The fixed input size of an NCHW image input ([n, 3, H, W] with H, W > 0); an empty size
  /// when the model leaves it open.
  cv::Size imageSize() const;
};

/// Reads the declared input of an ONNX model (the protobuf fields ModelProto.graph,
/// GraphProto.input/initializer, ValueInfoProto.type.tensor_type.shape), without OpenCV.
/// @throws YoloModelError naming the file when it cannot be read, is not a well-formed ONNX
///         protobuf or declares no input.
OnnxInputInfo readOnnxInput(const std::string& onnx_path);
/// readOnnxInput() of the bytes of a model; errors name `source`.
OnnxInputInfo parseOnnxInput(const std::string& bytes, const std::string& source);

/// Reads class names, one per line (trailing whitespace and CR removed, blank lines skipped).
/// @throws YoloModelError naming the file when it cannot be read or holds no name.
std::vector<std::string> readClassNames(const std::string& path);
/// readClassNames() of the names read from `input`; errors name `source`.
std::vector<std::string> parseClassNames(std::istream& input, const std::string& source);

/// The affine map between image pixels and network-input pixels: net = image · scale + pad.
struct InputTransform
{
  cv::Size image_size;
  cv::Size input_size;
  double scale_x = 1.0;
  double scale_y = 1.0;
  double pad_x = 0.0;      ///< left border [network px]
  double pad_y = 0.0;      ///< top border [network px]
  int resized_width = 0;   ///< image width once resized [network px]
  int resized_height = 0;  ///< image height once resized [network px]

  /// Letterbox: one scale min(W/w, H/h), the resized image centred (borders split evenly,
  /// the odd pixel right/bottom). Stretch: scale_x = W/w, scale_y = H/h, no border.
  /// @throws std::invalid_argument for an empty size.
  static InputTransform make(cv::Size image_size, cv::Size input_size, ResizeMode mode);

  /// A box in network-input pixels mapped to image pixels and clipped to [0, width] × [0, height].
  BoundingBox toImage(double x_min, double y_min, double x_max, double y_max) const;
};

/// One decoded, not yet suppressed box in network-input pixels.
struct YoloCandidate
{
  int class_id = 0;
  float score = 0.F;
  cv::Rect2d box;  ///< network-input pixels
};

/// Decodes every row of every output blob (any shape whose last dimension is 5 + num_classes)
/// into one candidate per class whose score reaches `score_threshold`.
/// @throws std::invalid_argument when a blob's last dimension is not 5 + num_classes.
std::vector<YoloCandidate> decodeYoloOutputs(const std::vector<cv::Mat>& outputs, YoloOutputLayout layout,
                                             cv::Size input_size, int num_classes, double score_threshold);

/// Per-class non-maximum suppression (cv::dnn::NMSBoxes per class id): returns the kept
/// candidates, by class then by decreasing score.
std::vector<YoloCandidate> suppressPerClass(const std::vector<YoloCandidate>& candidates,
                                            double score_threshold, double nms_threshold);

/// The boxes of a ridden vehicle and of its rider merged into one (YoloDetectorConfig::rider_merge),
/// and the boxes left as they were.
struct RiderMergeResult
{
  std::vector<Detection> riders;  ///< union boxes labelled by rider_merge, the higher score of the two
  std::vector<Detection> others;  ///< every other box, labels unchanged
};

/// Pairs each box whose label (a model class name) is a key of `vehicle_labels` with the
/// `rider_class` box that rides it, vehicles by decreasing score, each rider at most once: a
/// rider's horizontal centre lies within the vehicle box, its top above the vehicle's top and its
/// bottom more than a fifth of the vehicle's height below that top (the person sits on or stands
/// over it); of several, the one with the widest horizontal overlap.
RiderMergeResult mergeRiders(std::vector<Detection> detections, const std::string& rider_class,
                             const std::map<std::string, std::string>& vehicle_labels);

/// What the detector publishes of the boxes found, labelled by their model class names: riders
/// merged (mergeRiders()), then class_map applied to the other boxes, by decreasing score.
std::vector<Detection> publishedDetections(std::vector<Detection> detections,
                                           const YoloDetectorConfig& config);

/// A YOLO network ready to run. Not thread-safe: one detect() at a time.
class YoloDetector : public Detector
{
public:
  /// Validates `config`, checks and loads the model files, selects backend and target (falling
  /// back to OpenCV/CPU, see warnings()) and runs one forward pass to check the output shape
  /// against the class names.
  /// @throws std::invalid_argument for a bad config; YoloModelError naming the file for a
  ///         missing, unreadable, truncated or mismatched model file.
  explicit YoloDetector(const YoloDetectorConfig& config);

  /// Detects objects in `image` (CV_8UC3 for kBgr8/kRgb8, CV_8UC1 for kMono8). Boxes are in
  /// image pixels, clipped to the image; class_id indexes classNames(), label is the
  /// (renamed) class name. Sorted by decreasing score.
  /// @throws std::invalid_argument for an empty image or a type that does not match `format`.
  std::vector<Detection> detect(const cv::Mat& image, PixelFormat format);

  // Detector: detect() of the image's pixels.
  bool needsPixels() const override { return true; }
  std::vector<Detection> detect(const DetectorImage& image) override
  {
    return detect(image.pixels, image.format);
  }
  /// Changes the score and NMS thresholds. @throws std::invalid_argument outside [0, 1].
  void setThresholds(double score_threshold, double nms_threshold) override;
  /// "<model> (<n> classes), input WxH <resize mode>, <backend/target>".
  std::string description() const override;

  /// The network input blob (1×3×H×W, float32, [0, 1]) for `image`, as detect() builds it.
  cv::Mat makeInputBlob(const cv::Mat& image, PixelFormat format, InputTransform& transform) const;

  const YoloDetectorConfig& config() const { return config_; }
  const std::vector<std::string>& classNames() const { return class_names_; }
  cv::Size inputSize() const { return input_size_; }
  /// Floating-point operations of one forward pass (cv::dnn::Net::getFLOPS).
  std::int64_t flops();
  /// Backend/target fallbacks that happened while loading (empty when none).
  std::vector<std::string> warnings() const override { return warnings_; }
  /// "backend/target" actually used, e.g. "opencv/cpu".
  std::string backendDescription() const;

private:
  /// The input size of an ONNX model: the one it declares, or the one given where it leaves it
  /// open. @throws YoloModelError when neither is known or the two differ.
  cv::Size onnxInputSize(const OnnxInputInfo& input) const;
  void selectBackend();

  YoloDetectorConfig config_;
  std::vector<std::string> class_names_;
  cv::dnn::Net net_;
  std::vector<std::string> output_names_;
  cv::Size input_size_;
  YoloOutputLayout layout_ = YoloOutputLayout::kOpenCvRegion;
  std::string backend_used_ = "opencv";
  std::string target_used_ = "cpu";
  std::vector<std::string> warnings_;
};

/// Draws each detection as a rectangle with "label score" on `image` (CV_8UC3, BGR); the
/// colour depends on the class id.
void drawDetections(cv::Mat& image, const std::vector<Detection>& detections);

}  // namespace grid_vision_fusion
