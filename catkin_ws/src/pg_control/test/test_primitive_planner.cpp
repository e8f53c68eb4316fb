// Unit tests for pg_control::PrimitivePlanner and the Cartesian interpolation (ROS-free; no roscore).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "pg_control/cartesian_path.h"
#include "pg_control/primitive_planner.h"
#include "pg_control/tool_pose.h"
#include "pg_control/urdf_chain.h"

namespace pg_control {
namespace {

constexpr double kPi = 3.14159265358979323846;
using Kind = PrimitiveStep::Kind;

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos) throw std::runtime_error("test fixture: '" + from + "' not found");
  return text.replace(at, from.size(), to);
}

class PrimitivePlannerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    config_ = new pg_core::WorkspaceConfig(pg_core::WorkspaceConfig::fromFile(PG_WORKSPACE_YAML));
    model_ = new UrdfModelPtr(loadUrdfFile(config_->robot().urdf_path));
    planner_ = new PrimitivePlanner(*config_, **model_);
  }
  static void TearDownTestSuite() {
    delete planner_;
    delete model_;
    delete config_;
  }

  static std::map<std::string, JointVector> atHome() {
    return {{"left", planner_->home("left")}, {"right", planner_->home("right")}};
  }

  static std::vector<std::string> stepNames(const PrimitivePlan& plan) {
    std::vector<std::string> names;
    for (const auto& s : plan.steps) names.push_back(s.name);
    return names;
  }

  static const PrimitiveStep& step(const PrimitivePlan& plan, const std::string& name) {
    for (const auto& s : plan.steps) {
      if (s.name == name) return s;
    }
    throw std::runtime_error("no step " + name);
  }

  // Every waypoint of a Cartesian step puts the TCP, pointing down at yaw, on its listed point.
  static void expectOnLine(const PrimitivePlan& plan, const std::string& name, double yaw) {
    const PrimitiveStep& s = step(plan, name);
    ASSERT_EQ(s.tcp_points.size(), s.motion.positions.size()) << name;
    const ArmKinematics& arm = planner_->arm(plan.arm);
    for (std::size_t k = 0; k < s.tcp_points.size(); ++k) {
      const Eigen::Isometry3d want = toolDownPose(s.tcp_points[k], yaw);
      const Eigen::Isometry3d got = arm.fk(s.motion.positions[k]);
      ASSERT_LT(positionError(got, want), 1e-5) << name << " #" << k;
      ASSERT_LT(rotationError(got, want), 1e-4) << name << " #" << k;
      if (k) {
        ASSERT_LE((s.tcp_points[k] - s.tcp_points[k - 1]).norm(), config_->primitives().waypoint_step + 1e-12);
        ASSERT_LE((s.motion.positions[k] - s.motion.positions[k - 1]).cwiseAbs().maxCoeff(), 0.5);
      }
    }
  }

  static std::string refusal(const PrimitiveRequest& r, const PrimitivePlanner& planner = *planner_) {
    try {
      planner.plan(r, atHome());
    } catch (const PrimitiveRefused& e) {
      return e.what();
    }
    return "";
  }

  static pg_core::WorkspaceConfig* config_;
  static UrdfModelPtr* model_;
  static PrimitivePlanner* planner_;
};

pg_core::WorkspaceConfig* PrimitivePlannerTest::config_ = nullptr;
UrdfModelPtr* PrimitivePlannerTest::model_ = nullptr;
PrimitivePlanner* PrimitivePlannerTest::planner_ = nullptr;

