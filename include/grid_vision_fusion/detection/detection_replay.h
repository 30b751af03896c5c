// Detection replay: detections read from per-frame KITTI object label files instead of a
// network, so the fusion can be evaluated with oracle boxes (ground truth label_2 files), with
// detections computed elsewhere (KITTI result files with a 16th score column), or with the
// seeded noise of a real detector drawn on the oracle boxes (detection_noise.h).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "grid_vision_fusion/detection/detection_noise.h"
#include "grid_vision_fusion/detection/detector.h"
#include "grid_vision_fusion/detection/kitti_labels.h"

namespace grid_vision_fusion
{
/// Where the frame index of an image comes from.
enum class FrameIndexSource
{
  kCounter,    ///< first_index for the first image replayed, +1 for each following one
  kHeaderSeq,  ///< the image header's sequence number plus first_index
};

/// Parses "counter" or "seq". @throws std::invalid_argument otherwise.
FrameIndexSource frameIndexSourceFromString(const std::string& name);
/// The name parsed by frameIndexSourceFromString().
std::string toString(FrameIndexSource source);

/// The KITTI object types, in the order that gives replayed detections their class_id.
const std::vector<std::string>& kittiObjectTypes();

/// Parameters of the replay.
struct DetectionReplayConfig
{
  /// Directory of the per-frame label files (e.g. .../training/label_2).
  std::string directory;
  /// printf pattern of a file name from the frame index (one integer conversion), e.g. "%06d.txt".
  std::string file_pattern = "%06d.txt";
  FrameIndexSource index_source = FrameIndexSource::kCounter;
  /// Index of the first image (counter) or offset added to the header seq. Range >= 0 for the
  /// counter; any value for seq (the sum must be >= 0).
  int first_index = 0;
  /// KITTI type → published label (e.g. "Car" → "car", "Person_sitting" → "pedestrian").
  /// Types not in the map are dropped. Empty: every type except DontCare, label = the type in
  /// lower case.
  std::map<std::string, std::string> class_map;
  /// Score of labels without a 16th column (ground truth). Range [0, 1].
  double default_score = 1.0;
  /// Labels with a score below this are dropped. Range [0, 1].
  double score_threshold = kDefaultScoreThreshold;
  /// When true a missing file means "no object in this frame"; when false it is an error.
  bool missing_file_is_empty = false;
  /// A real detector's errors drawn on the labels (keys replay/noise/...); off by default.
  DetectionNoiseConfig noise;

  /// @throws std::invalid_argument naming the first bad field.
  void validate() const;
};

/// Reads the detections of frame after frame.
class DetectionReplay : public Detector
{
public:
  /// @throws std::invalid_argument for a bad config or a directory that does not exist.
  explicit DetectionReplay(const DetectionReplayConfig& config);

  /// The frame index of the next image: the counter (then advanced) or `header_seq` + first_index.
  /// @throws std::out_of_range when the index would be negative.
  std::int64_t nextFrameIndex(std::uint32_t header_seq);

  /// Path of the label file of `frame_index`.
  std::string pathOf(std::int64_t frame_index) const;

  /// The detections of `frame_index`, boxes clipped to `image_width` × `image_height` (0: no
  /// clipping), in file order; class_id = the type's index in kittiObjectTypes() (types not in
  /// that list get its size). Labels whose box is empty after clipping are dropped. With
  /// noise.enabled: the labels' detections under the noise of (noise.seed, frame_index), in
  /// order of decreasing score; the score threshold applies to the noisy scores.
  /// @throws KittiLabelError naming the file for a missing (unless missing_file_is_empty) or
  ///         malformed label file.
  std::vector<Detection> detectionsOf(std::int64_t frame_index, std::uint32_t image_width,
                                      std::uint32_t image_height) const;

  /// Changes the score threshold. @throws std::invalid_argument outside [0, 1].
  void setScoreThreshold(double score_threshold);

  // Detector: the labels of the image's frame index, no pixels needed.
  std::int64_t frameIndex(std::uint32_t header_seq) override { return nextFrameIndex(header_seq); }
  bool needsPixels() const override { return false; }
  std::vector<Detection> detect(const DetectorImage& image) override
  {
    return detectionsOf(image.frame_index, image.width, image.height);
  }
  /// The score threshold; there is no NMS (`nms_threshold` is ignored).
  void setThresholds(double score_threshold, double /*nms_threshold*/) override
  {
    setScoreThreshold(score_threshold);
  }
  /// "replay of <directory>/<file_pattern>, frame index from the <counter|header seq>".
  std::string description() const override;

  const DetectionReplayConfig& config() const { return config_; }

private:
  DetectionReplayConfig config_;
  std::int64_t counter_ = 0;
};

}  // namespace grid_vision_fusion
