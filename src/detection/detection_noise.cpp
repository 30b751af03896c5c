#include "grid_vision_fusion/detection/detection_noise.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "grid_vision_fusion/detection/detection_replay.h"
#include "grid_vision_fusion/normal_quantile.h"
#include "grid_vision_fusion/splitmix64.h"

namespace grid_vision_fusion
{
namespace
{
/// The noise streams, one per component.
enum class Stream : std::uint64_t
{
  kPresence = 1,
  kScore = 2,
  kConfusion = 3,
  kPartial = 4,
  kJitter = 5,
  kExtra = 6,
  kFalsePositive = 7,
};

/// The first number of a SplitMix64 stream seeded with `x`: a hash that chains the seed's parts.
std::uint64_t splitMix(std::uint64_t x)
{
  return SplitMix64(x).next();
}

/// A counter-based generator (SplitMix64) seeded by (seed, frame, stream, index). Its normal and
/// Poisson draws are written out here so that they are the same with every standard library.
class NoiseStream
{
public:
  NoiseStream(std::uint32_t seed, std::int64_t frame, Stream stream, std::uint64_t index)
  {
    std::uint64_t h = splitMix(seed);
    h = splitMix(h ^ static_cast<std::uint64_t>(frame));
    h = splitMix(h ^ static_cast<std::uint64_t>(stream));
    random_ = SplitMix64(splitMix(h ^ index));
  }

