// What a nodelet tells about its own flow, for its diagnostics and its warnings: the rate of each
// input and of its output over a sliding window, the latency of its outputs from their sensor
// stamps, the inputs it dropped by reason, and the inputs that stopped coming while another one
// keeps coming. Times are ROS times in seconds (the bag's clock under use_sim_time); a time
// before the last one seen (a bag played again) starts the window afresh. Thread-safe.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace grid_vision_fusion
{
class StageMonitor
{
public:
  /// `inputs`: name → topic of each input the output needs (e.g. {"grid", "/grid"}).
  explicit StageMonitor(std::vector<std::pair<std::string, std::string>> inputs, double window_s = 5.0);

  /// An input message arrived at `now`.
  void input(const std::string& name, double now);
  /// An output was published at `now` for a sensor message stamped `stamp` (latency now − stamp,
  /// at least 0: under use_sim_time the bag's clock may lag its messages by a tick).
  void output(double now, double stamp);
  /// An input dropped: counted under `reason` (a short fixed phrase); `detail` is the last
  /// message of that kind, shown with the count.
  void drop(const std::string& reason, const std::string& detail = "");

  struct Report
  {
    std::map<std::string, double> input_rate_hz;  ///< per input name, over the window
    double output_rate_hz = 0.0;                  ///< over the window
    double latency_median_s = 0.0;                ///< of the outputs in the window (0: none)
    double latency_max_s = 0.0;
    std::uint64_t outputs = 0;                                           ///< since the start
    std::map<std::string, std::pair<std::uint64_t, std::string>> drops;  ///< reason → count, last detail
    std::uint64_t new_drops = 0;                                         ///< since the previous report()
    /// "images arrive on /image but no camera_info on /camera_info for 2.3 s"-like sentences:
    /// inputs silent for more than `silence_s` while another arrives; or, with every input
    /// arriving, no output for more than `silence_s`.
    std::vector<std::string> stalls;
  };
  /// The figures at `now`; `silence_s` is how long an input or the output may be missing.
  Report report(double now, double silence_s = 1.0);

private:
  struct Channel
  {
    std::string topic;
    std::deque<double> arrivals;  ///< within the window
    double last = -1.0;           ///< -1: never
  };
  void restartIfBackwards(double now);

  std::mutex mutex_;
  double window_s_;
  std::vector<std::pair<std::string, Channel>> inputs_;
  std::deque<std::pair<double, double>> outputs_;  ///< (time, latency) within the window
  double last_output_ = -1.0;
  double first_input_ = -1.0;
  double latest_ = -1.0;
  std::uint64_t output_count_ = 0;
  std::uint64_t drop_count_ = 0;
  std::uint64_t reported_drops_ = 0;
  std::map<std::string, std::pair<std::uint64_t, std::string>> drops_;
};

}  // namespace grid_vision_fusion
