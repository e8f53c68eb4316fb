// Unit tests for pg_core::WorkspaceConfig (ROS-free; no roscore).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "pg_core/workspace_config.h"

#ifndef PG_WORKSPACE_YAML
#error "PG_WORKSPACE_YAML (path of catkin_ws/src/pg_description/config/workspace.yaml) must be defined by the build"
#endif

namespace pg_core {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kEps = 1e-12;

// A complete, valid config with one `key: value` per line; sections are unindented lines ending in ':'.
const std::vector<std::string> kMinimalLines = {
    "frames:",
    "  world: world",
    "workspace:",
    "  x: [-0.1, 0.1]",
    "  y: [-0.05, 0.05]",
    "  z: [0.0, 0.3]",
    "heightmap:",
    "  resolution: 0.01",
    "  rotations: 8",
    "primitives:",
    "  approach_height: 0.1",
    "  grasp_depth: 0.04",
    "  grasp_min_z: 0.02",
    "  lift_height: 0.1",
    "  push_length: 0.13",
    "  push_depth: 0.01",
    "  push_min_z: 0.005",
    "  push_window_px: 5",
    "  transit_height: 0.3",
    "  cartesian_speed: 0.3",
    "  push_speed: 0.1",
    "  waypoint_step: 0.01",
    "  time_budget: 8.0",
    "gripper:",
    "  max_opening: 0.085",
    "  tcp_offset: 0.15",
    "  closed_threshold: 0.004",
    "robot:",
    "  urdf: pg_description/urdf/pushgrasp.urdf",
    "  dh: {d: [0.1625, 0, 0, 0.1333, 0.0997, 0.0996], a: [0, -0.425, -0.3922, 0, 0, 0], alpha: [1.57, 0, 0, 1.57, "
    "-1.57, 0]}",
    "  joint_names: [j1, j2, j3, j4, j5, j6]",
    "  joint_lower: [-6, -6, -3, -6, -6, -6]",
    "  joint_upper: [6, 6, 3, 6, 6, 6]",
    "  joint_velocity_limit: 3.14",
    "  arms: {left: {xyz: [0, 0.5, 0], rpy: [0, 0, -1.57], home: [0, -1, 1, 0, -1, 0], ik_branch: [1, -1, 1]}}",
};

// The minimal config without the entry `dotted` ("section" drops the whole section, "section.key" one line).
std::string withoutKey(const std::string& dotted) {
  const auto dot = dotted.find('.');
  const std::string section = dotted.substr(0, dot);
  const std::string key = dot == std::string::npos ? "" : dotted.substr(dot + 1);
  std::string text;
  std::string current;
  for (const auto& line : kMinimalLines) {
    const bool is_section = line.back() == ':' && line[0] != ' ';
    if (is_section) current = line.substr(0, line.size() - 1);
    const bool drop = current == section && (key.empty() || (!is_section && line.rfind("  " + key + ":", 0) == 0));
    if (!drop) text += line + "\n";
  }
  return text;
}

std::string errorOf(const std::string& yaml_text) {
  try {
    WorkspaceConfig::fromString(yaml_text, "test.yaml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(WorkspaceConfig, LoadsTheSharedConfigFile) {
  const WorkspaceConfig c = WorkspaceConfig::fromFile(PG_WORKSPACE_YAML);
  EXPECT_EQ(c.source(), PG_WORKSPACE_YAML);
  EXPECT_EQ(c.worldFrame(), "world");
  EXPECT_DOUBLE_EQ(c.xRange().min, -0.224);
  EXPECT_DOUBLE_EQ(c.xRange().max, 0.224);
  EXPECT_DOUBLE_EQ(c.yRange().min, -0.224);
  EXPECT_DOUBLE_EQ(c.yRange().max, 0.224);
  EXPECT_DOUBLE_EQ(c.zRange().min, 0.0);
  EXPECT_DOUBLE_EQ(c.zRange().max, 0.4);
  EXPECT_DOUBLE_EQ(c.resolution(), 0.002);
  EXPECT_EQ(c.rows(), 224);  // DESIGN.md section 3: 224 x 224 cells at 0.002 m
  EXPECT_EQ(c.cols(), 224);
  EXPECT_EQ(c.rotations(), 16);

  const PrimitiveParams& p = c.primitives();  // DESIGN.md section 4
  EXPECT_DOUBLE_EQ(p.approach_height, 0.10);
  EXPECT_DOUBLE_EQ(p.grasp_depth, 0.04);
  EXPECT_DOUBLE_EQ(p.grasp_min_z,
                   0.012);  // DESIGN says 0.02 for its grasp point; ours is the fingertip end (docs/ARCHITECTURE.md)
  EXPECT_DOUBLE_EQ(p.lift_height, 0.10);
  EXPECT_DOUBLE_EQ(p.push_length, 0.13);
  EXPECT_DOUBLE_EQ(p.push_depth, 0.01);
  EXPECT_DOUBLE_EQ(p.push_min_z, 0.005);
  EXPECT_EQ(p.push_window_px, 5);
  EXPECT_GT(p.cartesian_speed, 0.0);
  EXPECT_GT(p.waypoint_step, 0.0);
  EXPECT_GT(p.time_budget, 0.0);

  EXPECT_DOUBLE_EQ(p.transit_height, 0.30);
  EXPECT_DOUBLE_EQ(p.push_speed, 0.1);
  // Low objects take their own grasp z (docs/ARCHITECTURE.md); 20 mm and taller keep DESIGN section 4's rule.
  EXPECT_DOUBLE_EQ(p.grasp_low_heights[0], 0.002);
  EXPECT_DOUBLE_EQ(p.grasp_low_heights[1], 0.02);
  EXPECT_DOUBLE_EQ(p.grasp_low_fraction, 0.35);
  EXPECT_DOUBLE_EQ(p.grasp_low_min_z, 0.0015);

  EXPECT_DOUBLE_EQ(c.gripper().max_opening, 0.085);
  EXPECT_GT(c.gripper().tcp_offset, 0.0);
  EXPECT_DOUBLE_EQ(c.gripper().closed_threshold, 0.004);

  const RobotParams& r = c.robot();  // DESIGN.md section 3: UR5e
  EXPECT_DOUBLE_EQ(r.dh_d[0], 0.1625);
  EXPECT_DOUBLE_EQ(r.dh_a[1], -0.425);
  EXPECT_DOUBLE_EQ(r.dh_a[2], -0.3922);
  EXPECT_DOUBLE_EQ(r.dh_d[3], 0.1333);
  EXPECT_DOUBLE_EQ(r.dh_d[4], 0.0997);
  EXPECT_DOUBLE_EQ(r.dh_d[5], 0.0996);
  EXPECT_NEAR(r.joint_velocity_limit, kPi, 1e-12);
  EXPECT_NEAR(r.joint_upper[2], kPi, 1e-12);
  EXPECT_NEAR(r.joint_lower[0], -2 * kPi, 1e-12);
  ASSERT_EQ(r.joint_names.size(), 6u);
  EXPECT_EQ(r.joint_names[0], "shoulder_pan_joint");
  ASSERT_EQ(r.arms.size(), 2u);
  ASSERT_NE(c.arm("left"), nullptr);
  ASSERT_NE(c.arm("right"), nullptr);
  EXPECT_EQ(c.arm("middle"), nullptr);
  EXPECT_DOUBLE_EQ(c.arm("left")->xyz[1], 0.5);
  EXPECT_DOUBLE_EQ(c.arm("right")->xyz[1], -0.5);
  EXPECT_EQ(c.arm("left")->ik_branch[1], -1);
  // robot.urdf is relative to catkin_ws/src, i.e. three directories above the config file.
  EXPECT_EQ(r.urdf, "pg_description/urdf/pushgrasp.urdf");
  const std::string yaml = PG_WORKSPACE_YAML;
  const std::string src = yaml.substr(0, yaml.size() - std::string("pg_description/config/workspace.yaml").size());
  EXPECT_EQ(r.urdf_path, src + "pg_description/urdf/pushgrasp.urdf");
}

TEST(WorkspaceConfig, RelativeUrdfUsesBaseDir) {
  EXPECT_EQ(WorkspaceConfig::fromString(withoutKey(""), "t", "/a/src").robot().urdf_path,
            "/a/src/pg_description/urdf/pushgrasp.urdf");
  EXPECT_EQ(WorkspaceConfig::fromString(withoutKey("")).robot().urdf_path, "pg_description/urdf/pushgrasp.urdf");
  std::string text = withoutKey("primitives.push_speed");
  EXPECT_NE(errorOf(text).find("missing key 'primitives.push_speed'"), std::string::npos);
  text = withoutKey("robot.arms") +
         "  arms: {left: {xyz: [0, 0, 0], rpy: [0, 0, 0], home: [0, 0, 0, 0, 0, 0], "
         "ik_branch: [1, 0, 1]}}\n";
  EXPECT_NE(errorOf(text).find("'robot.arms.left.ik_branch' must hold three signs"), std::string::npos)
      << errorOf(text);
}

TEST(WorkspaceConfig, MinimalConfigIsValid) {
  EXPECT_EQ(errorOf(withoutKey("")), "");
  const WorkspaceConfig c = WorkspaceConfig::fromString(withoutKey(""));
  EXPECT_EQ(c.cols(), 20);
  EXPECT_EQ(c.rows(), 10);
  EXPECT_EQ(c.rotations(), 8);
  EXPECT_EQ(c.worldFrame(), "world");
}

TEST(WorkspaceConfig, LowGraspKeysAreOptionalAndChecked) {
  const PrimitiveParams off = WorkspaceConfig::fromString(withoutKey("")).primitives();
  EXPECT_DOUBLE_EQ(off.grasp_low_heights[0], 0.0);  // absent: an empty range, the section 4 rule everywhere
  EXPECT_DOUBLE_EQ(off.grasp_low_heights[1], 0.0);
  EXPECT_DOUBLE_EQ(off.grasp_low_fraction, 0.0);
  EXPECT_DOUBLE_EQ(off.grasp_low_min_z, 0.0);

  const auto with = [](const std::string& lines) {
    std::string text = withoutKey("");
    text.replace(text.find("primitives:\n"), 12, "primitives:\n" + lines);
    return text;
  };
  const PrimitiveParams on =
      WorkspaceConfig::fromString(
          with("  grasp_low_heights: [0.002, 0.02]\n  grasp_low_fraction: 0.35\n  grasp_low_min_z: 0.0015\n"))
          .primitives();
  EXPECT_DOUBLE_EQ(on.grasp_low_heights[0], 0.002);
  EXPECT_DOUBLE_EQ(on.grasp_low_heights[1], 0.02);
  EXPECT_DOUBLE_EQ(on.grasp_low_fraction, 0.35);
  EXPECT_DOUBLE_EQ(on.grasp_low_min_z, 0.0015);

  const std::vector<std::pair<std::string, std::string>> bad = {
      {"  grasp_low_heights: [0.02, 0.002]\n", "'primitives.grasp_low_heights' must be [lo, hi]"},
      {"  grasp_low_heights: [-0.001, 0.02]\n", "'primitives.grasp_low_heights' must be [lo, hi]"},
      {"  grasp_low_heights: [0.002]\n", "'primitives.grasp_low_heights' must be a list of 2 numbers"},
      {"  grasp_low_heights: [abc, 0.02]\n", "'primitives.grasp_low_heights[0]' must be a finite number"},
      {"  grasp_low_fraction: 1.5\n", "'primitives.grasp_low_fraction' must lie in [0, 1]"},
      {"  grasp_low_min_z: -0.001\n", "'primitives.grasp_low_min_z' must be >= 0"},
  };
  for (const auto& [line, want] : bad) {
    EXPECT_NE(errorOf(with(line)).find(want), std::string::npos) << line << " -> " << errorOf(with(line));
  }
}

TEST(WorkspaceConfig, MissingKeyIsNamed) {
  const std::vector<std::string> keys = {
      "workspace",
      "workspace.x",
      "workspace.y",
      "workspace.z",
      "heightmap",
      "heightmap.resolution",
      "heightmap.rotations",
      "frames",
      "frames.world",
      "primitives",
      "primitives.approach_height",
      "primitives.grasp_depth",
      "primitives.grasp_min_z",
      "primitives.lift_height",
      "primitives.push_length",
      "primitives.push_depth",
      "primitives.push_min_z",
      "primitives.push_window_px",
      "primitives.cartesian_speed",
      "primitives.waypoint_step",
      "primitives.time_budget",
      "gripper",
      "gripper.max_opening",
      "gripper.tcp_offset",
      "gripper.closed_threshold",
      "primitives.transit_height",
      "primitives.push_speed",
      "robot",
      "robot.urdf",
      "robot.dh",
      "robot.joint_names",
      "robot.joint_lower",
      "robot.joint_upper",
      "robot.joint_velocity_limit",
      "robot.arms",
  };
  for (const auto& key : keys) {
    const std::string text = withoutKey(key);
    ASSERT_NE(text, withoutKey("")) << key;
    const std::string err = errorOf(text);
    EXPECT_NE(err.find("missing key '" + key + "'"), std::string::npos) << key << " -> " << err;
    EXPECT_NE(err.find("test.yaml"), std::string::npos) << err;
  }
}

TEST(WorkspaceConfig, MalformedValuesAreNamed) {
  std::string text = withoutKey("heightmap.resolution");
  text.replace(text.find("heightmap:\n"), 11, "heightmap:\n  resolution: abc\n");
  EXPECT_NE(errorOf(text).find("'heightmap.resolution' must be a finite number"), std::string::npos) << errorOf(text);

  text = withoutKey("workspace.x");
  text.replace(text.find("workspace:\n"), 11, "workspace:\n  x: [0.1]\n");
  EXPECT_NE(errorOf(text).find("'workspace.x' must be a list"), std::string::npos) << errorOf(text);

  text = withoutKey("workspace.z");
  text.replace(text.find("workspace:\n"), 11, "workspace:\n  z: [0.3, 0.0]\n");
  EXPECT_NE(errorOf(text).find("'workspace.z' must have min < max"), std::string::npos) << errorOf(text);

  text = withoutKey("heightmap.rotations");
  text.replace(text.find("heightmap:\n"), 11, "heightmap:\n  rotations: 2.5\n");
  EXPECT_NE(errorOf(text).find("'heightmap.rotations' must be an integer"), std::string::npos) << errorOf(text);

  EXPECT_NE(errorOf("workspace: 5\n").find("missing key 'workspace.x' ('workspace' is not a mapping)"),
            std::string::npos)
      << errorOf("workspace: 5\n");
  text = withoutKey("frames.world");
  text.replace(text.find("frames:\n"), 8, "frames:\n  world: [a, b]\n");
  EXPECT_NE(errorOf(text).find("'frames.world' must be a non-empty string"), std::string::npos) << errorOf(text);

  EXPECT_NE(errorOf("- just\n- a list\n").find("not a YAML mapping"), std::string::npos);
  EXPECT_NE(errorOf("workspace: [unclosed\n").find("YAML error"), std::string::npos);
}

TEST(WorkspaceConfig, MissingFileIsNamed) {
  try {
    WorkspaceConfig::fromFile("/nonexistent/pg/workspace.yaml");
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/pg/workspace.yaml"), std::string::npos) << e.what();
  }
}

TEST(WorkspaceConfig, ContainsIsTheClosedBox) {
  const WorkspaceConfig c = WorkspaceConfig::fromFile(PG_WORKSPACE_YAML);
  EXPECT_TRUE(c.contains(0.0, 0.0, 0.0));
  EXPECT_TRUE(c.contains(-0.224, -0.224, 0.0));
  EXPECT_TRUE(c.contains(0.224, 0.224, 0.4));
  EXPECT_TRUE(c.contains(0.1, -0.2, 0.05));
  EXPECT_FALSE(c.contains(0.225, 0.0, 0.1));
  EXPECT_FALSE(c.contains(0.0, -0.2241, 0.1));
  EXPECT_FALSE(c.contains(0.0, 0.0, -0.001));
  EXPECT_FALSE(c.contains(0.0, 0.0, 0.401));
  EXPECT_FALSE(c.contains(std::nan(""), 0.0, 0.1));
}

TEST(WorkspaceConfig, PixelToWorldGivesCellCentres) {
  const WorkspaceConfig c = WorkspaceConfig::fromFile(PG_WORKSPACE_YAML);
  PointXY p = c.pixelToWorld(0, 0);
  EXPECT_NEAR(p.x, -0.223, kEps);
  EXPECT_NEAR(p.y, -0.223, kEps);
  p = c.pixelToWorld(223, 223);
  EXPECT_NEAR(p.x, 0.223, kEps);
  EXPECT_NEAR(p.y, 0.223, kEps);
  // Row indexes y, column indexes x.
  p = c.pixelToWorld(10, 100);
  EXPECT_NEAR(p.x, -0.224 + 100.5 * 0.002, kEps);
  EXPECT_NEAR(p.y, -0.224 + 10.5 * 0.002, kEps);
}

TEST(WorkspaceConfig, WorldToPixelFloorsAndRoundTrips) {
  const WorkspaceConfig c = WorkspaceConfig::fromFile(PG_WORKSPACE_YAML);
  Pixel px = c.worldToPixel(-0.224, -0.224);
  EXPECT_EQ(px.row, 0);
  EXPECT_EQ(px.col, 0);
  px = c.worldToPixel(-0.224 + 0.0019, -0.224 + 0.0021);  // floor, not round
  EXPECT_EQ(px.col, 0);
  EXPECT_EQ(px.row, 1);
  px = c.worldToPixel(0.1005, -0.2005);  // x -> col, y -> row
  EXPECT_EQ(px.col, 162);
  EXPECT_EQ(px.row, 11);
  EXPECT_TRUE(c.isInGrid(px));

  // Just outside the grid on either side.
  px = c.worldToPixel(-0.2241, 0.2239);
  EXPECT_EQ(px.col, -1);
  EXPECT_EQ(px.row, 223);
  EXPECT_FALSE(c.isInGrid(px));
  px = c.worldToPixel(0.2241, 0.0);
  EXPECT_EQ(px.col, 224);
  EXPECT_FALSE(c.isInGrid(px));

  for (int row = 0; row < c.rows(); ++row) {
    for (int col = 0; col < c.cols(); ++col) {
      const PointXY w = c.pixelToWorld(row, col);
      ASSERT_TRUE(c.contains(w.x, w.y, 0.0)) << row << "," << col;
      const Pixel back = c.worldToPixel(w.x, w.y);
      ASSERT_EQ(back.row, row);
      ASSERT_EQ(back.col, col);
    }
  }
  EXPECT_THROW(c.worldToPixel(std::nan(""), 0.0), std::out_of_range);
  EXPECT_THROW(c.worldToPixel(0.0, 1e300), std::out_of_range);
}

TEST(WorkspaceConfig, RotationToYaw) {
  const WorkspaceConfig c = WorkspaceConfig::fromFile(PG_WORKSPACE_YAML);
  EXPECT_DOUBLE_EQ(c.rotationToYaw(0), 0.0);
  EXPECT_NEAR(c.rotationToYaw(1), 22.5 * kPi / 180.0, kEps);
  EXPECT_NEAR(c.rotationToYaw(4), kPi / 2.0, kEps);
  EXPECT_NEAR(c.rotationToYaw(8), kPi, kEps);
  EXPECT_NEAR(c.rotationToYaw(15), 15.0 * kPi / 8.0, kEps);
  EXPECT_THROW(c.rotationToYaw(16), std::out_of_range);
  EXPECT_THROW(c.rotationToYaw(-1), std::out_of_range);
}

}  // namespace
}  // namespace pg_core

// catkin_add_gtest links GTest::gtest only (no gtest_main), so the test brings its own main().
int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
