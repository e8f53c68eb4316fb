// gtest of the ROS-free heightmap projector core (include/pg_policy/heightmap_projector.h) on synthetic clouds and
// depth images. The agreement with the numpy reference on a simulated scene is tested by
// tests/ros/heightmap_projector.test.
#include <gtest/gtest.h>
#include <pg_core/workspace_config.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "pg_policy/heightmap_projector.h"

namespace pg_policy {
namespace {

constexpr double kRes = 0.002;

// A small 4 x 3 (cols x rows) grid: x in [0, 0.008), y in [0, 0.006), z in [0.1, 0.5).
ProjectorConfig smallConfig() {
  ProjectorConfig c;
  c.bounds = {0.0, 0.008, 0.0, 0.006, 0.1, 0.5};
  c.resolution = kRes;
  return c;
}

// The projector's configuration from the real pg_description/config/workspace.yaml, read by pg_core.
ProjectorConfig workspaceYamlConfig() {
  return ProjectorConfig::fromWorkspace(pg_core::WorkspaceConfig::fromFile(PG_WORKSPACE_YAML));
}

pcl::PointXYZRGB point(double x, double y, double z, std::uint8_t r = 0, std::uint8_t g = 0, std::uint8_t b = 0) {
  pcl::PointXYZRGB p;
  p.x = static_cast<float>(x);
  p.y = static_cast<float>(y);
  p.z = static_cast<float>(z);
  p.r = r;
  p.g = g;
  p.b = b;
  return p;
}

// Centre of cell (row, col) of the small grid.
double cx(int col) { return (col + 0.5) * kRes; }
double cy(int row) { return (row + 0.5) * kRes; }

std::size_t at(const HeightmapGrid& g, int row, int col) { return static_cast<std::size_t>(row) * g.cols + col; }

int countValid(const HeightmapGrid& g) {
  int n = 0;
  for (std::uint8_t v : g.valid) n += v == 255 ? 1 : 0;
  return n;
}

// world <- camera_color_optical_frame of config/workspace.yaml: xyz (0, 0, 0.7), rpy (pi, 0, -pi/2).
Eigen::Isometry3d cameraPose() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = (Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(0.0, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  t.translation() = Eigen::Vector3d(0.0, 0.0, 0.7);
  return t;
}

TEST(HeightmapProjector, OnePointPerCell) {
  HeightmapProjector projector(smallConfig());
  ASSERT_EQ(projector.rows(), 3);
  ASSERT_EQ(projector.cols(), 4);
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col) {
      cloud.push_back(point(cx(col), cy(row), 0.1 + 0.01 * (row * 4 + col + 1), row * 4 + col, 10 * row, 20 * col));
    }
  }
  const HeightmapGrid g = projector.project(cloud, Eigen::Isometry3d::Identity());
  ASSERT_EQ(g.rows, 3);
  ASSERT_EQ(g.cols, 4);
  ASSERT_EQ(g.height.size(), 12u);
  ASSERT_EQ(g.color.size(), 36u);
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col) {
      const std::size_t i = at(g, row, col);
      EXPECT_EQ(g.valid[i], 255);
      EXPECT_NEAR(g.height[i], 0.01 * (row * 4 + col + 1), 1e-6) << row << "," << col;
      EXPECT_EQ(g.color[3 * i + 0], row * 4 + col);
      EXPECT_EQ(g.color[3 * i + 1], 10 * row);
      EXPECT_EQ(g.color[3 * i + 2], 20 * col);
    }
  }
}