TEST_F(PrimitivePlannerTest, GraspSequenceMatchesPgSim) {
  PrimitiveRequest r;
  r.type = PrimitiveType::kGrasp;
  r.position = Eigen::Vector3d(0.05, -0.1, 0.03);
  r.yaw = 0.4;
  const PrimitivePlan plan = planner_->plan(r, atHome());
  EXPECT_EQ(plan.arm, "right");  // closest base to the pre-grasp pose
  EXPECT_EQ(stepNames(plan),
            (std::vector<std::string>{"open", "transit", "approach", "close", "lift", "check", "home", "release"}));
  const pg_core::GripperParams& g = config_->gripper();
  const pg_core::PrimitiveParams& pr = config_->primitives();
  EXPECT_EQ(step(plan, "open").kind, Kind::kGripper);
  EXPECT_DOUBLE_EQ(step(plan, "open").opening, g.max_opening);
  EXPECT_FALSE(step(plan, "open").wait);
  EXPECT_DOUBLE_EQ(step(plan, "close").opening, 0.0);
  EXPECT_TRUE(step(plan, "close").wait);
  EXPECT_EQ(step(plan, "check").kind, Kind::kCheckGrasp);
  EXPECT_DOUBLE_EQ(step(plan, "release").opening, g.max_opening);
  EXPECT_TRUE(step(plan, "release").wait);

  // approach: above (transit height) -> pre-grasp (approach_height above) -> grasp point, 1 cm steps.
  const PrimitiveStep& approach = step(plan, "approach");
  ASSERT_EQ(approach.tcp_points.size(), 1u + 17u + 10u);
  EXPECT_LT((approach.tcp_points.front() - Eigen::Vector3d(0.05, -0.1, pr.transit_height)).norm(), 1e-12);
  EXPECT_LT((approach.tcp_points[17] - Eigen::Vector3d(0.05, -0.1, 0.03 + pr.approach_height)).norm(), 1e-12);
  EXPECT_LT((approach.tcp_points.back() - r.position).norm(), 1e-12);
  expectOnLine(plan, "approach", r.yaw);
  const PrimitiveStep& lift = step(plan, "lift");
  ASSERT_EQ(lift.tcp_points.size(), 11u);
  EXPECT_LT((lift.tcp_points.back() - Eigen::Vector3d(0.05, -0.1, 0.03 + pr.lift_height)).norm(), 1e-12);
  expectOnLine(plan, "lift", r.yaw);

  // Joint continuity: transit home -> first approach waypoint, lift starts where approach ended, home ends at home.
  const PrimitiveStep& transit = step(plan, "transit");
  EXPECT_LT((transit.motion.positions.front() - planner_->home("right")).norm(), 1e-12);
  EXPECT_LT((transit.motion.positions.back() - approach.motion.positions.front()).norm(), 1e-12);
  EXPECT_LT((lift.motion.positions.front() - approach.motion.positions.back()).norm(), 1e-12);
  const PrimitiveStep& home = step(plan, "home");
  EXPECT_LT((home.motion.positions.front() - lift.motion.positions.back()).norm(), 1e-12);
  EXPECT_LT((home.motion.positions.back() - planner_->home("right")).norm(), 1e-12);
  EXPECT_EQ(planner_->arm("right").branchOf(approach.motion.positions.back()), planner_->arm("right").branch());
}

TEST_F(PrimitivePlannerTest, PushSequenceClipsTheEndToTheWorkspace) {
  PrimitiveRequest r;
  r.type = PrimitiveType::kPush;
  r.position = Eigen::Vector3d(0.1, 0.05, 0.02);
  r.yaw = 0.0;
  const PrimitivePlan plan = planner_->plan(r, atHome());
  EXPECT_EQ(plan.arm, "left");
  EXPECT_EQ(stepNames(plan),
            (std::vector<std::string>{"close", "transit", "approach", "push", "retreat", "home", "release"}));
  EXPECT_DOUBLE_EQ(step(plan, "close").opening, 0.0);
  EXPECT_FALSE(step(plan, "close").wait);
  const PrimitiveStep& push = step(plan, "push");
  // 0.1 + 0.13 = 0.23 is clipped to x = 0.224: 0.124 m in 13 steps.
  ASSERT_EQ(push.tcp_points.size(), 14u);
  EXPECT_LT((push.tcp_points.back() - Eigen::Vector3d(0.224, 0.05, 0.02)).norm(), 1e-12);
  const PrimitiveStep& retreat = step(plan, "retreat");
  EXPECT_LT((retreat.tcp_points.back() - Eigen::Vector3d(0.224, 0.05, 0.12)).norm(), 1e-12);
  expectOnLine(plan, "approach", r.yaw);
  expectOnLine(plan, "push", r.yaw);
  expectOnLine(plan, "retreat", r.yaw);
  // Pushes run at push_speed, the other lines at cartesian_speed.
  const pg_core::PrimitiveParams& pr = config_->primitives();
  EXPECT_GE(push.motion.duration(), 0.124 / pr.push_speed - 1e-9);
  EXPECT_GE(retreat.motion.duration(), pr.approach_height / pr.cartesian_speed - 1e-9);
  EXPECT_LT(retreat.motion.duration(), 2.0 * pr.approach_height / pr.cartesian_speed);
}

