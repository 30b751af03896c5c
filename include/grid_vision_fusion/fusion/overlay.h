// Drawing of the paper's GUI (its Fig. 4): boxes coloured by motion, fusion bands, projected
// grid points. Pure OpenCV; used by the fusion and projection nodelets and the offline tools.
#pragma once

#include <opencv2/core.hpp>

#include <vector>

#include "grid_vision_fusion/fusion/fusion.h"

namespace grid_vision_fusion
{
/// BGR colours of the overlays: static blue, dynamic green (as in the paper), unknown grey.
cv::Scalar motionColor(Motion motion);
/// BGR colour of a projected cell of state `state` (static blue, dynamic green).
cv::Scalar cellStateColor(CellState state);

/// Draws every projected point as a small filled dot coloured by its state. Points outside
/// `image` or with non-finite pixel coordinates are skipped. @p image must be CV_8UC3 (BGR).
void drawProjectedPoints(cv::Mat& image, const ProjectedPointsView& points, int radius = 2);

/// Draws the fusion result over `image` (CV_8UC3, BGR): the projected points, the fusion band
/// of every box (thin rectangle), every box (thick, coloured by the motion of its object; grey
/// when its region was empty or its track is tentative) and a label "dynamic car 4.2 m/s" /
/// "static van"; for a tracked result with the track id, "#12 dynamic car 4.2 m/s", and
/// "#13 static car (new track)" for a tentative one. Motion, label and speed are the objects'
/// reports' (result.reports: reportPerFrame() or trackObjects()).
void drawFusionOverlay(cv::Mat& image, const std::vector<Detection>& detections, const FusionResult& result,
                       const ProjectedPointsView& points, const FusionConfig& config);

/// The label text of an object: "<motion> <label>", plus " <speed> m/s" (one decimal) when
/// dynamic, e.g. "dynamic car 4.2 m/s", "static van".
std::string objectLabel(Motion motion, const std::string& label, double speed_mps);
/// objectLabel() after the track id: "#12 dynamic car 4.2 m/s".
std::string trackLabel(std::uint32_t id, Motion motion, const std::string& label, double speed_mps);

}  // namespace grid_vision_fusion