TEST(HeightmapProjector, KeepsTheHighestPointAndItsColour) {
  HeightmapProjector projector(smallConfig());
  for (bool high_first : {true, false}) {
    pcl::PointCloud<pcl::PointXYZRGB> cloud;
    const pcl::PointXYZRGB low = point(cx(1), cy(2), 0.15, 1, 2, 3);
    const pcl::PointXYZRGB high = point(cx(1) + 0.0005, cy(2) - 0.0005, 0.30, 200, 100, 50);
    cloud.push_back(high_first ? high : low);
    cloud.push_back(high_first ? low : high);
    const HeightmapGrid g = projector.project(cloud, Eigen::Isometry3d::Identity());
    const std::size_t i = at(g, 2, 1);
    EXPECT_EQ(countValid(g), 1);
    EXPECT_EQ(g.valid[i], 255);
    EXPECT_NEAR(g.height[i], 0.20, 1e-6);
    EXPECT_EQ(g.color[3 * i], 200);
    EXPECT_EQ(g.color[3 * i + 1], 100);
    EXPECT_EQ(g.color[3 * i + 2], 50);
  }
}

TEST(HeightmapProjector, TieKeepsTheLaterPoint) {
  HeightmapProjector projector(smallConfig());
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  cloud.push_back(point(cx(0), cy(0), 0.2, 1, 1, 1));
  cloud.push_back(point(cx(0), cy(0), 0.2, 9, 9, 9));
  const HeightmapGrid g = projector.project(cloud, Eigen::Isometry3d::Identity());
  EXPECT_EQ(g.color[0], 9);
}

TEST(HeightmapProjector, CropsToTheWorkspaceBox) {
  HeightmapProjector projector(smallConfig());
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  cloud.push_back(point(-0.0001, cy(1), 0.2));  // x < x_min
  cloud.push_back(point(0.0081, cy(1), 0.2));   // x >= x_max
  cloud.push_back(point(cx(1), -0.0001, 0.2));  // y < y_min
  cloud.push_back(point(cx(1), 0.0061, 0.2));   // y >= y_max
  cloud.push_back(point(cx(2), cy(1), 0.5));    // z >= z_max
  cloud.push_back(point(cx(2), cy(1), 0.7));
  HeightmapGrid g = projector.project(cloud, Eigen::Isometry3d::Identity());
  EXPECT_EQ(countValid(g), 0);
  for (float h : g.height) EXPECT_EQ(h, 0.0f);
  for (std::uint8_t c : g.color) EXPECT_EQ(c, 0);

  // Below z_min: kept, height clipped to 0 (as the numpy reference); the cell is valid.
  cloud.clear();
  cloud.push_back(point(cx(3), cy(0), 0.05, 7, 8, 9));
  g = projector.project(cloud, Eigen::Isometry3d::Identity());
  EXPECT_EQ(countValid(g), 1);
  EXPECT_EQ(g.valid[at(g, 0, 3)], 255);
  EXPECT_EQ(g.height[at(g, 0, 3)], 0.0f);
  EXPECT_EQ(g.color[3 * at(g, 0, 3)], 7);
}

TEST(HeightmapProjector, SkipsNonFinitePoints) {
  HeightmapProjector projector(smallConfig());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  pcl::PointXYZRGB p = point(cx(1), cy(1), 0.2, 5, 5, 5);
  cloud.push_back(p);
  p.z = nan;
  cloud.push_back(p);
  p = point(cx(2), cy(1), 0.2);
  p.x = nan;
  cloud.push_back(p);
  p = point(cx(3), cy(1), 0.2);
  p.z = -inf;
  cloud.push_back(p);
  const HeightmapGrid g = projector.project(cloud, Eigen::Isometry3d::Identity());
  EXPECT_EQ(countValid(g), 1);
  EXPECT_NEAR(g.height[at(g, 1, 1)], 0.1, 1e-6);
  EXPECT_EQ(g.color[3 * at(g, 1, 1)], 5);
}

