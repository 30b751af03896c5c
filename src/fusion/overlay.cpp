#include "grid_vision_fusion/fusion/overlay.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
const cv::Scalar kBlue(255, 0, 0);
const cv::Scalar kGreen(0, 200, 0);
const cv::Scalar kGrey(160, 160, 160);
const cv::Scalar kBandColor(0, 0, 255);  // red, as the fusion regions of the paper's Fig. 2

void requireBgr(const cv::Mat& image)
{
  if (image.type() != CV_8UC3)
  {
    throw std::invalid_argument("overlay drawing needs a CV_8UC3 (BGR) image");
  }
}
/// The label an object is published with: its track's, else its detection's.
}  // namespace

cv::Scalar motionColor(Motion motion)
{
  switch (motion)
  {
    case Motion::kStatic:
      return kBlue;
    case Motion::kDynamic:
      return kGreen;
    case Motion::kUnknown:
      break;
  }
  return kGrey;
}

cv::Scalar cellStateColor(CellState state)
{
  return state == CellState::kDynamic ? kGreen : kBlue;
}

void drawProjectedPoints(cv::Mat& image, const ProjectedPointsView& points, int radius)
{
  requireBgr(image);
  for (std::size_t i = 0; i < points.size; ++i)
  {
    const float u = points.u[i];
    const float v = points.v[i];
    if (!std::isfinite(u) || !std::isfinite(v) || u < 0.F || v < 0.F || u >= image.cols || v >= image.rows)
    {
      continue;
    }
    const auto state = points.state[i] == static_cast<std::uint8_t>(CellState::kDynamic) ? CellState::kDynamic
                                                                                         : CellState::kStatic;
    cv::circle(image, cv::Point(static_cast<int>(u), static_cast<int>(v)), radius, cellStateColor(state),
               cv::FILLED);
  }
}

std::string objectLabel(Motion motion, const std::string& label, double speed_mps)
{
  std::string text = toString(motion) + " " + label;
  if (motion == Motion::kDynamic)
  {
    char speed[32];
    std::snprintf(speed, sizeof(speed), " %.1f m/s", speed_mps);
    text += speed;
  }
  return text;
}

std::string trackLabel(std::uint32_t id, Motion motion, const std::string& label, double speed_mps)
{
  return "#" + std::to_string(id) + " " + objectLabel(motion, label, speed_mps);
}

void drawFusionOverlay(cv::Mat& image, const std::vector<Detection>& detections, const FusionResult& result,
                       const ProjectedPointsView& points, const FusionConfig& config)
{
  requireBgr(image);
  drawProjectedPoints(image, points);
  // The report of each detection's object (none: the fusion has no object for it).
  std::vector<const ReportedObject*> object_of(detections.size(), nullptr);
  for (std::size_t i = 0; i < result.objects.size() && i < result.reports.size(); ++i)
  {
    if (result.objects[i].detection_index < detections.size())
    {
      object_of[result.objects[i].detection_index] = &result.reports[i];
    }
  }
  for (std::size_t d = 0; d < detections.size(); ++d)
  {
    const Detection& detection = detections[d];
    const FusionRegion band = FusionRegion::fromBox(detection.box, config);
    cv::rectangle(image, cv::Point2f(band.u_min, band.v_min), cv::Point2f(band.u_max, band.v_max), kBandColor,
                  1);
    const ReportedObject* object = object_of[d];
    const bool tentative = object && object->track_state == TrackState::kTentative;
    // A new (tentative) track is drawn grey, as an object without a verdict.
    const cv::Scalar color = motionColor(object && !tentative ? object->motion : Motion::kUnknown);
    const cv::Point2f top_left(detection.box.x_min, detection.box.y_min);
    cv::rectangle(image, top_left, cv::Point2f(detection.box.x_max, detection.box.y_max), color, 2);
    std::string text = detection.label + " (no grid points)";
    if (tentative)
    {
      text = trackLabel(object->id, object->motion, object->label, object->speed()) + " (new track)";
    }
    else if (object)
    {
      text = result.tracked ? trackLabel(object->id, object->motion, object->label, object->speed())
                            : objectLabel(object->motion, object->label, object->speed());
    }
    int baseline = 0;
    const double scale = 0.5;
    const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline);
    const int x = std::max(0, static_cast<int>(top_left.x));
    const int y = std::max(size.height + 2, static_cast<int>(top_left.y) - 2);
    cv::rectangle(image, cv::Point(x, y - size.height - 2), cv::Point(x + size.width + 2, y + baseline),
                  color, cv::FILLED);
    cv::putText(image, text, cv::Point(x + 1, y - 1), cv::FONT_HERSHEY_SIMPLEX, scale,
                cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }
}

}  // namespace grid_vision_fusion
