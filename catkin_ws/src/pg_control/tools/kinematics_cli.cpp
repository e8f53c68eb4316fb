// pg_control_kinematics: the C++ kinematics on stdin/stdout, for cross-checks against pg_core's Python kinematics.
//
// Usage: pg_control_kinematics WORKSPACE_YAML [URDF]   (URDF default: the config's robot.urdf)
// One command per input line, one answer line each (numbers in %.17g; rad, metres, `world` frame):
//   fk ARM q1..q6               -> 16 numbers: world <- <arm>_gripper_tcp, row-major 4x4
//   tool0 ARM q1..q6            -> 16 numbers: world <- <arm>_tool0
//   branch ARM q1..q6           -> shoulder wrist elbow (signs, pg_core.ur_ik order)
//   ik ARM x y z yaw s1..s6     -> q1..q6 of the tool-down TCP pose, seeded from s, or "none"
// A malformed line answers "error: <reason>"; the exit status is 0 unless the config or URDF cannot be loaded.
#include <pg_core/workspace_config.h>

#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include "pg_control/arm_kinematics.h"
#include "pg_control/urdf_chain.h"

namespace {

using pg_control::JointVector;

void printMatrix(const Eigen::Isometry3d& t) {
  const Eigen::Matrix4d m = t.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) std::printf("%s%.17g", (r || c) ? " " : "", m(r, c));
  }
  std::printf("\n");
}

bool readVector(std::istream& in, int n, JointVector* out) {
  out->resize(n);
  for (int i = 0; i < n; ++i) {
    if (!(in >> (*out)(i))) return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) {
    std::fprintf(stderr, "usage: %s WORKSPACE_YAML [URDF]\n", argv[0]);
    return 2;
  }
  std::map<std::string, std::unique_ptr<pg_control::ArmKinematics>> arms;
  try {
    const pg_core::WorkspaceConfig config = pg_core::WorkspaceConfig::fromFile(argv[1]);
    const pg_control::UrdfModelPtr model =
        pg_control::loadUrdfFile(argc == 3 ? std::string(argv[2]) : config.robot().urdf_path);
    for (const auto& spec : config.robot().arms) {
      arms[spec.name] = std::make_unique<pg_control::ArmKinematics>(*model, "world", spec, config.robot());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pg_control_kinematics: %s\n", e.what());
    return 1;
  }

  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    std::string cmd;
    std::string arm;
    if (!(in >> cmd)) continue;
    in >> arm;
    const auto it = arms.find(arm);
    if (it == arms.end()) {
      std::printf("error: unknown arm '%s'\n", arm.c_str());
      continue;
    }
    const pg_control::ArmKinematics& kin = *it->second;
    try {
      JointVector q;
      if (cmd == "fk" || cmd == "tool0" || cmd == "branch") {
        if (!readVector(in, 6, &q)) throw std::invalid_argument("need 6 joint angles");
        if (cmd == "fk") {
          printMatrix(kin.fk(q));
        } else if (cmd == "tool0") {
          printMatrix(kin.fkLink(q, arm + "_tool0"));
        } else {
          const pg_control::IkBranch b = kin.branchOf(q);
          std::printf("%d %d %d\n", b.shoulder, b.wrist, b.elbow);
        }
      } else if (cmd == "ik") {
        JointVector pose;
        JointVector seed;
        if (!readVector(in, 4, &pose) || !readVector(in, 6, &seed))
          throw std::invalid_argument("need x y z yaw s1..s6");
        const std::optional<JointVector> sol = kin.solveDown(pose.head<3>(), pose(3), seed);
        if (!sol) {
          std::printf("none\n");
        } else {
          for (int i = 0; i < 6; ++i) std::printf("%s%.17g", i ? " " : "", (*sol)(i));
          std::printf("\n");
        }
      } else {
        throw std::invalid_argument("unknown command '" + cmd + "'");
      }
    } catch (const std::exception& e) {
      std::printf("error: %s\n", e.what());
    }
    std::fflush(stdout);
  }
  return 0;
}