TEST(HeightmapProjector, AppliesTheTransformAndReusesBuffers) {
  HeightmapProjector projector(smallConfig());
  // A point at (cx(3), cy(2), 0.3) in world, expressed in the camera frame.
  const Eigen::Isometry3d world_from_cam = cameraPose();
  const Eigen::Vector3d p_cam = world_from_cam.inverse() * Eigen::Vector3d(cx(3), cy(2), 0.3);
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  cloud.push_back(point(p_cam.x(), p_cam.y(), p_cam.z(), 42, 0, 0));
  HeightmapGrid g;
  // Fill with stale data first: a second call must not keep anything from the first.
  pcl::PointCloud<pcl::PointXYZRGB> other;
  other.push_back(point(cx(0), cy(0), 0.4, 1, 1, 1));
  projector.project(other, Eigen::Isometry3d::Identity(), g);
  projector.project(cloud, world_from_cam, g);
  EXPECT_EQ(countValid(g), 1);
  EXPECT_EQ(g.valid[at(g, 2, 3)], 255);
  EXPECT_NEAR(g.height[at(g, 2, 3)], 0.2, 1e-6);
  EXPECT_EQ(g.color[3 * at(g, 2, 3)], 42);
  EXPECT_EQ(g.color[0], 0);

  // Raw arrays give the same.
  const float xyz[3] = {cloud[0].x, cloud[0].y, cloud[0].z};
  const std::uint8_t rgb[3] = {42, 0, 0};
  HeightmapGrid a;
  projector.projectArrays(xyz, rgb, 1, world_from_cam, a);
  EXPECT_EQ(a.height, g.height);
  EXPECT_EQ(a.color, g.color);
  EXPECT_EQ(a.valid, g.valid);
}

// Synthetic 640 x 480 top-down RGB-D frame with the config's intrinsics: table at 0.7 m, a 0.1 m tall box, holes.
struct SyntheticFrame {
  static constexpr int kW = 640;
  static constexpr int kH = 480;
  CameraIntrinsics k{615.0, 615.0, 319.5, 239.5};
  std::vector<std::uint16_t> depth_mm = std::vector<std::uint16_t>(kW * kH);
  std::vector<float> depth_m = std::vector<float>(kW * kH);
  std::vector<std::uint8_t> rgb = std::vector<std::uint8_t>(kW * kH * 3);

  SyntheticFrame() {
    for (int v = 0; v < kH; ++v) {
      for (int u = 0; u < kW; ++u) {
        const int i = v * kW + u;
        // Depths are multiples of 125 mm so that mm / 1000 is exact in float too.
        std::uint16_t mm = 750;                                  // below the table: height clipped to 0
        if (u > 100 && u < 540) mm = 625;                        // 0.075 m above the table
        if (u > 250 && u < 400 && v > 150 && v < 300) mm = 500;  // box top, 0.2 m
        if ((u * 7 + v * 3) % 101 == 0) mm = 0;                  // holes: no return
        depth_mm[i] = mm;
        depth_m[i] = static_cast<float>(mm) / 1000.0f;
        // One colour per surface (as a rendered flat face): within a cell the top points tie to ~1 ulp, and which
        // of them wins is rounding noise (float cloud vs double depth path), so it must not matter.
        rgb[3 * i + 0] = static_cast<std::uint8_t>(mm / 5);
        rgb[3 * i + 1] = static_cast<std::uint8_t>(255 - mm / 5);
        rgb[3 * i + 2] = static_cast<std::uint8_t>(mm == 500 ? 200 : 30);
      }
    }
  }
  DepthImageView metres() const {
    return {reinterpret_cast<const std::uint8_t*>(depth_m.data()), kW, kH, kW * sizeof(float),
            DepthEncoding::kFloat32Metres};
  }
  DepthImageView millimetres() const {
    return {reinterpret_cast<const std::uint8_t*>(depth_mm.data()), kW, kH, kW * sizeof(std::uint16_t),
            DepthEncoding::kUint16Millimetres};
  }
  ColorImageView color() const { return {rgb.data(), kW * 3, false}; }
};

