#include "grid_vision_fusion/detection/yolo_detector.h"

#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace grid_vision_fusion
{
namespace
{
constexpr int kMaxInputSize = 4096;

bool endsWith(const std::string& text, const std::string& suffix)
{
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

int backendId(const std::string& name)
{
  if (name == "opencv")
  {
    return cv::dnn::DNN_BACKEND_OPENCV;
  }
  if (name == "cuda")
  {
    return cv::dnn::DNN_BACKEND_CUDA;
  }
  if (name == "inference_engine")
  {
    return cv::dnn::DNN_BACKEND_INFERENCE_ENGINE;
  }
  return -1;
}

int targetId(const std::string& name)
{
  if (name == "cpu")
  {
    return cv::dnn::DNN_TARGET_CPU;
  }
  if (name == "opencl")
  {
    return cv::dnn::DNN_TARGET_OPENCL;
  }
  if (name == "opencl_fp16")
  {
    return cv::dnn::DNN_TARGET_OPENCL_FP16;
  }
  if (name == "cuda")
  {
    return cv::dnn::DNN_TARGET_CUDA;
  }
  if (name == "cuda_fp16")
  {
    return cv::dnn::DNN_TARGET_CUDA_FP16;
  }
  return -1;
}

}  // namespace

YoloOutputLayout yoloOutputLayoutFromString(const std::string& name)
{
  if (name == "pixels")
  {
    return YoloOutputLayout::kPixels;
  }
  if (name == "opencv_region")
  {
    return YoloOutputLayout::kOpenCvRegion;
  }
  throw std::invalid_argument("onnx_layout must be \"pixels\" or \"opencv_region\", got \"" + name + "\"");
}

std::string toString(YoloOutputLayout layout)
{
  return layout == YoloOutputLayout::kPixels ? "pixels" : "opencv_region";
}

ResizeMode resizeModeFromString(const std::string& name)
{
  if (name == "letterbox")
  {
    return ResizeMode::kLetterbox;
  }
  if (name == "resize")
  {
    return ResizeMode::kStretch;
  }
  throw std::invalid_argument("resize mode must be \"letterbox\" or \"resize\", got \"" + name + "\"");
}

std::string toString(ResizeMode mode)
{
  return mode == ResizeMode::kLetterbox ? "letterbox" : "resize";
}

ModelFormat modelFormat(const std::string& model_path)
{
  if (endsWith(model_path, ".cfg"))
  {
    return ModelFormat::kDarknet;
  }
  return endsWith(model_path, ".onnx") ? ModelFormat::kOnnx : ModelFormat::kUnknown;
}

void YoloDetectorConfig::validate() const
{
  const bool darknet = modelFormat(model_path) == ModelFormat::kDarknet;
  const bool onnx = modelFormat(model_path) == ModelFormat::kOnnx;
  if (!darknet && !onnx)
  {
    throw std::invalid_argument("model must name a Darknet .cfg or an .onnx file, got \"" + model_path +
                                "\"");
  }
  if (darknet && weights_path.empty())
  {
    throw std::invalid_argument("weights must name the .weights file of the Darknet model " + model_path);
  }
  if (onnx && !weights_path.empty())
  {
    throw std::invalid_argument("weights must be empty for an ONNX model, got \"" + weights_path + "\"");
  }
  if (class_names_path.empty())
  {
    throw std::invalid_argument("class_names must name the class names file");
  }
  if (input_width < 0 || input_width > kMaxInputSize || input_height < 0 || input_height > kMaxInputSize)
  {
    throw std::invalid_argument("input_width and input_height must be in [0, 4096], got " +
                                std::to_string(input_width) + " x " + std::to_string(input_height));
  }
  if ((input_width == 0) != (input_height == 0))
  {
    throw std::invalid_argument(
        "input_width and input_height must both be 0 (the model's own size) or both set");
  }
  if (!(score_threshold >= 0.0 && score_threshold <= 1.0))
  {
    throw std::invalid_argument("score_threshold must be in [0, 1], got " + std::to_string(score_threshold));
  }
  if (!(nms_threshold >= 0.0 && nms_threshold <= 1.0))
  {
    throw std::invalid_argument("nms_threshold must be in [0, 1], got " + std::to_string(nms_threshold));
  }
  if (backendId(backend) < 0)
  {
    throw std::invalid_argument("backend must be \"opencv\", \"cuda\" or \"inference_engine\", got \"" +
                                backend + "\"");
  }
  if (targetId(target) < 0)
  {
    throw std::invalid_argument(
        "target must be \"cpu\", \"opencl\", \"opencl_fp16\", \"cuda\" or \"cuda_fp16\", got \"" + target +
        "\"");
  }
  for (const auto& entry : class_map)
  {
    if (entry.first.empty() || entry.second.empty())
    {
      throw std::invalid_argument("class_map entries must have non-empty names, got \"" + entry.first +
                                  "\" -> \"" + entry.second + "\"");
    }
  }
  for (const auto& entry : rider_merge)
  {
    if (entry.first.empty() || entry.second.empty() || entry.first == rider_class)
    {
      throw std::invalid_argument("rider_merge entries must map a vehicle class other than rider_class \"" +
                                  rider_class + "\" to a non-empty label, got \"" + entry.first + "\" -> \"" +
                                  entry.second + "\"");
    }
  }
  if (!rider_merge.empty() && rider_class.empty())
  {
    throw std::invalid_argument(
        "rider_class must name the riders' model class (e.g. person) for rider_merge");
  }
}

InputTransform InputTransform::make(cv::Size image_size, cv::Size input_size, ResizeMode mode)
{
  if (image_size.width <= 0 || image_size.height <= 0 || input_size.width <= 0 || input_size.height <= 0)
  {
    throw std::invalid_argument("InputTransform: empty image or input size");
  }
  InputTransform t;
  t.image_size = image_size;
  t.input_size = input_size;
  if (mode == ResizeMode::kStretch)
  {
    t.resized_width = input_size.width;
    t.resized_height = input_size.height;
  }
  else
  {
    const double scale = std::min(static_cast<double>(input_size.width) / image_size.width,
                                  static_cast<double>(input_size.height) / image_size.height);
    t.resized_width =
        std::clamp(static_cast<int>(std::lround(image_size.width * scale)), 1, input_size.width);
    t.resized_height =
        std::clamp(static_cast<int>(std::lround(image_size.height * scale)), 1, input_size.height);
    t.pad_x = (input_size.width - t.resized_width) / 2;
    t.pad_y = (input_size.height - t.resized_height) / 2;
  }
  t.scale_x = static_cast<double>(t.resized_width) / image_size.width;
  t.scale_y = static_cast<double>(t.resized_height) / image_size.height;
  return t;
}

BoundingBox InputTransform::toImage(double x_min, double y_min, double x_max, double y_max) const
{
  auto clip = [](double value, int limit)
  { return static_cast<float>(std::clamp(value, 0.0, double(limit))); };
  BoundingBox box;
  box.x_min = clip((x_min - pad_x) / scale_x, image_size.width);
  box.x_max = clip((x_max - pad_x) / scale_x, image_size.width);
  box.y_min = clip((y_min - pad_y) / scale_y, image_size.height);
  box.y_max = clip((y_max - pad_y) / scale_y, image_size.height);
  return box;
}

std::vector<YoloCandidate> decodeYoloOutputs(const std::vector<cv::Mat>& outputs, YoloOutputLayout layout,
                                             cv::Size input_size, int num_classes, double score_threshold)
{
  const int columns = 5 + num_classes;
  std::vector<YoloCandidate> candidates;
  for (const cv::Mat& output : outputs)
  {
    if (output.empty())
    {
      continue;
    }
    if (output.depth() != CV_32F || output.size[output.dims - 1] != columns)
    {
      throw std::invalid_argument("YOLO output blob of " + std::to_string(output.size[output.dims - 1]) +
                                  " float columns per box, expected 5 + " + std::to_string(num_classes) +
                                  " classes = " + std::to_string(columns));
    }
    const cv::Mat rows = output.isContinuous() ? output : output.clone();
    const std::size_t count = rows.total() / static_cast<std::size_t>(columns);
    const float* data = rows.ptr<float>();
    const double sx = layout == YoloOutputLayout::kOpenCvRegion ? input_size.width : 1.0;
    const double sy = layout == YoloOutputLayout::kOpenCvRegion ? input_size.height : 1.0;
    for (std::size_t r = 0; r < count; ++r)
    {
      const float* row = data + r * static_cast<std::size_t>(columns);
      const float objectness = row[4];
      if (!(objectness > 0.F) || !std::isfinite(row[0]) || !std::isfinite(row[1]) || !std::isfinite(row[2]) ||
          !std::isfinite(row[3]))
      {
        continue;
      }
      const double w = row[2] * sx;
      const double h = row[3] * sy;
      const cv::Rect2d box(row[0] * sx - w / 2.0, row[1] * sy - h / 2.0, w, h);
      for (int c = 0; c < num_classes; ++c)
      {
        const float score = layout == YoloOutputLayout::kOpenCvRegion ? row[5 + c] : objectness * row[5 + c];
        if (score > 0.F && score >= score_threshold && std::isfinite(score))
        {
          candidates.push_back({c, score, box});
        }
      }
    }
  }
  return candidates;
}

std::vector<YoloCandidate> suppressPerClass(const std::vector<YoloCandidate>& candidates,
                                            double score_threshold, double nms_threshold)
{
  std::map<int, std::vector<std::size_t>> by_class;
  for (std::size_t i = 0; i < candidates.size(); ++i)
  {
    by_class[candidates[i].class_id].push_back(i);
  }
  std::vector<YoloCandidate> kept;
  for (const auto& entry : by_class)
  {
    std::vector<cv::Rect2d> boxes;
    std::vector<float> scores;
    for (std::size_t i : entry.second)
    {
      boxes.push_back(candidates[i].box);
      scores.push_back(candidates[i].score);
    }
    std::vector<int> indices;
    cv::dnn::NMSBoxes(boxes, scores, static_cast<float>(score_threshold), static_cast<float>(nms_threshold),
                      indices);
    for (int index : indices)
    {
      kept.push_back(candidates[entry.second[static_cast<std::size_t>(index)]]);
    }
  }
  return kept;
}

YoloDetector::YoloDetector(const YoloDetectorConfig& config) : config_(config)
{
  config_.validate();
  class_names_ = readClassNames(config_.class_names_path);
  const bool darknet = modelFormat(config_.model_path) == ModelFormat::kDarknet;
  try
  {
    if (darknet)
    {
      const DarknetCfgInfo info = parseDarknetCfg(config_.model_path);
      if (info.yolo_layers == 0)
      {
        throw YoloModelError(config_.model_path + ": the Darknet cfg has no [yolo] or [region] output layer");
      }
      if (info.num_classes != static_cast<int>(class_names_.size()))
      {
        throw YoloModelError(config_.class_names_path + ": lists " + std::to_string(class_names_.size()) +
                             " classes, but " + config_.model_path +
                             " has classes=" + std::to_string(info.num_classes));
      }
      checkDarknetWeights(config_.weights_path, config_.model_path, info);
      input_size_ = config_.input_width > 0 ? cv::Size(config_.input_width, config_.input_height)
                                            : cv::Size(info.input_width, info.input_height);
      layout_ = YoloOutputLayout::kOpenCvRegion;
      net_ = cv::dnn::readNetFromDarknet(config_.model_path, config_.weights_path);
    }
    else
    {
      input_size_ = onnxInputSize(readOnnxInput(config_.model_path));
      layout_ = config_.onnx_layout;
      net_ = cv::dnn::readNetFromONNX(config_.model_path);
    }
  }
  catch (const cv::Exception& e)
  {
    throw YoloModelError(config_.model_path + ": OpenCV cannot load the model" +
                         (darknet ? " with " + config_.weights_path : std::string()) + ": " + e.what());
  }
  if (net_.empty())
  {
    throw YoloModelError(config_.model_path + ": OpenCV loaded an empty network");
  }
  output_names_ = net_.getUnconnectedOutLayersNames();
  selectBackend();

  // One forward pass on a grey input: allocates the layers (so the first frame is not slow),
  // proves the backend works and checks the output width against the class names.
  const cv::Mat probe(input_size_, CV_8UC3, cv::Scalar::all(127));
  InputTransform transform;
  std::vector<cv::Mat> outputs;
  for (int attempt = 0; attempt < 2; ++attempt)
  {
    try
    {
      net_.setInput(makeInputBlob(probe, PixelFormat::kBgr8, transform));
      net_.forward(outputs, output_names_);
      break;
    }
    catch (const cv::Exception& e)
    {
      if (attempt == 0 && (backend_used_ != "opencv" || target_used_ != "cpu"))
      {
        warnings_.push_back("forward pass on backend " + backendDescription() + " failed (" + e.what() +
                            "); falling back to opencv/cpu");
        backend_used_ = "opencv";
        target_used_ = "cpu";
        net_.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
        net_.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
        continue;
      }
      throw YoloModelError(config_.model_path + ": forward pass at input " +
                           std::to_string(input_size_.width) + "x" + std::to_string(input_size_.height) +
                           " failed: " + e.what());
    }
  }
  for (const cv::Mat& output : outputs)
  {
    const int columns = output.size[output.dims - 1];
    if (columns != 5 + static_cast<int>(class_names_.size()))
    {
      throw YoloModelError(config_.class_names_path + ": lists " + std::to_string(class_names_.size()) +
                           " classes, but " + config_.model_path + " outputs " + std::to_string(columns) +
                           " values per box (5 + " + std::to_string(columns - 5) + " classes)");
    }
  }
}

cv::Size YoloDetector::onnxInputSize(const OnnxInputInfo& input) const
{
  const cv::Size given(config_.input_width, config_.input_height);
  const cv::Size declared = input.imageSize();
  const auto text = [](cv::Size size)
  { return std::to_string(size.width) + "x" + std::to_string(size.height); };
  std::string shape;
  for (const long long dim : input.shape)
  {
    shape += (shape.empty() ? "" : ", ") + (dim > 0 ? std::to_string(dim) : std::string("?"));
  }
  const std::string declaration = "input \"" + input.name + "\" [" + shape + "]";
  if (declared.empty() && given.area() == 0)
  {
    throw YoloModelError(config_.model_path + ": the model's " + declaration +
                         " leaves its image size open: give the input size it was exported for");
  }
  if (!declared.empty() && given.area() > 0 && given != declared)
  {
    throw YoloModelError(config_.model_path + ": the model declares its " + declaration + ", an input of " +
                         text(declared) + ", but the input size given is " + text(given) + ": give " +
                         text(declared) + " or no size at all");
  }
  return declared.empty() ? given : declared;
}

void YoloDetector::selectBackend()
{
  const int backend = backendId(config_.backend);
  const int target = targetId(config_.target);
  const std::vector<cv::dnn::Target> available =
      cv::dnn::getAvailableTargets(static_cast<cv::dnn::Backend>(backend));
  if (std::find(available.begin(), available.end(), target) == available.end())
  {
    warnings_.push_back("DNN backend/target " + config_.backend + "/" + config_.target +
                        " is not available in this OpenCV build; falling back to opencv/cpu");
    backend_used_ = "opencv";
    target_used_ = "cpu";
  }
  else
  {
    backend_used_ = config_.backend;
    target_used_ = config_.target;
  }
  net_.setPreferableBackend(backendId(backend_used_));
  net_.setPreferableTarget(targetId(target_used_));
}

std::string YoloDetector::backendDescription() const
{
  return backend_used_ + "/" + target_used_;
}

std::string YoloDetector::description() const
{
  return config_.model_path + " (" + std::to_string(class_names_.size()) + " classes), input " +
         std::to_string(input_size_.width) + "x" + std::to_string(input_size_.height) + " " +
         toString(config_.resize_mode) + ", " + backendDescription();
}

std::int64_t YoloDetector::flops()
{
  return net_.getFLOPS(cv::dnn::MatShape{1, 3, input_size_.height, input_size_.width});
}

void YoloDetector::setThresholds(double score_threshold, double nms_threshold)
{
  YoloDetectorConfig updated = config_;
  updated.score_threshold = score_threshold;
  updated.nms_threshold = nms_threshold;
  updated.validate();
  config_ = updated;
}

cv::Mat YoloDetector::makeInputBlob(const cv::Mat& image, PixelFormat format, InputTransform& transform) const
{
  if (image.empty())
  {
    throw std::invalid_argument("detect: empty image");
  }
  const int expected_type = format == PixelFormat::kMono8 ? CV_8UC1 : CV_8UC3;
  if (image.type() != expected_type)
  {
    throw std::invalid_argument(
        std::string("detect: image of OpenCV type ") + cv::typeToString(image.type()) +
        " does not match its pixel format (expected " + cv::typeToString(expected_type) + ")");
  }
  cv::Mat three_channel = image;
  bool image_rgb = format == PixelFormat::kRgb8;
  if (format == PixelFormat::kMono8)
  {
    cv::cvtColor(image, three_channel, cv::COLOR_GRAY2RGB);
    image_rgb = true;
  }
  transform = InputTransform::make(image.size(), input_size_, config_.resize_mode);
  cv::Mat resized;
  cv::resize(three_channel, resized, cv::Size(transform.resized_width, transform.resized_height), 0.0, 0.0,
             cv::INTER_LINEAR);
  cv::Mat canvas(input_size_, CV_32FC3, cv::Scalar::all(0.5));
  resized.convertTo(canvas(cv::Rect(static_cast<int>(transform.pad_x), static_cast<int>(transform.pad_y),
                                    transform.resized_width, transform.resized_height)),
                    CV_32F, 1.0 / 255.0);
  const bool swap_rb = image_rgb != config_.network_rgb;
  return cv::dnn::blobFromImage(canvas, 1.0, cv::Size(), cv::Scalar(), swap_rb, false, CV_32F);
}

std::vector<Detection> YoloDetector::detect(const cv::Mat& image, PixelFormat format)
{
  InputTransform transform;
  net_.setInput(makeInputBlob(image, format, transform));
  std::vector<cv::Mat> outputs;
  net_.forward(outputs, output_names_);
  const std::vector<YoloCandidate> kept =
      suppressPerClass(decodeYoloOutputs(outputs, layout_, input_size_, static_cast<int>(class_names_.size()),
                                         config_.score_threshold),
                       config_.score_threshold, config_.nms_threshold);
  std::vector<Detection> detections;
  for (const YoloCandidate& candidate : kept)
  {
    Detection detection;
    detection.class_id = static_cast<std::uint32_t>(candidate.class_id);
    detection.label = class_names_[static_cast<std::size_t>(candidate.class_id)];
    detection.score = candidate.score;
    detection.box = transform.toImage(candidate.box.x, candidate.box.y, candidate.box.x + candidate.box.width,
                                      candidate.box.y + candidate.box.height);
    if (detection.box.x_max > detection.box.x_min && detection.box.y_max > detection.box.y_min)
    {
      detections.push_back(std::move(detection));
    }
  }
  return publishedDetections(std::move(detections), config_);
}

RiderMergeResult mergeRiders(std::vector<Detection> detections, const std::string& rider_class,
                             const std::map<std::string, std::string>& vehicle_labels)
{
  RiderMergeResult result;
  std::vector<std::size_t> vehicles;
  std::vector<std::size_t> riders;
  for (std::size_t i = 0; i < detections.size(); ++i)
  {
    if (vehicle_labels.count(detections[i].label) != 0)
    {
      vehicles.push_back(i);
    }
    else if (detections[i].label == rider_class)
    {
      riders.push_back(i);
    }
  }
  std::stable_sort(vehicles.begin(), vehicles.end(),
                   [&](std::size_t a, std::size_t b) { return detections[a].score > detections[b].score; });
  std::vector<bool> used(detections.size(), false);
  for (const std::size_t v : vehicles)
  {
    const BoundingBox& vehicle = detections[v].box;
    const double rides_below = vehicle.y_min + 0.2 * (vehicle.y_max - vehicle.y_min);
    double widest = 0.0;
    std::size_t best = detections.size();
    for (const std::size_t r : riders)
    {
      const BoundingBox& rider = detections[r].box;
      const double centre = 0.5 * (rider.x_min + rider.x_max);
      const double overlap = std::min(rider.x_max, vehicle.x_max) - std::max(rider.x_min, vehicle.x_min);
      if (!used[r] && centre >= vehicle.x_min && centre <= vehicle.x_max && rider.y_min < vehicle.y_min &&
          rider.y_max > rides_below && overlap > widest)
      {
        widest = overlap;
        best = r;
      }
    }
    if (best == detections.size())
    {
      continue;
    }
    used[v] = used[best] = true;
    Detection merged = detections[v];
    const BoundingBox& rider = detections[best].box;
    merged.label = vehicle_labels.at(detections[v].label);
    merged.score = std::max(detections[v].score, detections[best].score);
    merged.box = {std::min(vehicle.x_min, rider.x_min), std::min(vehicle.y_min, rider.y_min),
                  std::max(vehicle.x_max, rider.x_max), std::max(vehicle.y_max, rider.y_max)};
    result.riders.push_back(std::move(merged));
  }
  for (std::size_t i = 0; i < detections.size(); ++i)
  {
    if (!used[i])
    {
      result.others.push_back(std::move(detections[i]));
    }
  }
  return result;
}

std::vector<Detection> publishedDetections(std::vector<Detection> detections,
                                           const YoloDetectorConfig& config)
{
  RiderMergeResult merged = mergeRiders(std::move(detections), config.rider_class, config.rider_merge);
  std::vector<Detection> published = std::move(merged.riders);
  for (Detection& detection : merged.others)
  {
    if (!config.class_map.empty())
    {
      const auto it = config.class_map.find(detection.label);
      if (it == config.class_map.end())
      {
        continue;
      }
      detection.label = it->second;
    }
    published.push_back(std::move(detection));
  }
  std::stable_sort(published.begin(), published.end(),
                   [](const Detection& a, const Detection& b) { return a.score > b.score; });
  return published;
}

void drawDetections(cv::Mat& image, const std::vector<Detection>& detections)
{
  static const cv::Scalar kPalette[] = {{0, 200, 255}, {255, 128, 0}, {0, 255, 0},   {255, 0, 255},
                                        {0, 0, 255},   {255, 255, 0}, {128, 0, 255}, {0, 128, 255}};
  for (const Detection& d : detections)
  {
    const cv::Scalar colour = kPalette[d.class_id % (sizeof(kPalette) / sizeof(kPalette[0]))];
    const cv::Point top_left(static_cast<int>(std::lround(d.box.x_min)),
                             static_cast<int>(std::lround(d.box.y_min)));
    const cv::Point bottom_right(static_cast<int>(std::lround(d.box.x_max)),
                                 static_cast<int>(std::lround(d.box.y_max)));
    cv::rectangle(image, top_left, bottom_right, colour, 2);
    char text[96];
    std::snprintf(text, sizeof(text), "%s %.2f", d.label.c_str(), static_cast<double>(d.score));
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &baseline);
    const cv::Point origin(top_left.x, std::max(size.height + 2, top_left.y - 3));
    cv::rectangle(image, origin + cv::Point(0, baseline), origin + cv::Point(size.width, -size.height - 2),
                  colour, cv::FILLED);
    cv::putText(image, text, origin, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
}

}  // namespace grid_vision_fusion
