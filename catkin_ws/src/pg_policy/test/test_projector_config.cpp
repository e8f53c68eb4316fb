// gtest of the heightmap projector's configuration (include/pg_policy/heightmap_projector.h): the grid of the real
// pg_description/config/workspace.yaml, read by pg_core, and the errors that name the key.
#include <gtest/gtest.h>
#include <pg_core/workspace_config.h>

#include <stdexcept>
#include <string>

#include "pg_policy/heightmap_projector.h"

namespace pg_policy {
namespace {

TEST(ProjectorConfig, LoadsWorkspaceYaml) {
  const ProjectorConfig c = ProjectorConfig::fromWorkspace(pg_core::WorkspaceConfig::fromFile(PG_WORKSPACE_YAML));
  EXPECT_DOUBLE_EQ(c.bounds.x_min, -0.224);
  EXPECT_DOUBLE_EQ(c.bounds.x_max, 0.224);
  EXPECT_DOUBLE_EQ(c.bounds.y_min, -0.224);
  EXPECT_DOUBLE_EQ(c.bounds.y_max, 0.224);
  EXPECT_DOUBLE_EQ(c.bounds.z_min, 0.0);
  EXPECT_DOUBLE_EQ(c.bounds.z_max, 0.4);
  EXPECT_DOUBLE_EQ(c.resolution, 0.002);
  EXPECT_EQ(c.world_frame, "world");
  const HeightmapProjector projector(c);
  EXPECT_EQ(projector.rows(), 224);
  EXPECT_EQ(projector.cols(), 224);
  // The projector's grid is the one pg_core::WorkspaceConfig defines.
  const pg_core::WorkspaceConfig ws = pg_core::WorkspaceConfig::fromFile(PG_WORKSPACE_YAML);
  EXPECT_EQ(projector.rows(), ws.rows());
  EXPECT_EQ(projector.cols(), ws.cols());
}

// Configuration errors are pg_core::WorkspaceConfig's (see its own test); the projector adds its own checks.
TEST(ProjectorConfig, ErrorsNameTheKey) {
  const auto expectErrorNaming = [](const std::string& yaml, const std::string& key) {
    try {
      pg_core::WorkspaceConfig::fromString("frames: {world: world}\n" + yaml);
      FAIL() << "expected std::runtime_error naming " << key;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  };
  expectErrorNaming("workspace: {x: [0, 1], y: [0, 1]}\nheightmap: {resolution: 0.1}\n", "workspace.z");
  expectErrorNaming("workspace: {x: [0, 1], y: [0, 1], z: [0, 1]}\nheightmap: {resolution: -1}\n",
                    "heightmap.resolution");
  EXPECT_THROW(pg_core::WorkspaceConfig::fromFile("/nonexistent/workspace.yaml"), std::runtime_error);
  ProjectorConfig bad;
  bad.bounds = {0.0, 0.008, 0.0, 0.006, 0.1, 0.5};
  bad.resolution = 0.0;
  EXPECT_THROW(HeightmapProjector{bad}, std::invalid_argument);
}

}  // namespace
}  // namespace pg_policy

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