TEST(HeightmapProjector, DepthPathMatchesCloudPath) {
  HeightmapProjector projector(workspaceYamlConfig());
  const SyntheticFrame f;
  HeightmapGrid from_depth;
  projector.projectDepth(f.metres(), f.color(), f.k, cameraPose(), from_depth);
  const pcl::PointCloud<pcl::PointXYZRGB> cloud = HeightmapProjector::depthToCloud(f.metres(), f.color(), f.k);
  ASSERT_EQ(cloud.width, 640u);
  ASSERT_EQ(cloud.height, 480u);
  EXPECT_FALSE(cloud.is_dense);
  const HeightmapGrid from_cloud = projector.project(cloud, cameraPose());
  ASSERT_EQ(from_depth.valid.size(), from_cloud.valid.size());
  // The cloud holds float32 coordinates, the depth path doubles: a point right on a cell edge may switch cells.
  int same = 0;
  int valid = 0;
  for (std::size_t i = 0; i < from_depth.valid.size(); ++i) {
    valid += from_depth.valid[i] == 255 ? 1 : 0;
    const bool eq = from_depth.valid[i] == from_cloud.valid[i] &&
                    std::fabs(from_depth.height[i] - from_cloud.height[i]) <= 1e-6f &&
                    std::memcmp(&from_depth.color[3 * i], &from_cloud.color[3 * i], 3) == 0;
    same += eq ? 1 : 0;
  }
  const double n = static_cast<double>(from_depth.valid.size());
  EXPECT_GE(same / n, 0.999) << same << " of " << n;
  EXPECT_GE(valid / n, 0.95);  // the camera sees the whole workspace
  // Heights present in the scene: 0 (clipped), 0.075 and 0.2 m.
  int box = 0;
  for (std::size_t i = 0; i < from_depth.height.size(); ++i) {
    const float h = from_depth.height[i];
    EXPECT_TRUE(std::fabs(h) < 1e-6f || std::fabs(h - 0.075f) < 1e-6f || std::fabs(h - 0.2f) < 1e-6f) << h;
    box += std::fabs(h - 0.2f) < 1e-6f ? 1 : 0;
  }
  EXPECT_GT(box, 1000);
}

TEST(HeightmapProjector, MillimetreDepthEqualsMetreDepth) {
  HeightmapProjector projector(workspaceYamlConfig());
  const SyntheticFrame f;
  HeightmapGrid m;
  HeightmapGrid mm;
  projector.projectDepth(f.metres(), f.color(), f.k, cameraPose(), m);
  projector.projectDepth(f.millimetres(), f.color(), f.k, cameraPose(), mm);
  EXPECT_EQ(m.height, mm.height);
  EXPECT_EQ(m.valid, mm.valid);
  EXPECT_EQ(m.color, mm.color);
}

TEST(HeightmapProjector, BgrColourAndNoColour) {
  HeightmapProjector projector(workspaceYamlConfig());
  const SyntheticFrame f;
  HeightmapGrid rgb;
  HeightmapGrid bgr;
  HeightmapGrid none;
  std::vector<std::uint8_t> swapped(f.rgb);
  for (std::size_t i = 0; i < swapped.size(); i += 3) std::swap(swapped[i], swapped[i + 2]);
  projector.projectDepth(f.metres(), f.color(), f.k, cameraPose(), rgb);
  projector.projectDepth(f.metres(), {swapped.data(), 640 * 3, true}, f.k, cameraPose(), bgr);
  projector.projectDepth(f.metres(), {}, f.k, cameraPose(), none);
  EXPECT_EQ(rgb.color, bgr.color);
  EXPECT_EQ(rgb.height, none.height);
  for (std::uint8_t c : none.color) ASSERT_EQ(c, 0);
}

