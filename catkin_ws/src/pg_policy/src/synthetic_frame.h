// A synthetic top-down 640 x 480 RGB-D frame for the projector benchmark and its gtest: the config/workspace.yaml
// camera (0.7 m above the table, optical axis down), boxes 5-8 cm tall, +-1 mm noise, ~1 % holes (depth 0).
#ifndef PG_POLICY_SYNTHETIC_FRAME_H
#define PG_POLICY_SYNTHETIC_FRAME_H

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <vector>

#include "pg_policy/heightmap_projector.h"

namespace pg_policy {

struct SyntheticFrame {
  static constexpr int kWidth = 640;
  static constexpr int kHeight = 480;
  CameraIntrinsics intrinsics{615.0, 615.0, 319.5, 239.5};
  std::vector<float> depth_m;           // 32FC1 metres, 0 = hole
  std::vector<std::uint16_t> depth_mm;  // the same in 16UC1 millimetres
  std::vector<std::uint8_t> rgb;        // rgb8
  Eigen::Isometry3d world_from_camera;  // xyz (0, 0, 0.7), rpy (pi, 0, -pi/2) as in config/workspace.yaml

  SyntheticFrame() : depth_m(kWidth * kHeight), depth_mm(kWidth * kHeight), rgb(3 * kWidth * kHeight) {
    std::uint32_t seed = 12345;
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        seed = seed * 1664525u + 1013904223u;  // LCG noise, +-1 mm
        float z = 0.7f + ((seed >> 16) % 3 - 1) * 0.001f;
        if (((u / 80) + (v / 80)) % 3 == 0) z -= 0.05f + 0.01f * ((u / 80) % 4);  // boxes 5-8 cm tall
        if ((seed >> 8) % 100 == 0) z = 0.0f;                                     // holes
        const int i = v * kWidth + u;
        depth_m[i] = z;
        depth_mm[i] = static_cast<std::uint16_t>(std::lround(z * 1000.0f));
        rgb[3 * i] = static_cast<std::uint8_t>(u);
        rgb[3 * i + 1] = static_cast<std::uint8_t>(v);
        rgb[3 * i + 2] = static_cast<std::uint8_t>(u + v);
      }
    }
    world_from_camera = Eigen::Isometry3d::Identity();
    world_from_camera.linear() =
        (Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))
            .toRotationMatrix();
    world_from_camera.translation() = Eigen::Vector3d(0.0, 0.0, 0.7);
  }

  DepthImageView metres() const {
    return {reinterpret_cast<const std::uint8_t*>(depth_m.data()), kWidth, kHeight, kWidth * sizeof(float),
            DepthEncoding::kFloat32Metres};
  }
  DepthImageView millimetres() const {
    return {reinterpret_cast<const std::uint8_t*>(depth_mm.data()), kWidth, kHeight, kWidth * sizeof(std::uint16_t),
            DepthEncoding::kUint16Millimetres};
  }
  ColorImageView color() const { return {rgb.data(), kWidth * 3, false}; }
  // The organised PointXYZRGB cloud of the frame (camera optical frame, NaN at holes).
  pcl::PointCloud<pcl::PointXYZRGB> cloud() const {
    return HeightmapProjector::depthToCloud(metres(), color(), intrinsics);
  }
};

}  // namespace pg_policy

#endif  // PG_POLICY_SYNTHETIC_FRAME_H
