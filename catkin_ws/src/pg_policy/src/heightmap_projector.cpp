// ROS-free heightmap projector core; see include/pg_policy/heightmap_projector.h for the convention.
#include "pg_policy/heightmap_projector.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace pg_policy {

namespace {

// ---------------------------------------------------------------------------------------------------------------------
// The hot loop: transform one point into `world`, find its cell, keep the running max.

class Binner {
 public:
  Binner(const ProjectorConfig& config, int rows, int cols, const Eigen::Isometry3d& world_from_src, double* best,
         std::uint8_t* color)
      : x_min_(config.bounds.x_min),
        y_min_(config.bounds.y_min),
        z_min_(config.bounds.z_min),
        z_max_(config.bounds.z_max),
        res_(config.resolution),
        inv_res_(1.0 / config.resolution),
        rows_(rows),
        cols_(cols),
        best_(best),
        color_(color) {
    const Eigen::Matrix3d rot = world_from_src.linear();
    const Eigen::Vector3d t = world_from_src.translation();
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        r_[i][j] = rot(i, j);
      }
      t_[i] = t(i);
    }
  }

  // (px, py, pz): point in the source frame (m), finite. rgb: 3 bytes (order per `bgr`) or nullptr for black.
  inline void add(double px, double py, double pz, const std::uint8_t* rgb, bool bgr) {
    // Same operation order as numpy's `pts @ R.T + t` so that results match to the last bit where possible.
    const double z = r_[2][0] * px + r_[2][1] * py + r_[2][2] * pz + t_[2];
    if (!(z < z_max_)) {
      return;
    }
    const double x = r_[0][0] * px + r_[0][1] * py + r_[0][2] * pz + t_[0];
    const int col = cellIndex(x - x_min_, cols_);
    if (col < 0) {
      return;
    }
    const double y = r_[1][0] * px + r_[1][1] * py + r_[1][2] * pz + t_[1];
    const int row = cellIndex(y - y_min_, rows_);
    if (row < 0) {
      return;
    }
    const std::size_t idx = static_cast<std::size_t>(row) * static_cast<std::size_t>(cols_) + col;
    const double h = std::max(z - z_min_, 0.0);
    if (h >= best_[idx]) {  // >=: on a tie the later point wins, as in the numpy reference
      best_[idx] = h;
      std::uint8_t* c = color_ + 3 * idx;
      if (rgb == nullptr) {
        c[0] = c[1] = c[2] = 0;
      } else if (bgr) {
        c[0] = rgb[2];
        c[1] = rgb[1];
        c[2] = rgb[0];
      } else {
        c[0] = rgb[0];
        c[1] = rgb[1];
        c[2] = rgb[2];
      }
    }
  }

 private:
  // Cell index floor(d / res) in [0, n), or -1 outside, exactly as numpy computes it (a true division and floor),
  // but on the fast path with a multiplication and an integer cast (std::floor is a libm call without SSE4.1):
  // d * (1/res) is within a few ulp of d / res, so the two floors can only differ when the quotient lies within
  // ~1e-12 of an integer; only then is the exact expression evaluated.
  inline int cellIndex(double d, int n) const {
    const double q = d * inv_res_;
    if (!(q >= -1.0 && q < n + 1.0)) {  // far outside, or NaN
      return -1;
    }
    double f = static_cast<double>(static_cast<int>(q + 1.0)) - 1.0;  // floor(q) up to rounding near integers
    const double frac = q - f;
    if (frac < 1e-9 || frac > 1.0 - 1e-9) {
      f = std::floor(d / res_);
    }
    return f >= 0.0 && f < n ? static_cast<int>(f) : -1;
  }

  double r_[3][3];
  double t_[3];
  double x_min_, y_min_, z_min_, z_max_, res_, inv_res_;
  int rows_, cols_;
  double* best_;
  std::uint8_t* color_;
};

