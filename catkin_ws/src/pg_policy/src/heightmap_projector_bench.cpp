// heightmap_projector_bench [runs] [workspace.yaml]: ms per 640 x 480 frame of the ROS-free projector core.
// Synthetic top-down RGB-D frame with the config's camera (table 0.7 m below it, a few boxes, ~1% holes), projected
// onto the config's 224 x 224 grid `runs` times (default 50) through the cloud path (organised PointXYZRGB cloud),
// the depth path with 32FC1 metres and with 16UC1 millimetres. Prints median and p90 per path.
#include <pg_core/workspace_config.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "pg_policy/heightmap_projector.h"
#include "synthetic_frame.h"

namespace {

struct Stats {
  double median_ms;
  double p90_ms;
};

Stats timeRuns(int runs, const std::function<void()>& fn) {
  fn();  // warm-up: buffers allocated, caches filled
  std::vector<double> ms;
  ms.reserve(runs);
  for (int i = 0; i < runs; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  return {ms[ms.size() / 2], ms[std::min(ms.size() - 1, static_cast<std::size_t>(0.9 * ms.size()))]};
}

}  // namespace

int main(int argc, char** argv) {
  const int runs = argc > 1 ? std::max(1, std::atoi(argv[1])) : 50;
  const std::string path =
      argc > 2 ? argv[2] : std::string(PG_WORKSPACE_YAML);  // pg_description's, as the package exports it
  pg_policy::HeightmapProjector projector(
      pg_policy::ProjectorConfig::fromWorkspace(pg_core::WorkspaceConfig::fromFile(path)));

  const pg_policy::SyntheticFrame frame;
  const pg_policy::CameraIntrinsics& k = frame.intrinsics;
  const pg_policy::DepthImageView view_m = frame.metres();
  const pg_policy::DepthImageView view_mm = frame.millimetres();
  const pg_policy::ColorImageView color = frame.color();
  const pcl::PointCloud<pcl::PointXYZRGB> cloud = frame.cloud();
  const Eigen::Isometry3d& pose = frame.world_from_camera;

  pg_policy::HeightmapGrid grid;
  const Stats s_cloud = timeRuns(runs, [&] { projector.project(cloud, pose, grid); });
  int valid = 0;
  for (std::uint8_t m : grid.valid) valid += m ? 1 : 0;
  const Stats s_m = timeRuns(runs, [&] { projector.projectDepth(view_m, color, k, pose, grid); });
  const Stats s_mm = timeRuns(runs, [&] { projector.projectDepth(view_mm, color, k, pose, grid); });

  std::printf("heightmap_projector_bench: %d runs, %dx%d frame -> %dx%d grid (%d valid cells)\n", runs,
              pg_policy::SyntheticFrame::kWidth, pg_policy::SyntheticFrame::kHeight, projector.rows(), projector.cols(),
              valid);
  std::printf("  cloud (PointXYZRGB)   median %.3f ms  p90 %.3f ms\n", s_cloud.median_ms, s_cloud.p90_ms);
  std::printf("  depth 32FC1 metres    median %.3f ms  p90 %.3f ms\n", s_m.median_ms, s_m.p90_ms);
  std::printf("  depth 16UC1 mm        median %.3f ms  p90 %.3f ms\n", s_mm.median_ms, s_mm.p90_ms);
  return 0;
}
