// A nodelet's flow on /diagnostics and in its log: one diagnostic_updater task named after the
// nodelet with the input and output rates, the latency from the sensor stamp, the drops by
// reason (StageMonitor) and the nodelet's own keys; once a second a throttled warning for each
// input that stopped coming while another keeps coming, or for inputs that lead to no output.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "grid_vision_fusion/ros_sync/stage_monitor.h"

namespace grid_vision_fusion
{
/// The publisher queue of a stage's result topic (detections, projected grids, objects) for
/// subscribers in other processes (rosbag record, a planner node, scripts/soak_monitor.py): a
/// subscriber that falls behind for a moment under load gets every result instead of the newest
/// one. Subscribers in the manager take each message by pointer, without this queue.
constexpr std::uint32_t kResultQueueSize = 10;

class StageDiagnostics
{
public:
  using Extra = std::function<void(diagnostic_updater::DiagnosticStatusWrapper&)>;

  /// `inputs`: name → topic as the nodelet subscribes it (resolved against `nh`, remappings
  /// included); `extra` adds the nodelet's own keys (mergeSummary() for its own warnings).
  StageDiagnostics(ros::NodeHandle& nh, ros::NodeHandle& pnh, const std::string& name,
                   const std::string& hardware_id,
                   const std::vector<std::pair<std::string, std::string>>& inputs, Extra extra = nullptr)
      : name_(name), monitor_(resolved(nh, inputs)), extra_(std::move(extra))
  {
    updater_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, name);
    updater_->setHardwareID(hardware_id);
    updater_->add(name, this, &StageDiagnostics::diagnose);
    timer_ = nh.createWallTimer(ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { tick(); });
  }

  /// Stops the once-a-second report. A nodelet's destructor calls it first: the manager may
  /// delete a nodelet from a worker thread while the process ends, and the timer is best taken
  /// off roscpp's timer manager before anything waits.
  void stop() { timer_.stop(); }

  void input(const std::string& name) { monitor_.input(name, ros::Time::now().toSec()); }
  void output(const ros::Time& sensor_stamp)
  {
    monitor_.output(ros::Time::now().toSec(), sensor_stamp.toSec());
  }
  void drop(const std::string& reason, const std::string& detail = "") { monitor_.drop(reason, detail); }

  /// Seconds between two warnings about the same stall.
  static constexpr double kWarnPeriodS = 5.0;

private:
  static std::vector<std::pair<std::string, std::string>> resolved(
      ros::NodeHandle& nh, const std::vector<std::pair<std::string, std::string>>& inputs)
  {
    std::vector<std::pair<std::string, std::string>> out;
    for (const auto& [name, topic] : inputs)
    {
      out.emplace_back(name, nh.resolveName(topic));
    }
    return out;
  }

  void tick()
  {
    const StageMonitor::Report report = monitor_.report(ros::Time::now().toSec());
    const ros::WallTime now = ros::WallTime::now();
    if (!report.stalls.empty() && (now - last_warning_).toSec() >= kWarnPeriodS)
    {
      last_warning_ = now;
      for (const std::string& stall : report.stalls)
      {
        ROS_WARN("%s: %s", name_.c_str(), stall.c_str());
      }
    }
    {
      std::lock_guard<std::mutex> lock(report_mutex_);
      report_ = report;
    }
    updater_->update();
  }

  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status)
  {
    StageMonitor::Report report;
    {
      std::lock_guard<std::mutex> lock(report_mutex_);
      report = report_;
    }
    status.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "publishing at %.2f Hz", report.output_rate_hz);
    if (!report.stalls.empty())
    {
      status.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN, report.stalls.front());
    }
    else if (report.new_drops > 0)
    {
      status.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%lu inputs dropped in the last second",
                           static_cast<unsigned long>(report.new_drops));
    }
    for (const auto& [name, rate] : report.input_rate_hz)
    {
      status.addf("input rate " + name + " [Hz]", "%.2f", rate);
    }
    status.addf("output rate [Hz]", "%.2f", report.output_rate_hz);
    status.addf("latency from the sensor stamp, median [s]", "%.3f", report.latency_median_s);
    status.addf("latency from the sensor stamp, max [s]", "%.3f", report.latency_max_s);
    status.add("outputs", report.outputs);
    for (const auto& [reason, drops] : report.drops)
    {
      status.add("dropped: " + reason,
                 std::to_string(drops.first) +
                     (drops.second.empty() ? std::string() : " (last: " + drops.second + ")"));
    }
    if (extra_)
    {
      extra_(status);
    }
  }

  std::string name_;
  StageMonitor monitor_;
  Extra extra_;
  std::unique_ptr<diagnostic_updater::Updater> updater_;
  ros::WallTimer timer_;
  ros::WallTime last_warning_;
  std::mutex report_mutex_;
  StageMonitor::Report report_;
};

}  // namespace grid_vision_fusion