TEST_F(PrimitivePlannerTest, EveryMotionRespectsTheJointVelocityLimit) {
  const double limit = config_->robot().joint_velocity_limit;
  for (int i = 0; i < 8; ++i) {
    PrimitiveRequest r;
    r.type = i % 2 ? PrimitiveType::kPush : PrimitiveType::kGrasp;
    r.position = Eigen::Vector3d(-0.2 + 0.05 * i, 0.2 - 0.06 * i, 0.01 + 0.01 * i);
    r.yaw = i * kPi / 8.0;
    const PrimitivePlan plan = planner_->plan(r, atHome());
    EXPECT_GT(plan.motionDuration(), 0.0);
    EXPECT_LT(plan.motionDuration(), 3.0 * config_->primitives().time_budget);
    for (const auto& s : plan.steps) {
      if (s.kind != Kind::kMove) continue;
      EXPECT_LE(s.motion.peakVelocity(), limit * 0.9 * (1 + 1e-6)) << s.name;
      for (std::size_t k = 1; k < s.motion.times.size(); ++k) ASSERT_GT(s.motion.times[k], s.motion.times[k - 1]);
    }
  }
}

TEST_F(PrimitivePlannerTest, OutOfWorkspaceIsRefused) {
  PrimitiveRequest r;
  r.position = Eigen::Vector3d(0.3, 0.0, 0.05);
  EXPECT_NE(refusal(r).find("grasp point (0.300, 0.000, 0.050) m is outside the workspace"), std::string::npos)
      << refusal(r);
  r.position = Eigen::Vector3d(0.0, 0.0, 0.35);  // lift pose at 0.45 m
  EXPECT_NE(refusal(r).find("pre-grasp pose"), std::string::npos) << refusal(r);
  r.position = Eigen::Vector3d(0.0, 0.0, 0.25);  // pre 0.35 fine, lift 0.35 fine -> accepted
  EXPECT_EQ(refusal(r), "");
  r.position = Eigen::Vector3d(0.0, 0.0, -0.01);
  EXPECT_NE(refusal(r).find("grasp point"), std::string::npos);
  r.type = PrimitiveType::kPush;
  r.position = Eigen::Vector3d(0.0, -0.25, 0.02);
  EXPECT_NE(refusal(r).find("push start"), std::string::npos) << refusal(r);
  r.position = Eigen::Vector3d(0.0, 0.0, 0.31);
  EXPECT_NE(refusal(r).find("pre-push pose"), std::string::npos) << refusal(r);
  r.position = Eigen::Vector3d(std::nan(""), 0.0, 0.1);
  EXPECT_EQ(refusal(r), "position x (world) = nan is not a finite number; nothing moved");
  r.position = Eigen::Vector3d(0.0, 0.0, 0.1);
  r.yaw = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(refusal(r), "yaw = -inf is not a finite number; nothing moved");
}

TEST_F(PrimitivePlannerTest, ArmSelection) {
  PrimitiveRequest r;
  r.position = Eigen::Vector3d(0.0, -0.1, 0.05);
  EXPECT_EQ(planner_->plan(r, atHome()).arm, "right");
  r.arm = "left";  // an explicit arm is honoured
  EXPECT_EQ(planner_->plan(r, atHome()).arm, "left");
  r.arm = "middle";
  EXPECT_NE(refusal(r).find("unknown arm 'middle' (known: left, right)"), std::string::npos) << refusal(r);
  r.arm = std::string(10000, 'a');  // a huge name is repeated cut, with its length
  const std::string huge = refusal(r);
  EXPECT_LT(huge.size(), 300U) << huge.substr(0, 300);
  EXPECT_NE(huge.find("unknown arm '" + std::string(64, 'a') + "\xE2\x80\xA6(10000 chars)' (known: left, right)"),
            std::string::npos)
      << huge.substr(0, 300);
  EXPECT_EQ(planner_->armOrder("", Eigen::Vector2d(0.0, 0.2)), (std::vector<std::string>{"left", "right"}));
  EXPECT_EQ(planner_->armOrder("", Eigen::Vector2d(0.0, -0.2)), (std::vector<std::string>{"right", "left"}));
  EXPECT_EQ(planner_->armOrder("", Eigen::Vector2d(0.1, 0.0)), (std::vector<std::string>{"left", "right"}));  // tie
  r.arm = "";
  EXPECT_THROW(planner_->plan(r, {{"left", planner_->home("left")}}), std::invalid_argument);
}

