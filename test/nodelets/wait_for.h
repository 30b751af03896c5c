// Helpers shared by the rostests.
#pragma once

#include <ros/master.h>
#include <ros/ros.h>

#include <functional>
#include <string>

namespace grid_vision_fusion
{
namespace test
{
/// Spins the global callback queue until `condition` holds or `timeout_s` wall seconds have
/// passed; calls `every_100ms` (when given) ten times a second meanwhile, e.g. to keep
/// publishing an input. Returns whether the condition holds.
inline bool waitFor(const std::function<bool()>& condition, double timeout_s,
                    const std::function<void()>& every_100ms = nullptr)
{
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  ros::WallTime next_action = ros::WallTime::now();
  while (ros::ok() && ros::WallTime::now() < deadline)
  {
    if (every_100ms && ros::WallTime::now() >= next_action)
    {
      every_100ms();
      next_action = ros::WallTime::now() + ros::WallDuration(0.1);
    }
    ros::spinOnce();
    if (condition())
    {
      return true;
    }
    ros::WallDuration(0.01).sleep();
  }
  ros::spinOnce();
  return condition();
}

/// Whether the master knows a publisher of `topic` (a resolved name such as "/objects").
inline bool topicAdvertised(const std::string& topic)
{
  ros::master::V_TopicInfo topics;
  ros::master::getTopics(topics);
  for (const auto& t : topics)
  {
    if (t.name == topic)
    {
      return true;
    }
  }
  return false;
}

}  // namespace test
}  // namespace grid_vision_fusion
