// gtest benchmark of the ROS-free projector core: median milliseconds per 640 x 480 frame on the synthetic frame of
// src/synthetic_frame.h, projected onto the config/workspace.yaml grid (224 x 224), one thread.
// The cloud path (organised PointXYZRGB) must take at most PG_PROJECTOR_BUDGET_MS (default 3 ms) per frame, or on a
// slower machine kReferenceRatio times a reference pass over the same cloud timed in the same run. A timing
// means nothing on a busy machine: when the 1-minute load average exceeds half the cores, the test is skipped and says
// so with the figures it measured. The figures are printed either way (`rosrun pg_policy heightmap_projector_bench`
// prints the same paths with p90).
#include <gtest/gtest.h>
#include <pg_core/workspace_config.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <thread>
#include <vector>

#include "pg_policy/heightmap_projector.h"
#include "synthetic_frame.h"

namespace pg_policy {
namespace {

constexpr int kRuns = 200;
// A machine slower than the budget's is held to this many reference passes instead (measured: 5.6-5.9 on a 2-core
// AMD EPYC at 4.9-5.1 ms per cloud; the single-pass projector this test guards against took twice as long).
constexpr double kReferenceRatio = 8.0;

double medianMs(const std::function<void()>& fn) {
  fn();  // warm-up: buffers allocated, caches filled
  std::vector<double> ms;
  for (int i = 0; i < kRuns; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  return ms[ms.size() / 2];
}

// The least work any projection of `cloud` does: every point moved into `world` and its height kept. Timed in the
// same run, it measures the machine, so that the budget holds the projector's own cost on a slower one too.
double referenceMs(const pcl::PointCloud<pcl::PointXYZRGB>& cloud, const Eigen::Isometry3d& world_from_camera) {
  const Eigen::Matrix4f tf = world_from_camera.matrix().cast<float>();
  std::vector<float> z(cloud.size());
  return medianMs([&] {
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const auto& p = cloud[i];
      z[i] = tf(2, 0) * p.x + tf(2, 1) * p.y + tf(2, 2) * p.z + tf(2, 3);
    }
    volatile float sink = z[z.size() / 2];
    (void)sink;
  });
}

double budgetMs() {
  const char* env = std::getenv("PG_PROJECTOR_BUDGET_MS");
  return env != nullptr ? std::atof(env) : 3.0;
}

TEST(ProjectorBenchmark, FrameWithinBudget) {
  HeightmapProjector projector(ProjectorConfig::fromWorkspace(pg_core::WorkspaceConfig::fromFile(PG_WORKSPACE_YAML)));
  const SyntheticFrame frame;
  const pcl::PointCloud<pcl::PointXYZRGB> cloud = frame.cloud();
  HeightmapGrid grid;
  const double cloud_ms = medianMs([&] { projector.project(cloud, frame.world_from_camera, grid); });
  const double depth_ms = medianMs(
      [&] { projector.projectDepth(frame.metres(), frame.color(), frame.intrinsics, frame.world_from_camera, grid); });
  const double ref_ms = referenceMs(cloud, frame.world_from_camera);
  const double mm_ms = medianMs([&] {
    projector.projectDepth(frame.millimetres(), frame.color(), frame.intrinsics, frame.world_from_camera, grid);
  });
  double load = 0.0;
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const bool busy = getloadavg(&load, 1) == 1 && load > 0.5 * cores;
  std::printf(
      "projector, median of %d frames (640x480 -> %dx%d): cloud %.3f ms, depth 32FC1 %.3f ms, "
      "depth 16UC1 %.3f ms, reference pass %.3f ms; load %.2f on %u cores\n",
      kRuns, projector.rows(), projector.cols(), cloud_ms, depth_ms, mm_ms, ref_ms, load, cores);
  RecordProperty("cloud_median_us", static_cast<int>(cloud_ms * 1000));
  if (busy) {
    GTEST_SKIP() << "load average " << load << " on " << cores << " cores: timing not meaningful (cloud " << cloud_ms
                 << " ms)";
  }
  const double budget = std::max(budgetMs(), kReferenceRatio * ref_ms);
  EXPECT_LE(cloud_ms, budget) << "cloud path median per 640x480 frame: the larger of PG_PROJECTOR_BUDGET_MS and "
                              << kReferenceRatio << " reference passes (" << ref_ms << " ms)";
}

}  // namespace
}  // namespace pg_policy

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
