#include "joint_state_cache.h"

#include <algorithm>
#include <limits>

namespace pg_control {

void JointStateCache::update(const sensor_msgs::JointState::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::size_t n = std::min(msg->name.size(), msg->position.size());
  for (std::size_t i = 0; i < n; ++i) positions_[msg->name[i]] = msg->position[i];
  last_ = ros::WallTime::now();
  ++count_;
}

double JointStateCache::secondsSinceLast() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (count_ == 0) return std::numeric_limits<double>::infinity();
  return (ros::WallTime::now() - last_).toSec();
}

std::optional<Eigen::VectorXd> JointStateCache::positions(const std::vector<std::string>& names,
                                                          std::string* missing) const {
  std::lock_guard<std::mutex> lock(mutex_);
  Eigen::VectorXd q(static_cast<Eigen::Index>(names.size()));
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto it = positions_.find(names[i]);
    if (it == positions_.end()) {
      if (missing) *missing = names[i];
      return std::nullopt;
    }
    q(static_cast<Eigen::Index>(i)) = it->second;
  }
  return q;
}

unsigned long JointStateCache::count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return count_;
}

}  // namespace pg_control