void checkDepthViews(const DepthImageView& depth, const ColorImageView& color, const CameraIntrinsics& k) {
  const std::size_t bpp = depth.encoding == DepthEncoding::kFloat32Metres ? sizeof(float) : sizeof(std::uint16_t);
  if (depth.data == nullptr || depth.width <= 0 || depth.height <= 0 ||
      depth.step < static_cast<std::size_t>(depth.width) * bpp) {
    throw std::invalid_argument("HeightmapProjector: bad depth image view");
  }
  if (color.data != nullptr && color.step < static_cast<std::size_t>(depth.width) * 3) {
    throw std::invalid_argument("HeightmapProjector: colour image rows shorter than 3 * depth width bytes");
  }
  if (!(k.fx > 0.0 && k.fy > 0.0) || !std::isfinite(k.cx) || !std::isfinite(k.cy)) {
    throw std::invalid_argument("HeightmapProjector: bad intrinsics (fx, fy must be > 0)");
  }
}

// Depth (m) of pixel u in a depth row; <= 0 or NaN means no return. 16UC1 is divided (not scaled by 0.001) so that
// a millimetre value and its float metre value agree exactly wherever the latter is exact.
inline double depthAt(const std::uint8_t* row, int u, DepthEncoding enc) {
  if (enc == DepthEncoding::kFloat32Metres) {
    float d;
    std::memcpy(&d, row + static_cast<std::size_t>(u) * sizeof(float), sizeof(float));
    return static_cast<double>(d);
  }
  std::uint16_t mm;
  std::memcpy(&mm, row + static_cast<std::size_t>(u) * sizeof(std::uint16_t), sizeof(std::uint16_t));
  return static_cast<double>(mm) / 1000.0;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------------------

ProjectorConfig ProjectorConfig::fromWorkspace(const pg_core::WorkspaceConfig& workspace) {
  ProjectorConfig c;
  c.bounds.x_min = workspace.xRange().min;
  c.bounds.x_max = workspace.xRange().max;
  c.bounds.y_min = workspace.yRange().min;
  c.bounds.y_max = workspace.yRange().max;
  c.bounds.z_min = workspace.zRange().min;
  c.bounds.z_max = workspace.zRange().max;
  c.resolution = workspace.resolution();
  c.world_frame = workspace.worldFrame();
  return c;
}

HeightmapProjector::HeightmapProjector(const ProjectorConfig& config) : config_(config) {
  const WorkspaceBounds& b = config.bounds;
  if (!(config.resolution > 0.0) || !(b.x_min < b.x_max) || !(b.y_min < b.y_max) || !(b.z_min < b.z_max)) {
    throw std::invalid_argument("HeightmapProjector: resolution must be > 0 and every bound min < max");
  }
  cols_ = static_cast<int>(std::lround((b.x_max - b.x_min) / config.resolution));
  rows_ = static_cast<int>(std::lround((b.y_max - b.y_min) / config.resolution));
  if (rows_ <= 0 || cols_ <= 0) {
    throw std::invalid_argument("HeightmapProjector: workspace smaller than one cell");
  }
  best_.reserve(static_cast<std::size_t>(rows_) * cols_);
}

void HeightmapProjector::begin(HeightmapGrid& out) {
  const std::size_t n = static_cast<std::size_t>(rows_) * cols_;
  out.rows = rows_;
  out.cols = cols_;
  out.color.assign(3 * n, 0);
  out.height.resize(n);
  out.valid.resize(n);
  best_.assign(n, -std::numeric_limits<double>::infinity());
}

void HeightmapProjector::finish(HeightmapGrid& out) const {
  const std::size_t n = best_.size();
  for (std::size_t i = 0; i < n; ++i) {
    const bool valid = best_[i] > -std::numeric_limits<double>::infinity();
    out.height[i] = valid ? static_cast<float>(best_[i]) : 0.0f;
    out.valid[i] = valid ? 255 : 0;
  }
}

void HeightmapProjector::project(const pcl::PointCloud<pcl::PointXYZRGB>& cloud,
                                 const Eigen::Isometry3d& world_from_cloud, HeightmapGrid& out) {
  begin(out);
  Binner binner(config_, rows_, cols_, world_from_cloud, best_.data(), out.color.data());
  for (const pcl::PointXYZRGB& p : cloud.points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      continue;
    }
    const std::uint8_t rgb[3] = {p.r, p.g, p.b};
    binner.add(p.x, p.y, p.z, rgb, false);
  }
  finish(out);
}

