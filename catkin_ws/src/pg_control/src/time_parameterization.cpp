#include "pg_control/time_parameterization.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pg_control {
namespace {

// Largest |v(s)| over s in [0, 1] of the cubic Hermite segment's joint speed: v(s) = A s^2 + B s + C (rad/s).
double segmentPeak(double dq, double duration, double v0, double v1) {
  const double slope = dq / duration;
  const double a = -6.0 * slope + 3.0 * v0 + 3.0 * v1;
  const double b = 6.0 * slope - 4.0 * v0 - 2.0 * v1;
  const double c = v0;
  double peak = std::max(std::abs(v0), std::abs(v1));
  if (std::abs(a) > 1e-12) {
    const double s = -b / (2.0 * a);
    if (s > 0.0 && s < 1.0) peak = std::max(peak, std::abs((a * s + b) * s + c));
  }
  return peak;
}

// Monotone waypoint velocities for the given segment durations (see the header).
std::vector<JointVector> waypointVelocities(const std::vector<JointVector>& q, const std::vector<double>& durations) {
  const std::size_t n = q.size();
  const Eigen::Index dof = q.front().size();
  std::vector<JointVector> v(n, JointVector::Zero(dof));
  for (std::size_t k = 1; k + 1 < n; ++k) {
    for (Eigen::Index j = 0; j < dof; ++j) {
      const double before = (q[k](j) - q[k - 1](j)) / durations[k - 1];
      const double after = (q[k + 1](j) - q[k](j)) / durations[k];
      if (before * after > 0.0) v[k](j) = std::abs(before) < std::abs(after) ? before : after;
    }
  }
  return v;
}

}  // namespace

JointVector TimedPath::sample(double t) const {
  if (positions.empty()) throw std::logic_error("TimedPath::sample: empty path");
  if (t <= 0.0 || positions.size() == 1) return positions.front();
  if (t >= duration()) return positions.back();
  const auto it = std::upper_bound(times.begin(), times.end(), t);
  const std::size_t k = static_cast<std::size_t>(it - times.begin()) - 1;
  const double h = times[k + 1] - times[k];
  const double s = (t - times[k]) / h;
  const double h00 = 2 * s * s * s - 3 * s * s + 1;
  const double h10 = s * s * s - 2 * s * s + s;
  const double h01 = -2 * s * s * s + 3 * s * s;
  const double h11 = s * s * s - s * s;
  return h00 * positions[k] + h10 * h * velocities[k] + h01 * positions[k + 1] + h11 * h * velocities[k + 1];
}

double TimedPath::peakVelocity() const {
  double peak = 0.0;
  for (std::size_t k = 0; k + 1 < positions.size(); ++k) {
    const double h = times[k + 1] - times[k];
    for (Eigen::Index j = 0; j < positions[k].size(); ++j) {
      peak = std::max(peak, segmentPeak(positions[k + 1](j) - positions[k](j), h, velocities[k](j),
                                        velocities[k + 1](j)));
    }
  }
  return peak;
}

double TimedPath::peakSecantVelocity() const {
  double peak = 0.0;
  for (std::size_t k = 0; k + 1 < positions.size(); ++k) {
    const double dq = (positions[k + 1] - positions[k]).cwiseAbs().maxCoeff();
    peak = std::max(peak, dq / (times[k + 1] - times[k]));
  }
  return peak;
}

TimedPath timeParameterize(const std::vector<JointVector>& path, const std::vector<double>& cartesian_lengths,
                           double tool_speed, const TimingOptions& options) {
  if (path.empty()) throw std::invalid_argument("timeParameterize: empty path");
  const std::size_t segments = path.size() - 1;
  if (!cartesian_lengths.empty() && cartesian_lengths.size() != segments) {
    throw std::invalid_argument("timeParameterize: need one Cartesian length per segment");
  }
  if (!cartesian_lengths.empty() && !(tool_speed > 0.0)) {
    throw std::invalid_argument("timeParameterize: tool speed must be > 0");
  }
  const double vmax = options.velocity_scale * options.joint_velocity_limit;
  if (!(vmax > 0.0) || !(options.min_segment_duration > 0.0)) {
    throw std::invalid_argument("timeParameterize: velocity limit, scale and minimum duration must be > 0");
  }
  for (const auto& q : path) {
    if (q.size() != path.front().size() || !q.allFinite()) {
      throw std::invalid_argument("timeParameterize: waypoints must be finite and of equal size");
    }
  }

  std::vector<double> durations(segments);
  for (std::size_t k = 0; k < segments; ++k) {
    const double joint_time = (path[k + 1] - path[k]).cwiseAbs().maxCoeff() / vmax;
    const double tool_time = cartesian_lengths.empty() ? 0.0 : cartesian_lengths[k] / tool_speed;
    durations[k] = std::max({joint_time, tool_time, options.min_segment_duration});
  }

  // Stretch segments whose cubic overshoots the limit. Durations only grow, and a segment with T >= 1.5 |dq| / vmax
  // never overshoots, so the loop ends; the last pass enforces that bound directly.
  std::vector<JointVector> velocities = waypointVelocities(path, durations);
  constexpr int kPasses = 50;
  for (int pass = 0; pass <= kPasses; ++pass) {
    bool stretched = false;
    for (std::size_t k = 0; k < segments; ++k) {
      double peak = 0.0;
      for (Eigen::Index j = 0; j < path[k].size(); ++j) {
        peak = std::max(peak, segmentPeak(path[k + 1](j) - path[k](j), durations[k], velocities[k](j),
                                          velocities[k + 1](j)));
      }
      if (peak > vmax * (1.0 + 1e-9)) {
        const double bound = 1.5 * (path[k + 1] - path[k]).cwiseAbs().maxCoeff() / vmax;
        durations[k] = pass == kPasses ? std::max(durations[k], bound) : durations[k] * peak / vmax * (1.0 + 1e-6);
        stretched = true;
      }
    }
    if (!stretched) break;
    velocities = waypointVelocities(path, durations);
  }

  TimedPath out;
  out.positions = path;
  out.velocities = velocities;
  out.times.assign(path.size(), 0.0);
  for (std::size_t k = 0; k < segments; ++k) out.times[k + 1] = out.times[k] + durations[k];
  return out;
}

}  // namespace pg_control
