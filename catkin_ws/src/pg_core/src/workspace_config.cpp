#include "pg_core/workspace_config.h"

#include <yaml-cpp/yaml.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace pg_core {
namespace {

constexpr double kContainsTolerance = 1e-9;  // m, as pg_core.geometry.Workspace.contains
constexpr double kPi = 3.14159265358979323846;

// Reads one config document and reports problems as std::runtime_error naming the source and the dotted key.
class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("workspace config " + source_ + ": " + what);
  }

  // parent[key]; `where` is the dotted path of `parent` ("" for the document root, else ending in '.').
  YAML::Node child(const YAML::Node& parent, const std::string& key, const std::string& where) const {
    if (!parent.IsMap()) {
      const std::string owner = where.empty() ? std::string("<root>") : where.substr(0, where.size() - 1);
      fail("missing key '" + where + key + "' ('" + owner + "' is not a mapping)");
    }
    YAML::Node node = parent[key];
    if (!node.IsDefined()) fail("missing key '" + where + key + "'");
    return node;
  }

  double number(const YAML::Node& parent, const std::string& key, const std::string& where) const {
    return toNumber(child(parent, key, where), where + key);
  }

  int integer(const YAML::Node& parent, const std::string& key, const std::string& where) const {
    const YAML::Node node = child(parent, key, where);
    try {
      if (node.IsScalar()) return node.as<int>();
    } catch (const YAML::Exception&) {
    }
    fail("'" + where + key + "' must be an integer, got '" + describe(node) + "'");
  }

  Interval interval(const YAML::Node& parent, const std::string& key, const std::string& where) const {
    const std::string name = where + key;
    const YAML::Node node = child(parent, key, where);
    if (!node.IsSequence() || node.size() != 2) fail("'" + name + "' must be a list [min, max] of 2 numbers");
    Interval iv;
    iv.min = toNumber(node[0], name + "[0]");
    iv.max = toNumber(node[1], name + "[1]");
    if (!(iv.min < iv.max)) fail("'" + name + "' must have min < max");
    return iv;
  }

  // A list of exactly N numbers.
  template <std::size_t N>
  std::array<double, N> numbers(const YAML::Node& parent, const std::string& key, const std::string& where) const {
    const std::string name = where + key;
    const YAML::Node node = child(parent, key, where);
    if (!node.IsSequence() || node.size() != N) {
      fail("'" + name + "' must be a list of " + std::to_string(N) + " numbers");
    }
    std::array<double, N> out{};
    for (std::size_t i = 0; i < N; ++i) out[i] = toNumber(node[i], name + "[" + std::to_string(i) + "]");
    return out;
  }

  // parent[key] when it is there, else `fallback`; malformed values fail as for a required key.
  double optionalNumber(const YAML::Node& parent, const std::string& key, const std::string& where,
                        double fallback) const {
    return parent.IsMap() && parent[key].IsDefined() ? number(parent, key, where) : fallback;
  }
  template <std::size_t N>
  std::array<double, N> optionalNumbers(const YAML::Node& parent, const std::string& key, const std::string& where,
                                        const std::array<double, N>& fallback) const {
    return parent.IsMap() && parent[key].IsDefined() ? numbers<N>(parent, key, where) : fallback;
  }

  std::string text(const YAML::Node& parent, const std::string& key, const std::string& where) const {
    const YAML::Node node = child(parent, key, where);
    if (!node.IsScalar() || node.Scalar().empty()) fail("'" + where + key + "' must be a non-empty string");
    return node.Scalar();
  }

  void requirePositive(double v, const std::string& name) const {
    if (!(v > 0.0)) fail("'" + name + "' must be > 0");
  }
  void requireNonNegative(double v, const std::string& name) const {
    if (!(v >= 0.0)) fail("'" + name + "' must be >= 0");
  }

 private:
  double toNumber(const YAML::Node& node, const std::string& name) const {
    double v = std::numeric_limits<double>::quiet_NaN();
    try {
      if (node.IsScalar()) v = node.as<double>();
    } catch (const YAML::Exception&) {
    }
    if (!std::isfinite(v)) fail("'" + name + "' must be a finite number, got '" + describe(node) + "'");
    return v;
  }

  static std::string describe(const YAML::Node& node) {
    if (node.IsScalar()) return node.Scalar();
    if (node.IsNull()) return "null";
    if (node.IsSequence()) return "<list>";
    if (node.IsMap()) return "<mapping>";
    return "<undefined>";
  }

  std::string source_;
};

// Directory part of a path ("" when there is none).
std::string dirName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return "";
  return slash == 0 ? std::string("/") : path.substr(0, slash);
}

