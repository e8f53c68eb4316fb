// Latest /joint_states positions by joint name, shared between the subscriber thread and the service thread.
#ifndef PG_CONTROL_JOINT_STATE_CACHE_H
#define PG_CONTROL_JOINT_STATE_CACHE_H

#include <ros/time.h>
#include <sensor_msgs/JointState.h>

#include <Eigen/Core>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace pg_control {

class JointStateCache {
 public:
  // Subscriber callback: stores every named position (rad or m) and the wall time of arrival.
  void update(const sensor_msgs::JointState::ConstPtr& msg);

  // Wall seconds since the last message; +inf when none arrived yet.
  double secondsSinceLast() const;
  // Positions of `names` in that order, or nullopt; `missing` (if given) gets the first name never received.
  std::optional<Eigen::VectorXd> positions(const std::vector<std::string>& names, std::string* missing = nullptr) const;
  // Number of messages received so far.
  unsigned long count() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, double> positions_;
  ros::WallTime last_;
  unsigned long count_ = 0;
};

}  // namespace pg_control

#endif  // PG_CONTROL_JOINT_STATE_CACHE_H