TEST(HeightmapProjector, HolesAreInvalidCells) {
  // The frame of pg_sim/test/test_sensor_model.py (test_depth_hole_becomes_invalid_cells), checked there against the
  // numpy reference: a 64 x 48 px depth image of a table 0.5 m below the camera (f = 100 px: 5 mm per pixel, 2 x 2 px
  // per 1 cm cell) with two 10 x 10 px holes, one of depth 0 and one NaN. Every cell under a hole is invalid (height
  // 0, colour black), every other cell valid: a hole is never table.
  ProjectorConfig c;
  c.bounds = {-0.16, 0.16, -0.12, 0.12, -0.01, 0.3};
  c.resolution = 0.01;
  HeightmapProjector projector(c);
  const int width = 64, height = 48;
  const CameraIntrinsics k{100.0, 100.0, 31.5, 23.5};
  std::vector<float> metres(static_cast<std::size_t>(width) * height, 0.5f);
  std::vector<std::uint16_t> mm(metres.size(), 500);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * width + u;
      const bool zero = v >= 10 && v < 20 && u >= 20 && u < 30, nan = v >= 30 && v < 40 && u >= 40 && u < 50;
      metres[i] = zero ? 0.0f : nan ? std::numeric_limits<float>::quiet_NaN() : metres[i];
      mm[i] = zero || nan ? 0 : mm[i];
    }
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // looking straight down: x_w = x, y_w = -y, z_w = 0.5 - z
  pose.linear() = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  pose.translation() = Eigen::Vector3d(0.0, 0.0, 0.5);
  const auto bytes = [](const void* data) { return static_cast<const std::uint8_t*>(data); };
  const DepthImageView as_metres{bytes(metres.data()), width, height, width * 4, DepthEncoding::kFloat32Metres};
  const DepthImageView as_mm{bytes(mm.data()), width, height, width * 2, DepthEncoding::kUint16Millimetres};
  HeightmapGrid from_metres, from_mm;
  projector.projectDepth(as_metres, {}, k, pose, from_metres);
  projector.projectDepth(as_mm, {}, k, pose, from_mm);
  HeightmapGrid from_cloud = projector.project(HeightmapProjector::depthToCloud(as_metres, {}, k), pose);
  for (const HeightmapGrid* g : {&from_metres, &from_mm, &from_cloud}) {
    ASSERT_EQ(g->rows, 24);
    ASSERT_EQ(g->cols, 32);
    for (int row = 0; row < g->rows; ++row) {
      for (int col = 0; col < g->cols; ++col) {
        // hole 0: pixels u 20..29, v 10..19 -> cols 10..14, rows 14..18; hole NaN: u 40..49, v 30..39 -> cols
        // 20..24, rows 4..8 (x = (u - cx) z / f, y = -(v - cy) z / f)
        const bool hole = (row >= 14 && row <= 18 && col >= 10 && col <= 14) ||
                          (row >= 4 && row <= 8 && col >= 20 && col <= 24);
        const std::size_t i = at(*g, row, col);
        EXPECT_EQ(g->valid[i], hole ? 0 : 255) << row << " " << col;
        EXPECT_FLOAT_EQ(g->height[i], hole ? 0.0f : 0.01f) << row << " " << col;
      }
    }
    EXPECT_EQ(countValid(*g), 24 * 32 - 2 * 25);
  }
}

TEST(HeightmapProjector, RejectsBadImages) {
  HeightmapProjector projector(smallConfig());
  const SyntheticFrame f;
  HeightmapGrid g;
  DepthImageView short_rows = f.metres();
  short_rows.step = 100;
  EXPECT_THROW(projector.projectDepth(short_rows, f.color(), f.k, Eigen::Isometry3d::Identity(), g),
               std::invalid_argument);
  EXPECT_THROW(projector.projectDepth(f.metres(), f.color(), CameraIntrinsics{}, Eigen::Isometry3d::Identity(), g),
               std::invalid_argument);
  EXPECT_THROW(projector.projectDepth(f.metres(), {f.rgb.data(), 10, false}, f.k, Eigen::Isometry3d::Identity(), g),
               std::invalid_argument);
}

}  // namespace
}  // namespace pg_policy

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