RobotParams readRobot(const Reader& r, const YAML::Node& root, const std::string& base_dir) {
  RobotParams robot;
  const YAML::Node sec = r.child(root, "robot", "");
  robot.urdf = r.text(sec, "urdf", "robot.");
  robot.urdf_path = (robot.urdf[0] == '/' || base_dir.empty()) ? robot.urdf : base_dir + "/" + robot.urdf;
  const YAML::Node dh = r.child(sec, "dh", "robot.");
  robot.dh_d = r.numbers<6>(dh, "d", "robot.dh.");
  robot.dh_a = r.numbers<6>(dh, "a", "robot.dh.");
  robot.dh_alpha = r.numbers<6>(dh, "alpha", "robot.dh.");
  const YAML::Node names = r.child(sec, "joint_names", "robot.");
  if (!names.IsSequence() || names.size() != 6) r.fail("'robot.joint_names' must be a list of 6 names");
  for (const auto& n : names) robot.joint_names.push_back(n.as<std::string>());
  robot.joint_lower = r.numbers<6>(sec, "joint_lower", "robot.");
  robot.joint_upper = r.numbers<6>(sec, "joint_upper", "robot.");
  for (std::size_t i = 0; i < 6; ++i) {
    if (!(robot.joint_lower[i] < robot.joint_upper[i])) r.fail("'robot.joint_lower' must be < 'robot.joint_upper'");
  }
  robot.joint_velocity_limit = r.number(sec, "joint_velocity_limit", "robot.");
  r.requirePositive(robot.joint_velocity_limit, "robot.joint_velocity_limit");
  const YAML::Node arms = r.child(sec, "arms", "robot.");
  if (!arms.IsMap() || arms.size() == 0) r.fail("'robot.arms' must be a non-empty mapping of arm name -> spec");
  for (const auto& kv : arms) {
    ArmSpec arm;
    arm.name = kv.first.as<std::string>();
    const std::string w = "robot.arms." + arm.name + ".";
    arm.xyz = r.numbers<3>(kv.second, "xyz", w);
    arm.rpy = r.numbers<3>(kv.second, "rpy", w);
    arm.home = r.numbers<6>(kv.second, "home", w);
    const std::array<double, 3> branch = r.numbers<3>(kv.second, "ik_branch", w);
    for (std::size_t i = 0; i < 3; ++i) {
      if (branch[i] != 1.0 && branch[i] != -1.0) r.fail("'" + w + "ik_branch' must hold three signs (1 or -1)");
      arm.ik_branch[i] = static_cast<int>(branch[i]);
    }
    robot.arms.push_back(arm);
  }
  return robot;
}

}  // namespace

WorkspaceConfig WorkspaceConfig::fromFile(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw std::runtime_error("workspace config " + path + ": cannot open file");
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("workspace config " + path + ": YAML error: " + e.what());
  }
  // src/pg_description/config/workspace.yaml -> src/
  return fromNode(root, path, dirName(dirName(dirName(path))));
}

WorkspaceConfig WorkspaceConfig::fromString(const std::string& yaml_text, const std::string& source,
                                            const std::string& base_dir) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("workspace config " + source + ": YAML error: " + e.what());
  }
  return fromNode(root, source, base_dir);
}

