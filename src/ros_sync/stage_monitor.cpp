#include "grid_vision_fusion/ros_sync/stage_monitor.h"

#include <algorithm>
#include <cstdio>

namespace grid_vision_fusion
{
namespace
{
/// Drops the items of `items` (oldest first) whose time, time_of(item), is before `oldest`.
template <typename T, typename TimeOf>
void dropBefore(std::deque<T>& items, double oldest, TimeOf time_of)
{
  while (!items.empty() && time_of(items.front()) < oldest)
  {
    items.pop_front();
  }
}

double itself(double t)
{
  return t;
}
double timeOfOutput(const std::pair<double, double>& output)
{
  return output.first;
}

std::string seconds(double s)
{
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f s", s);
  return text;
}
}  // namespace

StageMonitor::StageMonitor(std::vector<std::pair<std::string, std::string>> inputs, double window_s)
    : window_s_(window_s)
{
  for (auto& [name, topic] : inputs)
  {
    Channel channel;
    channel.topic = std::move(topic);
    inputs_.emplace_back(std::move(name), std::move(channel));
  }
}

void StageMonitor::restartIfBackwards(double now)
{
  if (now < latest_)
  {
    for (auto& entry : inputs_)
    {
      entry.second.arrivals.clear();
      entry.second.last = -1.0;
    }
    outputs_.clear();
    last_output_ = -1.0;
    first_input_ = -1.0;
  }
  latest_ = now;
}

void StageMonitor::input(const std::string& name, double now)
{
  std::lock_guard<std::mutex> lock(mutex_);
  restartIfBackwards(now);
  for (auto& entry : inputs_)
  {
    if (entry.first == name)
    {
      entry.second.arrivals.push_back(now);
      entry.second.last = now;
      dropBefore(entry.second.arrivals, now - window_s_, itself);
    }
  }
  if (first_input_ < 0.0)
  {
    first_input_ = now;
  }
}

void StageMonitor::output(double now, double stamp)
{
  std::lock_guard<std::mutex> lock(mutex_);
  restartIfBackwards(now);
  // A bag's /clock (100 Hz from rosbag play) may lag the stamps of its messages by a tick.
  outputs_.emplace_back(now, std::max(0.0, now - stamp));
  dropBefore(outputs_, now - window_s_, timeOfOutput);
  last_output_ = now;
  ++output_count_;
}

void StageMonitor::drop(const std::string& reason, const std::string& detail)
{
  std::lock_guard<std::mutex> lock(mutex_);
  auto& entry = drops_[reason];
  ++entry.first;
  entry.second = detail;
  ++drop_count_;
}

StageMonitor::Report StageMonitor::report(double now, double silence_s)
{
  std::lock_guard<std::mutex> lock(mutex_);
  restartIfBackwards(now);
  Report report;
  // Rates over the window, or over the time since the first input when that is shorter.
  const double span = first_input_ < 0.0 ? window_s_ : std::clamp(now - first_input_, 1.0, window_s_);
  for (auto& [name, channel] : inputs_)
  {
    dropBefore(channel.arrivals, now - window_s_, itself);
    report.input_rate_hz[name] = static_cast<double>(channel.arrivals.size()) / span;
  }
  dropBefore(outputs_, now - window_s_, timeOfOutput);
  report.output_rate_hz = static_cast<double>(outputs_.size()) / span;
  if (!outputs_.empty())
  {
    std::vector<double> latencies;
    for (const auto& output : outputs_)
    {
      latencies.push_back(output.second);
    }
    std::sort(latencies.begin(), latencies.end());
    report.latency_median_s = latencies[latencies.size() / 2];
    report.latency_max_s = latencies.back();
  }
  report.outputs = output_count_;
  report.drops = drops_;
  report.new_drops = drop_count_ - reported_drops_;
  reported_drops_ = drop_count_;

  if (first_input_ < 0.0)
  {
    return report;
  }
  const auto recent = [&](double t) { return t >= 0.0 && now - t <= silence_s; };
  bool all_recent = true;
  for (const auto& [name, channel] : inputs_)
  {
    all_recent = all_recent && recent(channel.last);
  }
  for (const auto& [arriving, present] : inputs_)
  {
    if (!recent(present.last))
    {
      continue;
    }
    for (const auto& [missing, absent] : inputs_)
    {
      const double silent = now - std::max(absent.last, first_input_);
      if (!recent(absent.last) && silent > silence_s)
      {
        report.stalls.push_back(arriving + " arrive on " + present.topic + " but no " + missing + " on " +
                                absent.topic + " for " + seconds(silent));
      }
    }
  }
  const double quiet = now - std::max(last_output_, first_input_);
  if (all_recent && quiet > silence_s)
  {
    std::string stall = "inputs arrive but nothing was published for " + seconds(quiet);
    if (!drops_.empty())
    {
      const auto last =
          std::max_element(drops_.begin(), drops_.end(),
                           [](const auto& a, const auto& b) { return a.second.first < b.second.first; });
      stall += " (most drops: " + last->first +
               (last->second.second.empty() ? "" : ": " + last->second.second) + ")";
    }
    report.stalls.push_back(stall);
  }
  return report;
}

}  // namespace grid_vision_fusion
