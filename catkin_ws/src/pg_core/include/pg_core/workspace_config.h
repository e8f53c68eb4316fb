// Shared geometry config (catkin_ws/src/pg_description/config/workspace.yaml) for the C++ side, ROS-free.
//
// The one C++ reader of workspace.yaml: every C++ node (pg_control's primitive controller, pg_policy's heightmap
// projector) gets its geometry from pg_core::WorkspaceConfig and never parses the file itself.
// This is the C++ owner of the pixel + rotation <-> world mapping of DESIGN.md section 3. Python reads the same file
// in pg_core.geometry, and the Python mapping must agree with this one (the two are to be tested against each other).
// Units: metres, radians, seconds. Positions are in the `world` frame.
#ifndef PG_CORE_WORKSPACE_CONFIG_H
#define PG_CORE_WORKSPACE_CONFIG_H

#include <array>
#include <string>
#include <vector>

namespace YAML {
class Node;
}  // namespace YAML

namespace pg_core {

// Closed interval [min, max] along one axis (m).
struct Interval {
  double min = 0.0;
  double max = 0.0;

  double length() const { return max - min; }
  bool contains(double v, double tol = 0.0) const { return v >= min - tol && v <= max + tol; }
};

// A heightmap cell: row indexes y, col indexes x (VPG/ravens convention). May lie outside the grid.
struct Pixel {
  int row = 0;
  int col = 0;
};

// A point in the table plane of `world` (m).
struct PointXY {
  double x = 0.0;
  double y = 0.0;
};

// `primitives:` section (DESIGN.md section 4). Field names are the YAML keys.
struct PrimitiveParams {
  double approach_height = 0.0;  // pre-pose above the action point (m)
  double grasp_depth = 0.0;      // grasp z = max(h - grasp_depth, grasp_min_z) outside grasp_low_heights (m)
  double grasp_min_z = 0.0;      // (m)
  double lift_height = 0.0;      // lift after closing (m)
  double push_length = 0.0;      // push travel along yaw (m)
  double push_depth = 0.0;       // push z = local max height - push_depth, never below push_min_z (m)
  double push_min_z = 0.0;       // (m)
  int push_window_px = 0;        // half-size of the local window for the push height (cells)
  double transit_height = 0.0;   // TCP z of free-space moves between home and the pre-pose (m)
  double cartesian_speed = 0.0;  // tool speed along straight-line segments (m/s)
  double push_speed = 0.0;       // tool speed while pushing (m/s)
  double waypoint_step = 0.0;    // Cartesian interpolation step (m)
  double time_budget = 0.0;      // seconds per primitive before it is aborted (s)
  // Low objects (pg_core.action_geometry.grasp_z_for_height): a local height h in [grasp_low_heights[0],
  // grasp_low_heights[1]) takes grasp z = max(grasp_low_fraction * h, grasp_low_min_z). Optional keys; absent = an
  // empty range (the DESIGN section 4 rule everywhere).
  std::array<double, 2> grasp_low_heights{};  // [lo, hi) (m), 0 <= lo <= hi
  double grasp_low_fraction = 0.0;            // in [0, 1]
  double grasp_low_min_z = 0.0;               // (m), >= 0
};

// `gripper:` section, the part the controller needs.
struct GripperParams {
  double max_opening = 0.0;       // m between the finger pads
  double tcp_offset = 0.0;        // tool0 -> fingertip centre along tool0 z (m)
  double closed_threshold = 0.0;  // opening (m) below which the gripper counts as fully closed
};

// One arm of `robot.arms` (joint and link names get the prefix `<name>_`).
struct ArmSpec {
  std::string name;                // "left", "right"
  std::array<double, 3> xyz{};     // `<name>_base_link` origin in `world` (m)
  std::array<double, 3> rpy{};     // its URDF fixed-axis roll-pitch-yaw in `world` (rad)
  std::array<double, 6> home{};    // home joint angles (rad)
  std::array<int, 3> ik_branch{};  // (shoulder, wrist, elbow) signs of the closed-form IK branch (pg_sim.robot.ur_ik)
};

// `robot:` section (DESIGN.md section 3). Joint arrays are in joint order shoulder_pan .. wrist_3.
struct RobotParams {
  std::string urdf;                      // as written in the file (relative to the catkin src dir unless absolute)
  std::string urdf_path;                 // resolved: see WorkspaceConfig::fromFile
  std::array<double, 6> dh_d{};          // standard DH d (m)
  std::array<double, 6> dh_a{};          // standard DH a (m)
  std::array<double, 6> dh_alpha{};      // standard DH alpha (rad)
  std::vector<std::string> joint_names;  // unprefixed, e.g. "shoulder_pan_joint"
  std::array<double, 6> joint_lower{};   // rad
  std::array<double, 6> joint_upper{};   // rad
  double joint_velocity_limit = 0.0;     // rad/s, every joint
  std::vector<ArmSpec> arms;             // in file order
};

class WorkspaceConfig {
 public:
  // Loads and validates a workspace.yaml. Throws std::runtime_error naming the file and, for a missing or malformed
  // entry, the dotted key (e.g. "missing key 'heightmap.resolution'").
  // A relative `robot.urdf` is resolved against the catkin src dir that holds the file, i.e. three directories up
  // (src/pg_description/config/workspace.yaml -> src/; also right for an install space's share/<pkg>/config/), as
  // pg_core.geometry does.
  static WorkspaceConfig fromFile(const std::string& path);
  // Same from YAML text; `source` names it in error messages. A relative `robot.urdf` is resolved against
  // `base_dir` (unchanged when `base_dir` is empty).
  static WorkspaceConfig fromString(const std::string& yaml_text, const std::string& source = "<string>",
                                    const std::string& base_dir = "");