WorkspaceConfig WorkspaceConfig::fromNode(const YAML::Node& root, const std::string& source,
                                          const std::string& base_dir) {
  const Reader r(source);
  if (!root.IsMap()) r.fail("not a YAML mapping");

  WorkspaceConfig c;
  c.source_ = source;

  const YAML::Node ws = r.child(root, "workspace", "");
  c.x_ = r.interval(ws, "x", "workspace.");
  c.y_ = r.interval(ws, "y", "workspace.");
  c.z_ = r.interval(ws, "z", "workspace.");

  const YAML::Node hm = r.child(root, "heightmap", "");
  c.resolution_ = r.number(hm, "resolution", "heightmap.");
  r.requirePositive(c.resolution_, "heightmap.resolution");
  c.rotations_ = r.integer(hm, "rotations", "heightmap.");
  if (c.rotations_ < 1) r.fail("'heightmap.rotations' must be >= 1");
  // Same rule as pg_core.geometry: round(span / resolution).
  c.rows_ = static_cast<int>(std::lround(c.y_.length() / c.resolution_));
  c.cols_ = static_cast<int>(std::lround(c.x_.length() / c.resolution_));
  if (c.rows_ < 1 || c.cols_ < 1) r.fail("'heightmap.resolution' is larger than the workspace");

  const YAML::Node frames = r.child(root, "frames", "");
  c.world_frame_ = r.text(frames, "world", "frames.");

  const YAML::Node pr = r.child(root, "primitives", "");
  const std::string p = "primitives.";
  PrimitiveParams& prim = c.primitives_;
  prim.approach_height = r.number(pr, "approach_height", p);
  prim.grasp_depth = r.number(pr, "grasp_depth", p);
  prim.grasp_min_z = r.number(pr, "grasp_min_z", p);
  prim.lift_height = r.number(pr, "lift_height", p);
  prim.push_length = r.number(pr, "push_length", p);
  prim.push_depth = r.number(pr, "push_depth", p);
  prim.push_min_z = r.number(pr, "push_min_z", p);
  prim.push_window_px = r.integer(pr, "push_window_px", p);
  prim.transit_height = r.number(pr, "transit_height", p);
  prim.cartesian_speed = r.number(pr, "cartesian_speed", p);
  prim.push_speed = r.number(pr, "push_speed", p);
  prim.waypoint_step = r.number(pr, "waypoint_step", p);
  prim.time_budget = r.number(pr, "time_budget", p);
  r.requireNonNegative(prim.approach_height, p + "approach_height");
  r.requireNonNegative(prim.grasp_depth, p + "grasp_depth");
  r.requireNonNegative(prim.lift_height, p + "lift_height");
  r.requirePositive(prim.push_length, p + "push_length");
  r.requireNonNegative(prim.push_depth, p + "push_depth");
  r.requireNonNegative(prim.push_window_px, p + "push_window_px");
  r.requirePositive(prim.cartesian_speed, p + "cartesian_speed");
  r.requirePositive(prim.push_speed, p + "push_speed");
  r.requirePositive(prim.waypoint_step, p + "waypoint_step");
  r.requirePositive(prim.time_budget, p + "time_budget");
  prim.grasp_low_heights = r.optionalNumbers<2>(pr, "grasp_low_heights", p, {0.0, 0.0});
  prim.grasp_low_fraction = r.optionalNumber(pr, "grasp_low_fraction", p, 0.0);
  prim.grasp_low_min_z = r.optionalNumber(pr, "grasp_low_min_z", p, 0.0);
  if (!(0.0 <= prim.grasp_low_heights[0] && prim.grasp_low_heights[0] <= prim.grasp_low_heights[1])) {
    r.fail("'" + p + "grasp_low_heights' must be [lo, hi] heights with 0 <= lo <= hi (m)");
  }
  if (!(prim.grasp_low_fraction >= 0.0 && prim.grasp_low_fraction <= 1.0)) {
    r.fail("'" + p + "grasp_low_fraction' must lie in [0, 1]");
  }
  r.requireNonNegative(prim.grasp_low_min_z, p + "grasp_low_min_z");

  const YAML::Node gr = r.child(root, "gripper", "");
  c.gripper_.max_opening = r.number(gr, "max_opening", "gripper.");
  c.gripper_.tcp_offset = r.number(gr, "tcp_offset", "gripper.");
  r.requirePositive(c.gripper_.max_opening, "gripper.max_opening");
  r.requireNonNegative(c.gripper_.tcp_offset, "gripper.tcp_offset");
  c.gripper_.closed_threshold = r.number(gr, "closed_threshold", "gripper.");
  r.requireNonNegative(c.gripper_.closed_threshold, "gripper.closed_threshold");

  c.robot_ = readRobot(r, root, base_dir);

  return c;
}

const ArmSpec* WorkspaceConfig::arm(const std::string& name) const {
  for (const auto& a : robot_.arms) {
    if (a.name == name) return &a;
  }
  return nullptr;
}

bool WorkspaceConfig::contains(double x, double y, double z) const {
  return x_.contains(x, kContainsTolerance) && y_.contains(y, kContainsTolerance) && z_.contains(z, kContainsTolerance);
}

PointXY WorkspaceConfig::pixelToWorld(int row, int col) const {
  return {x_.min + (col + 0.5) * resolution_, y_.min + (row + 0.5) * resolution_};
}

Pixel WorkspaceConfig::worldToPixel(double x, double y) const {
  const double col = std::floor((x - x_.min) / resolution_);
  const double row = std::floor((y - y_.min) / resolution_);
  constexpr double kLo = std::numeric_limits<int>::min();
  constexpr double kHi = std::numeric_limits<int>::max();
  if (!(col >= kLo && col <= kHi && row >= kLo && row <= kHi)) {
    throw std::out_of_range("worldToPixel: (" + std::to_string(x) + ", " + std::to_string(y) +
                            ") is not a finite point near the workspace");
  }
  return {static_cast<int>(row), static_cast<int>(col)};
}

double WorkspaceConfig::rotationToYaw(int r) const {
  if (r < 0 || r >= rotations_) {
    throw std::out_of_range("rotationToYaw: rotation index " + std::to_string(r) + " not in [0, " +
                            std::to_string(rotations_) + ")");
  }
  return r * 2.0 * kPi / rotations_;
}

}  // namespace pg_core