HeightmapGrid HeightmapProjector::project(const pcl::PointCloud<pcl::PointXYZRGB>& cloud,
                                          const Eigen::Isometry3d& world_from_cloud) {
  HeightmapGrid out;
  project(cloud, world_from_cloud, out);
  return out;
}

void HeightmapProjector::projectArrays(const float* xyz, const std::uint8_t* rgb, std::size_t count,
                                       const Eigen::Isometry3d& world_from_cloud, HeightmapGrid& out) {
  begin(out);
  Binner binner(config_, rows_, cols_, world_from_cloud, best_.data(), out.color.data());
  for (std::size_t i = 0; i < count; ++i) {
    const float* p = xyz + 3 * i;
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      continue;
    }
    binner.add(p[0], p[1], p[2], rgb == nullptr ? nullptr : rgb + 3 * i, false);
  }
  finish(out);
}

void HeightmapProjector::projectDepth(const DepthImageView& depth, const ColorImageView& color,
                                      const CameraIntrinsics& intrinsics, const Eigen::Isometry3d& world_from_camera,
                                      HeightmapGrid& out) {
  checkDepthViews(depth, color, intrinsics);
  begin(out);
  Binner binner(config_, rows_, cols_, world_from_camera, best_.data(), out.color.data());
  for (int v = 0; v < depth.height; ++v) {
    const std::uint8_t* drow = depth.data + static_cast<std::size_t>(v) * depth.step;
    const std::uint8_t* crow = color.data == nullptr ? nullptr : color.data + static_cast<std::size_t>(v) * color.step;
    const double dv = v - intrinsics.cy;
    for (int u = 0; u < depth.width; ++u) {
      const double z = depthAt(drow, u, depth.encoding);
      if (!(z > 0.0) || !std::isfinite(z)) {
        continue;
      }
      // Same expressions as pg_sim.world.camera.depth_to_points: (u - cx) * z / fx, (v - cy) * z / fy.
      const double x = (u - intrinsics.cx) * z / intrinsics.fx;
      const double y = dv * z / intrinsics.fy;
      binner.add(x, y, z, crow == nullptr ? nullptr : crow + 3 * static_cast<std::size_t>(u), color.bgr);
    }
  }
  finish(out);
}

pcl::PointCloud<pcl::PointXYZRGB> HeightmapProjector::depthToCloud(const DepthImageView& depth,
                                                                   const ColorImageView& color,
                                                                   const CameraIntrinsics& intrinsics) {
  checkDepthViews(depth, color, intrinsics);
  pcl::PointCloud<pcl::PointXYZRGB> cloud(static_cast<std::uint32_t>(depth.width),
                                          static_cast<std::uint32_t>(depth.height));
  cloud.is_dense = true;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < depth.height; ++v) {
    const std::uint8_t* drow = depth.data + static_cast<std::size_t>(v) * depth.step;
    const std::uint8_t* crow = color.data == nullptr ? nullptr : color.data + static_cast<std::size_t>(v) * color.step;
    for (int u = 0; u < depth.width; ++u) {
      pcl::PointXYZRGB& p = cloud.at(u, v);
      const double z = depthAt(drow, u, depth.encoding);
      if (!(z > 0.0) || !std::isfinite(z)) {
        p.x = p.y = p.z = nan;
        cloud.is_dense = false;
      } else {
        p.x = static_cast<float>((u - intrinsics.cx) * z / intrinsics.fx);
        p.y = static_cast<float>((v - intrinsics.cy) * z / intrinsics.fy);
        p.z = static_cast<float>(z);
      }
      if (crow != nullptr) {
        const std::uint8_t* c = crow + 3 * static_cast<std::size_t>(u);
        p.r = color.bgr ? c[2] : c[0];
        p.g = c[1];
        p.b = color.bgr ? c[0] : c[2];
      } else {
        p.r = p.g = p.b = 0;
      }
    }
  }
  return cloud;
}

}  // namespace pg_policy