  const std::string& source() const { return source_; }

  // `frames.world`: name of the TF frame every position of this config is expressed in (non-empty).
  const std::string& worldFrame() const { return world_frame_; }

  // Workspace box around `world` that every commanded pose must lie in (m).
  const Interval& xRange() const { return x_; }
  const Interval& yRange() const { return y_; }
  const Interval& zRange() const { return z_; }
  // True if (x, y, z) lies in the box (boundary included, with the same 1e-9 m tolerance as pg_core.geometry).
  bool contains(double x, double y, double z) const;

  // Heightmap grid: resolution (m per cell), rows along y and cols along x, each round(span / resolution).
  double resolution() const { return resolution_; }
  int rows() const { return rows_; }
  int cols() const { return cols_; }
  int rotations() const { return rotations_; }

  // Centre of cell (row, col): x = x_min + (col + 0.5) * res, y = y_min + (row + 0.5) * res. Defined for any
  // indices, including ones outside the grid.
  PointXY pixelToWorld(int row, int col) const;
  // Cell containing (x, y): col = floor((x - x_min) / res), row = floor((y - y_min) / res). The result may lie
  // outside the grid; check it with isInGrid().
  Pixel worldToPixel(double x, double y) const;
  bool isInGrid(const Pixel& p) const { return p.row >= 0 && p.row < rows_ && p.col >= 0 && p.col < cols_; }

  // Rotation index r in [0, rotations) -> yaw = r * 2 pi / rotations (rad). Throws std::out_of_range otherwise.
  double rotationToYaw(int r) const;

  const PrimitiveParams& primitives() const { return primitives_; }
  const GripperParams& gripper() const { return gripper_; }
  const RobotParams& robot() const { return robot_; }
  // The arm called `name`, or nullptr.
  const ArmSpec* arm(const std::string& name) const;

 private:
  WorkspaceConfig() = default;
  static WorkspaceConfig fromNode(const YAML::Node& root, const std::string& source, const std::string& base_dir);

  std::string source_;
  std::string world_frame_;
  Interval x_;
  Interval y_;
  Interval z_;
  double resolution_ = 0.0;
  int rotations_ = 0;
  int rows_ = 0;
  int cols_ = 0;
  PrimitiveParams primitives_;
  GripperParams gripper_;
  RobotParams robot_;
};

}  // namespace pg_core

#endif  // PG_CORE_WORKSPACE_CONFIG_H