TEST_F(PrimitivePlannerTest, FallsBackToTheOtherArmAndRefusesUnreachable) {
  // The config still says the right arm stands at y = -0.5 (so it is tried first for y < 0), but in this URDF it
  // stands 2 m away and reaches nothing: the planner must fall back to the left arm.
  const std::string urdf = replaced(readFile(config_->robot().urdf_path), "xyz=\"0 -0.5 0\"", "xyz=\"0 -2.0 0\"");
  const UrdfModelPtr far = parseUrdf(urdf, "test");
  const PrimitivePlanner planner(*config_, *far);
  PrimitiveRequest r;
  r.position = Eigen::Vector3d(0.0, -0.1, 0.05);
  EXPECT_EQ(planner.armOrder("", r.position.head<2>()).front(), "right");
  EXPECT_EQ(planner.plan(r, atHome()).arm, "left");
  r.arm = "right";
  const std::string why = refusal(r, planner);
  EXPECT_NE(why.find("is unreachable by arm(s) right"), std::string::npos) << why;

  // A workspace larger than the arms' reach: a far point inside it is refused as unreachable by both.
  const std::string yaml = replaced(readFile(PG_WORKSPACE_YAML), "x: [-0.224, 0.224]", "x: [-2.0, 2.0]");
  const pg_core::WorkspaceConfig big = pg_core::WorkspaceConfig::fromString(yaml, "big.yaml");
  const PrimitivePlanner big_planner(big, **model_);
  r.arm = "";
  r.position = Eigen::Vector3d(1.5, 0.0, 0.05);
  const std::string both = refusal(r, big_planner);
  EXPECT_NE(both.find("unreachable by arm(s) left, right"), std::string::npos) << both;
}

TEST_F(PrimitivePlannerTest, CartesianPathStepsAndErrors) {
  EXPECT_EQ(stepCount(0.1, 0.01), 10);
  EXPECT_EQ(stepCount(0.1 + 1e-12, 0.01), 10);  // rounding noise is not an extra step
  EXPECT_EQ(stepCount(0.1005, 0.01), 11);
  EXPECT_EQ(stepCount(0.0, 0.01), 1);
  EXPECT_THROW(stepCount(0.1, 0.0), std::invalid_argument);
  const ArmKinematics& arm = planner_->arm("left");
  const JointVector q0 = *arm.solveDown(Eigen::Vector3d(0.0, 0.0, 0.2), 0.0, arm.home());
  CartesianPathOptions opt;
  const CartesianPath p =
      planCartesianPath(arm, {Eigen::Vector3d(0.0, 0.0, 0.2), Eigen::Vector3d(0.0, 0.05, 0.2)}, 0.0, q0, opt);
  EXPECT_EQ(p.joints.size(), 6u);
  EXPECT_NEAR(p.length(), 0.05, 1e-12);
  EXPECT_THROW(planCartesianPath(arm, {Eigen::Vector3d(0.0, 0.0, 0.2), Eigen::Vector3d(3.0, 0.0, 0.2)}, 0.0, q0, opt),
               PlanningError);
  EXPECT_THROW(planCartesianPath(arm, {Eigen::Vector3d(0.0, 0.0, 0.2)}, 0.0, q0, opt), std::invalid_argument);
}

}  // namespace
}  // namespace pg_control

// catkin_add_gtest links GTest::gtest only (no gtest_main), so the test brings its own main().
int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
