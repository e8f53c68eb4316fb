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
      argc > 2 ? argv[2] : std::string(PG_POLICY_SOURCE_DIR "/../pg_description/config/workspace.yaml");
  pg_policy::HeightmapProjector projector(
      pg_policy::ProjectorConfig::fromWorkspace(pg_core::WorkspaceConfig::fromFile(path)));

  constexpr int kW = 640;
  constexpr int kH = 480;
  const pg_policy::CameraIntrinsics k{615.0, 615.0, 319.5, 239.5};
  std::vector<float> depth_m(kW * kH);
  std::vector<std::uint16_t> depth_mm(kW * kH);
  std::vector<std::uint8_t> rgb(kW * kH * 3);
  std::uint32_t seed = 12345;
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u) {
      seed = seed * 1664525u + 1013904223u;  // LCG noise, +-1 mm
      float z = 0.7f + ((seed >> 16) % 3 - 1) * 0.001f;
      if (((u / 80) + (v / 80)) % 3 == 0) z -= 0.05f + 0.01f * ((u / 80) % 4);  // boxes 5-8 cm tall
      if ((seed >> 8) % 100 == 0) z = 0.0f;                                     // holes
      const int i = v * kW + u;
      depth_m[i] = z;
      depth_mm[i] = static_cast<std::uint16_t>(std::lround(z * 1000.0f));
      rgb[3 * i] = static_cast<std::uint8_t>(u);
      rgb[3 * i + 1] = static_cast<std::uint8_t>(v);
      rgb[3 * i + 2] = static_cast<std::uint8_t>(u + v);
    }
  }
  const pg_policy::DepthImageView view_m{reinterpret_cast<const std::uint8_t*>(depth_m.data()), kW, kH,
                                         kW * sizeof(float), pg_policy::DepthEncoding::kFloat32Metres};
  const pg_policy::DepthImageView view_mm{reinterpret_cast<const std::uint8_t*>(depth_mm.data()), kW, kH,
                                          kW * sizeof(std::uint16_t), pg_policy::DepthEncoding::kUint16Millimetres};
  const pg_policy::ColorImageView color{rgb.data(), kW * 3, false};
  const pcl::PointCloud<pcl::PointXYZRGB> cloud = pg_policy::HeightmapProjector::depthToCloud(view_m, color, k);

  // world <- camera_color_optical_frame as in config/workspace.yaml: xyz (0, 0, 0.7), rpy (pi, 0, -pi/2).
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() =
      (Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  pose.translation() = Eigen::Vector3d(0.0, 0.0, 0.7);

  pg_policy::HeightmapGrid grid;
  const Stats s_cloud = timeRuns(runs, [&] { projector.project(cloud, pose, grid); });
  int valid = 0;
  for (std::uint8_t m : grid.valid) valid += m ? 1 : 0;
  const Stats s_m = timeRuns(runs, [&] { projector.projectDepth(view_m, color, k, pose, grid); });
  const Stats s_mm = timeRuns(runs, [&] { projector.projectDepth(view_mm, color, k, pose, grid); });

  std::printf("heightmap_projector_bench: %d runs, %dx%d frame -> %dx%d grid (%d valid cells)\n", runs, kW, kH,
              projector.rows(), projector.cols(), valid);
  std::printf("  cloud (PointXYZRGB)   median %.3f ms  p90 %.3f ms\n", s_cloud.median_ms, s_cloud.p90_ms);
  std::printf("  depth 32FC1 metres    median %.3f ms  p90 %.3f ms\n", s_m.median_ms, s_m.p90_ms);
  std::printf("  depth 16UC1 mm        median %.3f ms  p90 %.3f ms\n", s_mm.median_ms, s_mm.p90_ms);
  return 0;
}
