#include "pg_control/cartesian_path.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

namespace pg_control {
namespace {

std::string describe(const Eigen::Vector3d& p) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "(%.3f, %.3f, %.3f) m", p.x(), p.y(), p.z());
  return buf;
}

}  // namespace

double CartesianPath::length() const {
  double sum = 0.0;
  for (double l : lengths) sum += l;
  return sum;
}

int stepCount(double length, double step) {
  if (!(step > 0.0) || !std::isfinite(length) || length < 0.0) {
    throw std::invalid_argument("stepCount: need a finite length >= 0 and a step > 0");
  }
  return std::max(1, static_cast<int>(std::ceil(length / step * (1.0 - 1e-9))));
}

CartesianPath planCartesianPath(const ArmKinematics& arm, const std::vector<Eigen::Vector3d>& polyline, double yaw,
                                const JointVector& q_start, const CartesianPathOptions& options) {
  if (polyline.size() < 2) throw std::invalid_argument("planCartesianPath: a polyline needs at least 2 points");
  if (!std::isfinite(yaw)) throw std::invalid_argument("planCartesianPath: yaw must be finite");
  for (const auto& p : polyline) {
    if (!p.allFinite()) throw std::invalid_argument("planCartesianPath: polyline points must be finite");
  }
  CartesianPath path;
  path.joints.push_back(q_start);
  path.points.push_back(polyline.front());
  JointVector q = q_start;
  for (std::size_t leg = 0; leg + 1 < polyline.size(); ++leg) {
    const Eigen::Vector3d& a = polyline[leg];
    const Eigen::Vector3d& b = polyline[leg + 1];
    const double leg_length = (b - a).norm();
    const int n = stepCount(leg_length, options.step);
    for (int i = 1; i <= n; ++i) {
      const Eigen::Vector3d p = a + (b - a) * (static_cast<double>(i) / n);
      const std::optional<JointVector> next = arm.solveDown(p, yaw, q);
      if (!next) {
        throw PlanningError("arm '" + arm.name() + "': no IK solution on its branch at " + describe(p));
      }
      const double jump = (*next - q).cwiseAbs().maxCoeff();
      if (jump > options.max_jump) {
        throw PlanningError("arm '" + arm.name() + "': joint jump of " + std::to_string(jump) + " rad at " +
                            describe(p) + " (a flip mid-line)");
      }
      q = *next;
      path.joints.push_back(q);
      path.points.push_back(p);
      path.lengths.push_back(leg_length / n);
    }
  }
  return path;
}

}  // namespace pg_control
