// Unit tests for pg_control::ArmKinematics and the URDF chain (ROS-free; no roscore).
#include <gtest/gtest.h>
#include <pg_core/workspace_config.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>

#include "pg_control/arm_kinematics.h"
#include "pg_control/tool_pose.h"
#include "pg_control/urdf_chain.h"

namespace pg_control {
namespace {

constexpr double kPi = 3.14159265358979323846;

class ArmKinematicsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    config_ = new pg_core::WorkspaceConfig(pg_core::WorkspaceConfig::fromFile(PG_WORKSPACE_YAML));
    model_ = new UrdfModelPtr(loadUrdfFile(config_->robot().urdf_path));
    for (const auto& spec : config_->robot().arms) {
      arms_[spec.name] = new ArmKinematics(**model_, "world", spec, config_->robot());
    }
  }
  static void TearDownTestSuite() {
    for (auto& kv : arms_) delete kv.second;
    arms_.clear();
    delete model_;
    delete config_;
  }

  // world <- gripper_tcp from the official UR5e DH of the config (standard DH: Rz(q) Tz(d) Tx(a) Rx(alpha)), the
  // arm's base mount (xyz, URDF rpy) and the tcp offset along tool0 z: the closed form FK must agree with.
  static Eigen::Isometry3d dhTcp(const pg_core::ArmSpec& arm, const JointVector& q) {
    const pg_core::RobotParams& r = config_->robot();
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.translation() = Eigen::Vector3d(arm.xyz[0], arm.xyz[1], arm.xyz[2]);
    t.linear() = (Eigen::AngleAxisd(arm.rpy[2], Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(arm.rpy[1], Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(arm.rpy[0], Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    for (int i = 0; i < 6; ++i) {
      Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
      step.rotate(Eigen::AngleAxisd(q(i), Eigen::Vector3d::UnitZ()));
      step.translate(Eigen::Vector3d(r.dh_a[i], 0.0, r.dh_d[i]));
      step.rotate(Eigen::AngleAxisd(r.dh_alpha[i], Eigen::Vector3d::UnitX()));
      t = t * step;
    }
    return t * Eigen::Translation3d(0.0, 0.0, config_->gripper().tcp_offset);
  }

  // A random configuration on `arm`'s IK branch (wrist and elbow half-turns chosen, shoulder by rejection).
  static JointVector randomOnBranch(const ArmKinematics& arm, std::mt19937& rng) {
    std::uniform_real_distribution<double> any(-kPi, kPi);
    std::uniform_real_distribution<double> half(0.15, kPi - 0.15);
    for (;;) {
      JointVector q(6);
      for (int k = 0; k < 6; ++k) q(k) = any(rng);
      q(2) = arm.branch().elbow * half(rng);
      q(4) = arm.branch().wrist * half(rng);
      if (arm.branchOf(q) == arm.branch()) return q;
    }
  }

  static pg_core::WorkspaceConfig* config_;
  static UrdfModelPtr* model_;
  static std::map<std::string, ArmKinematics*> arms_;
};

pg_core::WorkspaceConfig* ArmKinematicsTest::config_ = nullptr;
UrdfModelPtr* ArmKinematicsTest::model_ = nullptr;
std::map<std::string, ArmKinematics*> ArmKinematicsTest::arms_;

TEST_F(ArmKinematicsTest, ChainMatchesTheConfig) {
  ASSERT_EQ(arms_.size(), 2u);
  for (const auto& [name, arm] : arms_) {
    ASSERT_EQ(arm->jointNames().size(), 6u);
    EXPECT_EQ(arm->jointNames()[0], name + "_shoulder_pan_joint");
    EXPECT_EQ(arm->jointNames()[5], name + "_wrist_3_joint");
    EXPECT_NEAR(arm->velocityLimit(), kPi, 1e-9);
    EXPECT_NEAR(arm->upper()(2), kPi, 1e-9);
    EXPECT_NEAR(arm->lower()(0), -2 * kPi, 1e-9);
    const pg_core::ArmSpec* spec = config_->arm(name);
    EXPECT_NEAR((arm->worldFromBase().translation() - Eigen::Vector3d(spec->xyz[0], spec->xyz[1], spec->xyz[2])).norm(),
                0.0, 1e-9);
    EXPECT_EQ(arm->branchOf(arm->home()), arm->branch()) << name << ": home must lie on the configured branch";
  }
}

TEST_F(ArmKinematicsTest, FkEqualsDhClosedFormWithMountAndTcpOffset) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> any(-2 * kPi, 2 * kPi);
  for (const auto& [name, arm] : arms_) {
    const pg_core::ArmSpec& spec = *config_->arm(name);
    for (int n = 0; n < 200; ++n) {
      JointVector q(6);
      for (int k = 0; k < 6; ++k) q(k) = any(rng);
      const Eigen::Isometry3d a = arm->fk(q);
      const Eigen::Isometry3d b = dhTcp(spec, q);
      ASSERT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), 1e-9) << name << " q=" << q.transpose();
    }
    // tool0 is the DH flange: the TCP lies tcp_offset further along its z.
    const JointVector q = arm->home();
    const Eigen::Isometry3d tool0 = arm->fkLink(q, name + "_tool0");
    const Eigen::Vector3d expected = tool0.translation() + config_->gripper().tcp_offset * tool0.linear().col(2);
    EXPECT_LT((arm->fk(q).translation() - expected).norm(), 1e-12);
  }
}

TEST_F(ArmKinematicsTest, HomeIsTheDocumentedPose) {
  // workspace.yaml: home puts the TCP at (+-0.347, +-0.143, 0.595) pointing down.
  const Eigen::Isometry3d left = arms_["left"]->fk(arms_["left"]->home());
  EXPECT_NEAR(left.translation().z(), 0.595, 2e-3);
  EXPECT_NEAR(std::abs(left.translation().x()), 0.347, 2e-3);
  EXPECT_NEAR(left.linear()(2, 2), -1.0, 1e-3);
}

TEST_F(ArmKinematicsTest, IkRoundTripOnRandomReachablePoses) {
  // 1000 random tool poses reachable on each arm's branch (FK of random on-branch joints), solved from home.
  std::mt19937 rng(42);
  int solved = 0;
  int total = 0;
  double worst_pos = 0.0;
  double worst_rot = 0.0;
  const auto start = std::chrono::steady_clock::now();
  for (int n = 0; n < 1000; ++n) {
    const ArmKinematics& arm = *arms_[n % 2 ? "right" : "left"];
    const JointVector q = randomOnBranch(arm, rng);
    const Eigen::Isometry3d goal = arm.fk(q);
    ++total;
    const std::optional<JointVector> sol = arm.solve(goal, arm.home());
    if (!sol) continue;
    const Eigen::Isometry3d reached = arm.fk(*sol);
    worst_pos = std::max(worst_pos, positionError(reached, goal));
    worst_rot = std::max(worst_rot, rotationError(reached, goal));
    EXPECT_TRUE(arm.withinLimits(*sol));
    EXPECT_EQ(arm.branchOf(*sol), arm.branch());
    ++solved;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("IK round trip: %d / %d solved, worst %.2e m, %.2e rad, %.2f ms per solve\n", solved, total, worst_pos,
              worst_rot, 1e3 * seconds / total);
  EXPECT_GE(solved, 990);
  EXPECT_LT(worst_pos, 1e-3);
  EXPECT_LT(worst_rot, 1e-2);
}

TEST_F(ArmKinematicsTest, IkSolvesEveryToolDownWorkspacePose) {
  // The poses primitives use: anywhere in the workspace, any yaw, TCP between the table and transit height.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> xy(-0.224, 0.224);
  std::uniform_real_distribution<double> z(0.005, 0.4);
  std::uniform_real_distribution<double> yaw(-kPi, kPi);
  for (int n = 0; n < 200; ++n) {
    const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
    const double y = yaw(rng);
    for (const auto& [name, arm] : arms_) {
      const std::optional<JointVector> q = arm->solveDown(p, y, arm->home());
      ASSERT_TRUE(q.has_value()) << name << " p=" << p.transpose() << " yaw=" << y;
      EXPECT_LT(positionError(arm->fk(*q), toolDownPose(p, y)), 1e-5);
      EXPECT_LT(rotationError(arm->fk(*q), toolDownPose(p, y)), 1e-4);
      EXPECT_EQ(arm->branchOf(*q), arm->branch());
    }
  }
}

TEST_F(ArmKinematicsTest, IkPrefersTheSolutionNearestTheSeed) {
  const ArmKinematics& arm = *arms_["left"];
  const std::optional<JointVector> q = arm.solveDown(Eigen::Vector3d(0.05, 0.1, 0.1), 0.3, arm.home());
  ASSERT_TRUE(q);
  // Seeding from the solution itself returns it; seeding 2 pi away on a joint returns the shifted twin.
  JointVector again = *arm.solveDown(Eigen::Vector3d(0.05, 0.1, 0.1), 0.3, *q);
  EXPECT_LT((again - *q).cwiseAbs().maxCoeff(), 1e-6);
  JointVector seed = *q;
  const double turn = (*q)(5) > 0.0 ? -2 * kPi : 2 * kPi;  // stays within the +-2 pi limit
  seed(5) += turn;
  again = *arm.solveDown(Eigen::Vector3d(0.05, 0.1, 0.1), 0.3, seed);
  EXPECT_NEAR(again(5), (*q)(5) + turn, 1e-6);
  // Without the branch requirement a nearby seed still gives the nearby solution.
  IkOptions free;
  free.require_branch = false;
  again = *arm.solveDown(Eigen::Vector3d(0.05, 0.1, 0.1), 0.3, *q, free);
  EXPECT_LT((again - *q).cwiseAbs().maxCoeff(), 1e-6);
}

TEST_F(ArmKinematicsTest, UnreachablePosesAreNotSolved) {
  const ArmKinematics& arm = *arms_["left"];
  IkOptions quick;
  quick.max_restarts = 5;
  EXPECT_FALSE(arm.solveDown(Eigen::Vector3d(2.0, 0.0, 0.1), 0.0, arm.home(), quick).has_value());
  EXPECT_FALSE(arm.solveDown(Eigen::Vector3d(0.0, 0.0, -1.5), 0.0, arm.home(), quick).has_value());
}

TEST_F(ArmKinematicsTest, ShiftTowardsKeepsLimits) {
  const ArmKinematics& arm = *arms_["left"];
  JointVector q = JointVector::Zero(6);
  JointVector seed = JointVector::Zero(6);
  seed(0) = 5.0;
  EXPECT_NEAR((*arm.shiftTowards(q, seed))(0), 2 * kPi, 1e-12);
  seed(2) = 5.0;  // the elbow is limited to +-pi: no shift
  EXPECT_NEAR((*arm.shiftTowards(q, seed))(2), 0.0, 1e-12);
  q(2) = 3.5;  // beyond the elbow limit: shifted back by -2 pi
  EXPECT_NEAR((*arm.shiftTowards(q, JointVector::Zero(6)))(2), 3.5 - 2 * kPi, 1e-12);
}

TEST_F(ArmKinematicsTest, BadInputThrows) {
  const ArmKinematics& arm = *arms_["left"];
  EXPECT_THROW(arm.fk(JointVector::Zero(5)), std::invalid_argument);
  JointVector nan = JointVector::Zero(6);
  nan(1) = std::nan("");
  EXPECT_THROW(arm.fk(nan), std::invalid_argument);
  EXPECT_THROW(arm.solveDown(Eigen::Vector3d::Zero(), 0.0, nan), std::invalid_argument);
  EXPECT_THROW(arm.fkLink(arm.home(), "right_tool0"), std::invalid_argument);
}

TEST_F(ArmKinematicsTest, UrdfErrorsAreNamed) {
  EXPECT_THROW(chainFromUrdf(**model_, "left_base_link", "no_such_link"), std::runtime_error);
  EXPECT_THROW(chainFromUrdf(**model_, "left_tool0", "left_base_link"), std::runtime_error);
  EXPECT_THROW(fixedTransform(**model_, "world", "left_tool0"), std::runtime_error);
  EXPECT_THROW(parseUrdf("<robot name='x'><link name='a'/", "test"), std::runtime_error);
  EXPECT_THROW(loadUrdfFile("/nonexistent.urdf"), std::runtime_error);
  pg_core::ArmSpec bad = *config_->arm("left");
  bad.name = "middle";
  EXPECT_THROW(ArmKinematics(**model_, "world", bad, config_->robot()), std::runtime_error);
}

}  // namespace
}  // namespace pg_control

// catkin_add_gtest links GTest::gtest only (no gtest_main), so the test brings its own main().
int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