  /// Uniform in [0, 1).
  double uniform() { return static_cast<double>(random_.next() >> 11U) * 0x1.0p-53; }
  bool bernoulli(double p) { return uniform() < p; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Standard normal (Box-Muller, one value per pair of uniforms).
  double normal()
  {
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }
  /// Standard normal truncated to [a, inf), by inversion.
  double normalAbove(double a)
  {
    const double tail = 0.5 * std::erfc(a / std::sqrt(2.0));  // P(Z >= a)
    const double q = tail * (1.0 - uniform());                // (0, tail]
    if (!(q > 0.0))
    {
      return a;
    }
    return -normalQuantile(std::min(q, 1.0 - 1e-16));
  }
  /// Poisson (Knuth's product of uniforms; mean <= 100).
  int poisson(double mean)
  {
    if (mean <= 0.0)
    {
      return 0;
    }
    const double limit = std::exp(-mean);
    int k = 0;
    double product = uniform();
    while (product > limit)
    {
      ++k;
      product *= uniform();
    }
    return k;
  }

private:
  SplitMix64 random_;
};

double sigmoid(double x)
{
  return 1.0 / (1.0 + std::exp(-x));
}
double logit(double p)
{
  return std::log(p / (1.0 - p));
}

int labelIndex(const std::string& label)
{
  const auto& labels = noiseModelLabels();
  const auto it = std::find(labels.begin(), labels.end(), label);
  return it == labels.end() ? -1 : static_cast<int>(it - labels.begin());
}

bool isVehicle(int label)
{
  return label >= 0 && label <= 2;
}
bool isPerson(int label)
{
  return label == 3 || label == 4;
}

/// The label after the confusion of `label` (index), one uniform of `stream`.
int confuse(const DetectionNoiseConfig& c, int label, NoiseStream& stream)
{
  struct Row
  {
    int first;
    double p_first;
    int second;
    double p_second;
  };
  // car 0, van 1, truck 2, pedestrian 3, cyclist 4
  const std::array<Row, 5> rows{
      Row{1, c.car_to_van, 2, c.car_to_truck}, Row{0, c.van_to_car, 2, c.van_to_truck},
      Row{0, c.truck_to_car, 1, c.truck_to_van}, Row{4, c.pedestrian_to_cyclist, -1, 0.0},
      Row{3, c.cyclist_to_pedestrian, -1, 0.0}};
  const double u = stream.uniform();
  if (label < 0)
  {
    return label;
  }
  const Row& row = rows[static_cast<std::size_t>(label)];
  if (u < row.p_first)
  {
    return row.first;
  }
  if (u < row.p_first + row.p_second)
  {
    return row.second;
  }
  return label;
}

/// A score drawn from N(mean, sigma^2) in logit(score / score_max), above min_score.
double drawScore(const DetectionNoiseConfig& c, double mean, double sigma, NoiseStream& stream)
{
  const double floor = logit(c.min_score / c.score_max);
  const double z = mean + sigma * stream.normalAbove((floor - mean) / sigma);
  return std::max(c.min_score, c.score_max * sigmoid(z));
}

/// Narrows `box` to a partial box (width fraction and side from `stream`).
void makePartial(const DetectionNoiseConfig& c, BoundingBox& box, NoiseStream& stream)
{
  const float fraction = static_cast<float>(stream.uniform(c.partial_width_min, c.partial_width_max));
  const float width = (box.x_max - box.x_min) * fraction;
  if (stream.bernoulli(0.5))
  {
    box.x_max = box.x_min + width;
  }
  else
  {
    box.x_min = box.x_max - width;
  }
}

/// Moves the edges of `box` by the edge errors of a label box `height` px high (of a pedestrian
/// or cyclist: `person`); edges on the
/// image border (within 1 px; none when the size is 0) stay: a box cut by the border stays cut.
void jitter(const DetectionNoiseConfig& c, BoundingBox& box, double height, bool person,
            std::uint32_t width_px, std::uint32_t height_px, NoiseStream& stream)
{
  const double scale = person ? c.person_scale : 1.0;
  const auto error = [&](const BoxEdgeNoise& e)
  {
    const bool tail = stream.bernoulli(e.tail_probability);
    const double sigma = scale * std::sqrt(e.sigma_px * e.sigma_px + std::pow(e.sigma_fraction * height, 2));
    return static_cast<float>(e.bias * height + stream.normal() * sigma * (tail ? e.tail_scale : 1.0));
  };
  const auto on_border = [](float value, std::uint32_t limit)
  { return limit > 0 && (value <= 1.F || value >= static_cast<float>(limit) - 1.F); };
  const float dl = error(c.left);
  const float dt = error(c.top);
  const float dr = error(c.right);
  const float db = error(c.bottom);
  if (!on_border(box.x_min, width_px))
  {
    box.x_min += dl;
  }
  if (!on_border(box.y_min, height_px))
  {
    box.y_min += dt;
  }
  if (!on_border(box.x_max, width_px))
  {
    box.x_max += dr;
  }
  if (!on_border(box.y_max, height_px))
  {
    box.y_max += db;
  }
}

/// Clips to the image (when its size is known); false when less than 1 px remains either way.
bool clipBox(BoundingBox& box, std::uint32_t width, std::uint32_t height)
{
  if (width > 0 && height > 0)
  {
    box = box.clippedTo(width, height);
  }
  return box.x_max - box.x_min >= 1.F && box.y_max - box.y_min >= 1.F;
}

Detection makeDetection(int label, double score, const BoundingBox& box)
{
  Detection d;
  d.label = noiseModelLabels()[static_cast<std::size_t>(label)];
  d.class_id = noiseClassId(d.label);
  d.score = static_cast<float>(score);
  d.box = box;
  return d;
}

/// What every step of one frame's noise needs.
struct NoiseFrame
{
  const DetectionNoiseConfig& c;
  std::int64_t frame;
  std::uint32_t width;
  std::uint32_t height;
};

/// The label's occlusion level, 0..3.
int occlusionOf(const NoiseLabel& in)
{
  return std::clamp(in.occluded, 0, 3);
}

/// The label's box height [px].
double heightOf(const NoiseLabel& in)
{
  return static_cast<double>(in.detection.box.y_max - in.detection.box.y_min);
}

/// Whether the label gets a box (the misses component; `score` its score). Labels the model does
/// not know and hidden ones (occlusion 3) as configured.
bool drawPresence(const NoiseFrame& f, const NoiseLabel& in, double& score)
{
  const DetectionNoiseConfig& c = f.c;
  if (!c.misses)
  {
    return true;
  }
  const int original = labelIndex(in.detection.label);
  if (original < 0)
  {
    return c.keep_other_labels;
  }
  const int occlusion = occlusionOf(in);
  if (occlusion == 3 && !c.fully_occluded_detected)
  {
    return false;
  }
  const auto label = static_cast<std::size_t>(original);
  const double height = heightOf(in);
  const double truncated = std::clamp(static_cast<double>(in.truncated), 0.0, 1.0);
  NoiseStream presence(c.seed, f.frame, Stream::kPresence, in.line);
  if (!presence.bernoulli(sigmoid(c.presence.predictor(label, height, occlusion, truncated))))
  {
    return false;
  }
  NoiseStream stream(c.seed, f.frame, Stream::kScore, in.line);
  score = drawScore(c, c.score.predictor(label, height, occlusion, truncated), c.score_sigma, stream);
  return true;
}

/// The label's box under the confusion, partial-box and jitter components (not clipped).
Detection noisyBox(const NoiseFrame& f, const NoiseLabel& in, double score)
{
  const DetectionNoiseConfig& c = f.c;
  const int original = labelIndex(in.detection.label);
  Detection detection = in.detection;
  detection.score = static_cast<float>(score);
  if (c.confusion && original >= 0)
  {
    NoiseStream stream(c.seed, f.frame, Stream::kConfusion, in.line);
    const int label = confuse(c, original, stream);
    detection.label = noiseModelLabels()[static_cast<std::size_t>(label)];
    detection.class_id = noiseClassId(detection.label);
  }
  if (c.partial_boxes)
  {
    NoiseStream stream(c.seed, f.frame, Stream::kPartial, in.line);
    const std::array<double, 3> p{c.partial_occlusion0, c.partial_occlusion1, c.partial_occlusion2};
    if (stream.bernoulli(p[static_cast<std::size_t>(std::min(occlusionOf(in), 2))]))
    {
      makePartial(c, detection.box, stream);
    }
  }
  if (c.box_jitter)
  {
    NoiseStream stream(c.seed, f.frame, Stream::kJitter, in.line);
    jitter(c, detection.box, heightOf(in), isPerson(original), f.width, f.height, stream);
  }
  return detection;
}

/// The extra boxes of a found label (a known one), appended to `out`.
void appendExtraBoxes(const NoiseFrame& f, const NoiseLabel& in, std::vector<Detection>& out)
{
  const DetectionNoiseConfig& c = f.c;
  const int original = labelIndex(in.detection.label);
  if (original < 0)
  {
    return;
  }
  NoiseStream stream(c.seed, f.frame, Stream::kExtra, in.line);
  const int count = stream.poisson(c.extra_rate);
  for (int k = 0; k < count; ++k)
  {
    BoundingBox box = in.detection.box;
    makePartial(c, box, stream);
    const int label = c.confusion ? confuse(c, original, stream) : original;
    const double score = drawScore(c, c.background.score_mean, c.background.score_sigma, stream);
    jitter(c, box, heightOf(in), isPerson(original), f.width, f.height, stream);
    if (clipBox(box, f.width, f.height))
    {
      out.push_back(makeDetection(label, score, box));
    }
  }
}

/// The frame's background false positives, appended to `out` (the image size known).
void appendFalsePositives(const NoiseFrame& f, std::vector<Detection>& out)
{
  const FalsePositiveNoise& fp = f.c.background;
  NoiseStream stream(f.c.seed, f.frame, Stream::kFalsePositive, 0);
  const int count = stream.poisson(fp.rate);
  const std::array<double, 5> weights{fp.car, fp.van, fp.truck, fp.pedestrian, fp.cyclist};
  const double sum = weights[0] + weights[1] + weights[2] + weights[3] + weights[4];
  const auto w = static_cast<double>(f.width);
  const auto h = static_cast<double>(f.height);
  for (int k = 0; k < count; ++k)
  {
    const double score = drawScore(f.c, fp.score_mean, fp.score_sigma, stream);
    double u = stream.uniform() * sum;
    int label = 0;
    while (label < 4 && u >= weights[static_cast<std::size_t>(label)])
    {
      u -= weights[static_cast<std::size_t>(label)];
      ++label;
    }
    const double box_height = std::min(fp.height_median * std::exp(fp.height_sigma * stream.normal()), h);
    const double box_width =
        std::min(box_height * (isVehicle(label) ? fp.vehicle_aspect : fp.person_aspect), w);
    const double bottom = stream.uniform(fp.bottom_min, fp.bottom_max) * h;
    const double centre = stream.uniform(box_width / 2.0, w - box_width / 2.0);
    BoundingBox box{static_cast<float>(centre - box_width / 2.0), static_cast<float>(bottom - box_height),
                    static_cast<float>(centre + box_width / 2.0), static_cast<float>(bottom)};
    if (clipBox(box, f.width, f.height))
    {
      out.push_back(makeDetection(label, score, box));
    }
  }
}

void require(bool ok, const std::string& key, const std::string& what, double value)
{
  if (!ok)
  {
    throw std::invalid_argument("replay/noise/" + key + " must be " + what + ", got " +
                                std::to_string(value));
  }
}

void requireProbability(double p, const std::string& key)
{
  require(p >= 0.0 && p <= 1.0, key, "in [0, 1]", p);
}

void requireFinite(double v, const std::string& key)
{
  require(std::isfinite(v), key, "finite", v);
}

void validateWeights(const NoiseCovariateWeights& w, const std::string& prefix)
{
  const std::array<std::pair<const char*, double>, 9> entries{{{"car", w.car},
                                                               {"van", w.van},
                                                               {"truck", w.truck},
                                                               {"pedestrian", w.pedestrian},
                                                               {"cyclist", w.cyclist},
                                                               {"height_slope", w.height_slope},
                                                               {"occlusion1", w.occlusion1},
                                                               {"occlusion2", w.occlusion2},
                                                               {"truncation", w.truncation}}};
  for (const auto& [name, value] : entries)
  {
    requireFinite(value, prefix + name);
  }
}

void validateEdge(const BoxEdgeNoise& e, const std::string& name)
{
  const std::string prefix = "box/" + name + "/";
  requireFinite(e.bias, prefix + "bias");
  require(std::isfinite(e.sigma_px) && e.sigma_px >= 0.0, prefix + "sigma_px", "finite and >= 0", e.sigma_px);
  require(std::isfinite(e.sigma_fraction) && e.sigma_fraction >= 0.0, prefix + "sigma_fraction",
          "finite and >= 0", e.sigma_fraction);
  requireProbability(e.tail_probability, prefix + "tail_probability");
  require(std::isfinite(e.tail_scale) && e.tail_scale >= 0.0, prefix + "tail_scale", "finite and >= 0",
          e.tail_scale);
}

}  // namespace

const std::vector<std::string>& noiseModelLabels()
{
  static const std::vector<std::string> kLabels{"car", "van", "truck", "pedestrian", "cyclist"};
  return kLabels;
}

std::uint32_t noiseClassId(const std::string& label)
{
  static const std::array<std::uint32_t, 5> kIds{0, 1, 2, 3, 5};
  const int index = labelIndex(label);
  return index < 0 ? static_cast<std::uint32_t>(kittiObjectTypes().size())
                   : kIds[static_cast<std::size_t>(index)];
}

double NoiseCovariateWeights::predictor(std::size_t label, double box_height, int occlusion,
                                        double truncated) const
{
  const std::array<double, 5> offsets{car, van, truck, pedestrian, cyclist};
  return offsets.at(label) + height_slope * std::log(std::max(box_height, 1.0) / kNoiseReferenceHeight) +
         (occlusion == 1 ? occlusion1 : 0.0) + (occlusion >= 2 ? occlusion2 : 0.0) + truncation * truncated;
}

void DetectionNoiseConfig::validate() const
{
  require(std::isfinite(score_max) && score_max > 0.0 && score_max <= 1.0, "score_max", "in (0, 1]",
          score_max);
  require(std::isfinite(min_score) && min_score > 0.0 && min_score < score_max, "min_score",
          "in (0, score_max)", min_score);
  validateWeights(presence, "presence/");
  validateWeights(score, "score/");
  require(std::isfinite(score_sigma) && score_sigma > 0.0, "score/sigma", "finite and > 0", score_sigma);
  validateEdge(left, "left");
  validateEdge(top, "top");
  validateEdge(right, "right");
  validateEdge(bottom, "bottom");
  require(std::isfinite(person_scale) && person_scale >= 0.0, "box/person_scale", "finite and >= 0",
          person_scale);
  requireProbability(partial_occlusion0, "partial/occlusion0");
  requireProbability(partial_occlusion1, "partial/occlusion1");
  requireProbability(partial_occlusion2, "partial/occlusion2");
  require(partial_width_min > 0.0 && partial_width_min <= 1.0, "partial/width_min", "in (0, 1]",
          partial_width_min);
  require(partial_width_max >= partial_width_min && partial_width_max <= 1.0, "partial/width_max",
          "in [width_min, 1]", partial_width_max);
  const std::array<std::pair<const char*, double>, 8> confusions{
      {{"car_to_van", car_to_van},
       {"car_to_truck", car_to_truck},
       {"van_to_car", van_to_car},
       {"van_to_truck", van_to_truck},
       {"truck_to_car", truck_to_car},
       {"truck_to_van", truck_to_van},
       {"pedestrian_to_cyclist", pedestrian_to_cyclist},
       {"cyclist_to_pedestrian", cyclist_to_pedestrian}}};
  for (const auto& [name, p] : confusions)
  {
    requireProbability(p, std::string("confusion/") + name);
  }
  require(car_to_van + car_to_truck <= 1.0, "confusion/car_to_truck", "<= 1 - car_to_van", car_to_truck);
  require(van_to_car + van_to_truck <= 1.0, "confusion/van_to_truck", "<= 1 - van_to_car", van_to_truck);
  require(truck_to_car + truck_to_van <= 1.0, "confusion/truck_to_van", "<= 1 - truck_to_car", truck_to_van);
  require(std::isfinite(extra_rate) && extra_rate >= 0.0 && extra_rate <= 100.0, "extra_rate", "in [0, 100]",
          extra_rate);
  const FalsePositiveNoise& f = background;
  require(std::isfinite(f.rate) && f.rate >= 0.0 && f.rate <= 100.0, "false_positives/rate", "in [0, 100]",
          f.rate);
  requireFinite(f.score_mean, "false_positives/score_mean");
  require(std::isfinite(f.score_sigma) && f.score_sigma > 0.0, "false_positives/score_sigma",
          "finite and > 0", f.score_sigma);
  require(std::isfinite(f.height_median) && f.height_median > 0.0, "false_positives/height_median",
          "finite and > 0 px", f.height_median);
  require(std::isfinite(f.height_sigma) && f.height_sigma >= 0.0, "false_positives/height_sigma",
          "finite and >= 0", f.height_sigma);
  require(f.bottom_min >= 0.0 && f.bottom_min <= 1.0, "false_positives/bottom_min", "in [0, 1]",
          f.bottom_min);
  require(f.bottom_max >= f.bottom_min && f.bottom_max <= 1.0, "false_positives/bottom_max",
          "in [bottom_min, 1]", f.bottom_max);
  require(std::isfinite(f.vehicle_aspect) && f.vehicle_aspect > 0.0, "false_positives/vehicle_aspect",
          "finite and > 0", f.vehicle_aspect);
  require(std::isfinite(f.person_aspect) && f.person_aspect > 0.0, "false_positives/person_aspect",
          "finite and > 0", f.person_aspect);
  const std::array<std::pair<const char*, double>, 5> weights{{{"car", f.car},
                                                               {"van", f.van},
                                                               {"truck", f.truck},
                                                               {"pedestrian", f.pedestrian},
                                                               {"cyclist", f.cyclist}}};
  double sum = 0.0;
  for (const auto& [name, w] : weights)
  {
    require(std::isfinite(w) && w >= 0.0, std::string("false_positives/") + name, "finite and >= 0", w);
    sum += w;
  }
  require(f.rate == 0.0 || sum > 0.0, "false_positives/car",
          "such that the label weights sum to > 0 when rate > 0", sum);
}

std::vector<Detection> applyDetectionNoise(const DetectionNoiseConfig& c, std::int64_t frame,
                                           const std::vector<NoiseLabel>& labels, std::uint32_t image_width,
                                           std::uint32_t image_height)
{
  const NoiseFrame f{c, frame, image_width, image_height};
  std::vector<Detection> out;
  for (const NoiseLabel& in : labels)
  {
    double score = in.detection.score;
    if (!drawPresence(f, in, score))
    {
      continue;
    }
    Detection detection = noisyBox(f, in, score);
    if (clipBox(detection.box, image_width, image_height))
    {
      out.push_back(detection);
    }
    if (c.extra_boxes)
    {
      appendExtraBoxes(f, in, out);
    }
  }
  if (c.false_positives && image_width > 0 && image_height > 0)
  {
    appendFalsePositives(f, out);
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const Detection& a, const Detection& b) { return a.score > b.score; });
  return out;
}

}  // namespace grid_vision_fusion
