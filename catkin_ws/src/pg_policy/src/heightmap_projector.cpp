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
// Two passes per chunk of points. locate(): each point's cell and height, written to per-point scratch arrays;
// branch-free, so the compiler vectorises it. scatterMax(): the running max per cell in input order, remembering the
// winning point's index; the colours are copied from the winners once at the end. The chunks (kChunk points, or one
// image row) keep the scratch in cache; the result is that of one pass over the frame, since the chunks are taken
// in input order. Measured on the 640 x 480 bench frame: 2.7 ms against 4.8 ms for one branchy pass that copied
// colours on every new maximum.

// world <- source transform as plain numbers (row-major rotation, translation).
struct Transform {
  double r[3][3];
  double t[3];
  explicit Transform(const Eigen::Isometry3d& m) {
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        r[i][j] = m.linear()(i, j);
      }
      t[i] = m.translation()(i);
    }
  }
};

// Cell and height of points 0..count-1, `point(i, px, py, pz)` giving point i in the source frame (m; `false`: no
// point there, e.g. a depth hole). cell[i]: row * cols + col, or -1 when the point is not used; height[i]: m above
// z_min, >= 0. col = floor((x - x_min) / res) is used when 0 <= col < cols, i.e. when 0 <= (x - x_min) / res < cols,
// and then equals the truncation of that quotient: the true division of the numpy reference, no floor call. A NaN
// anywhere fails a comparison and drops the point.
template <class PointAt>
__attribute__((target_clones("avx2", "default"))) void locate(const ProjectorConfig& c, int rows, int cols,
                                                              const Transform& tf, std::size_t count, PointAt point,
                                                              std::int32_t* cell, double* height) {
  const double x_min = c.bounds.x_min, y_min = c.bounds.y_min, z_min = c.bounds.z_min, z_max = c.bounds.z_max;
  const double res = c.resolution, n_cols = cols, n_rows = rows;
  const std::int32_t n = static_cast<std::int32_t>(count);  // begin() refused counts above 2^31 - 1
  for (std::int32_t i = 0; i < n; ++i) {
    double px, py, pz;
    const bool here = point(i, px, py, pz);
    // Same operation order as numpy's `pts @ R.T + t` so that results match to the last bit.
    const double z = tf.r[2][0] * px + tf.r[2][1] * py + tf.r[2][2] * pz + tf.t[2];
    const double x = tf.r[0][0] * px + tf.r[0][1] * py + tf.r[0][2] * pz + tf.t[0];
    const double y = tf.r[1][0] * px + tf.r[1][1] * py + tf.r[1][2] * pz + tf.t[1];
    const double qx = (x - x_min) / res;
    const double qy = (y - y_min) / res;
    const bool ok = here & (z < z_max) & (qx >= 0.0) & (qx < n_cols) & (qy >= 0.0) & (qy < n_rows);
    cell[i] = ok ? static_cast<std::int32_t>(qy) * cols + static_cast<std::int32_t>(qx) : -1;
    height[i] = std::max(z - z_min, 0.0);
  }
}

// Running max per cell over points in input order; on a tie the later point wins (>=), as numpy's fancy assignment
// does in the reference. best: per cell, -inf where empty; winner: per cell, index of the highest point (first + i);
// colour: per cell, colour_at(i) of the highest point (packed 0x00RRGGBB), when colour is not null. Branch-free
// in the comparison (it is taken at random).
template <class ColourAt>
void scatterMax(const std::int32_t* cell, const double* height, std::size_t count, std::int32_t first, double* best,
                std::int32_t* winner, std::uint32_t* colour, ColourAt colour_at) {
  for (std::size_t i = 0; i < count; ++i) {
    const std::int32_t idx = cell[i];
    if (idx < 0) {
      continue;
    }
    const double h = height[i];
    const double old = best[idx];
    const std::int32_t take = -static_cast<std::int32_t>(h >= old);  // all ones or zero
    best[idx] = std::max(old, h);  // equal values are the same number: which one is kept does not matter
    winner[idx] = (take & (first + static_cast<std::int32_t>(i))) | (~take & winner[idx]);
    if (colour != nullptr) {
      const auto t = static_cast<std::uint32_t>(take);
      colour[idx] = (t & colour_at(i)) | (~t & colour[idx]);
    }
  }
}

void scatterMax(const std::int32_t* cell, const double* height, std::size_t count, std::int32_t first, double* best,
                std::int32_t* winner) {
  scatterMax(cell, height, count, first, best, winner, nullptr, [](std::size_t) { return 0u; });
}

constexpr std::size_t kChunk = 4096;  // points per locate/scatter round of a cloud: the scratch stays in cache

// locate() + scatterMax() over points 0..count-1 in chunks of kChunk; cell and height: scratch of kChunk entries;
// colour (per cell, may be null) takes colour_at(point index) of each cell's highest point.
template <class PointAt, class ColourAt>
void locateAndScatter(const ProjectorConfig& c, int rows, int cols, const Transform& tf, std::size_t count,
                      PointAt point, std::int32_t* cell, double* height, double* best, std::int32_t* winner,
                      std::uint32_t* colour, ColourAt colour_at) {
  for (std::size_t start = 0; start < count; start += kChunk) {
    const std::size_t n = std::min(kChunk, count - start);
    const auto first = static_cast<std::int32_t>(start);
    locate(
        c, rows, cols, tf, n,
        [point, first](std::int32_t i, double& x, double& y, double& z) { return point(first + i, x, y, z); }, cell,
        height);
    scatterMax(cell, height, n, first, best, winner, colour, [&colour_at, start](std::size_t i) {
      return colour_at(start + i);
    });
  }
}

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

void HeightmapProjector::begin(HeightmapGrid& out, std::size_t points, std::size_t scratch) {
  const std::size_t n = static_cast<std::size_t>(rows_) * cols_;
  if (points > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    throw std::invalid_argument("HeightmapProjector: more than 2^31 - 1 points in one frame");
  }
  out.rows = rows_;
  out.cols = cols_;
  out.color.assign(3 * n, 0);
  out.height.resize(n);
  out.valid.resize(n);
  best_.assign(n, -std::numeric_limits<double>::infinity());
  winner_.assign(n, -1);
  colour_.assign(n, 0);
  cell_.resize(scratch);
  point_height_.resize(scratch);
}

template <class ColourOf>
void HeightmapProjector::finish(HeightmapGrid& out, ColourOf colour_of) const {
  const std::size_t n = best_.size();
  for (std::size_t i = 0; i < n; ++i) {
    const std::int32_t w = winner_[i];
    out.height[i] = w >= 0 ? static_cast<float>(best_[i]) : 0.0f;
    out.valid[i] = w >= 0 ? 255 : 0;
    if (w >= 0) {
      colour_of(i, w, out.color.data() + 3 * i);
    }
  }
}

namespace {

// |v| <= DBL_MAX: false for +-inf and NaN; a comparison, so that locate() stays vectorisable (std::isfinite is not).
inline bool finite(double v) { return std::abs(v) <= std::numeric_limits<double>::max(); }

}  // namespace

void HeightmapProjector::project(const pcl::PointCloud<pcl::PointXYZRGB>& cloud,
                                 const Eigen::Isometry3d& world_from_cloud, HeightmapGrid& out) {
  const std::size_t count = cloud.points.size();
  begin(out, count, std::min(count, kChunk));
  const pcl::PointXYZRGB* pts = cloud.points.data();
  locateAndScatter(
      config_, rows_, cols_, Transform(world_from_cloud), count,
      [pts](std::int32_t i, double& x, double& y, double& z) {
        x = pts[i].x;
        y = pts[i].y;
        z = pts[i].z;
        return finite(x) & finite(y) & finite(z);
      },
      cell_.data(), point_height_.data(), best_.data(), winner_.data(), colour_.data(),
      [pts](std::size_t i) { return pts[i].rgba & 0x00FFFFFFu; });  // the winners' colours while they are in cache
  const std::uint32_t* colour = colour_.data();
  finish(out, [colour](std::size_t cell, std::int32_t, std::uint8_t* c) {
    c[0] = static_cast<std::uint8_t>(colour[cell] >> 16);
    c[1] = static_cast<std::uint8_t>(colour[cell] >> 8);
    c[2] = static_cast<std::uint8_t>(colour[cell]);
  });
}

HeightmapGrid HeightmapProjector::project(const pcl::PointCloud<pcl::PointXYZRGB>& cloud,
                                          const Eigen::Isometry3d& world_from_cloud) {
  HeightmapGrid out;
  project(cloud, world_from_cloud, out);
  return out;
}

void HeightmapProjector::projectArrays(const float* xyz, const std::uint8_t* rgb, std::size_t count,
                                       const Eigen::Isometry3d& world_from_cloud, HeightmapGrid& out) {
  begin(out, count, std::min(count, kChunk));
  locateAndScatter(
      config_, rows_, cols_, Transform(world_from_cloud), count,
      [xyz](std::int32_t i, double& x, double& y, double& z) {
        x = xyz[3 * i];
        y = xyz[3 * i + 1];
        z = xyz[3 * i + 2];
        return finite(x) & finite(y) & finite(z);
      },
      cell_.data(), point_height_.data(), best_.data(), winner_.data(), nullptr, [](std::size_t) { return 0u; });
  finish(out, [rgb](std::size_t, std::int32_t w, std::uint8_t* c) {
    const std::uint8_t* src = rgb == nullptr ? nullptr : rgb + 3 * static_cast<std::size_t>(w);
    c[0] = src == nullptr ? 0 : src[0];
    c[1] = src == nullptr ? 0 : src[1];
    c[2] = src == nullptr ? 0 : src[2];
  });
}

namespace {

// locate() over one row of a depth image, `z` its depths (m, one per pixel): pixel u back-projected as
// pg_sim.world.camera.depth_to_points does, x = (u - cx) z / fx, y = (v - cy) z / fy (double precision); z <= 0 or
// non-finite: no return. The intrinsics are copied into locals so that the loop has no aliasing to fear.
void locateDepthRow(const ProjectorConfig& c, int rows, int cols, const Transform& tf, int width, double dv,
                    const CameraIntrinsics& k, const double* z_row, std::int32_t* cell, double* height) {
  const double fx = k.fx, fy = k.fy, cx = k.cx;
  locate(
      c, rows, cols, tf, static_cast<std::size_t>(width),
      [z_row, fx, fy, cx, dv](std::int32_t u, double& x, double& y, double& z) {
        z = z_row[u];
        x = (static_cast<double>(u) - cx) * z / fx;
        y = dv * z / fy;
        return (z > 0.0) & finite(z);
      },
      cell, height);
}

}  // namespace

void HeightmapProjector::projectDepth(const DepthImageView& depth, const ColorImageView& color,
                                      const CameraIntrinsics& intrinsics, const Eigen::Isometry3d& world_from_camera,
                                      HeightmapGrid& out) {
  checkDepthViews(depth, color, intrinsics);
  const std::size_t width = static_cast<std::size_t>(depth.width);
  begin(out, width * static_cast<std::size_t>(depth.height), width);
  const Transform tf(world_from_camera);
  depth_row_.resize(width);
  for (int v = 0; v < depth.height; ++v) {
    const std::uint8_t* drow = depth.data + static_cast<std::size_t>(v) * depth.step;
    double* z_row = depth_row_.data();
    if (depth.encoding == DepthEncoding::kFloat32Metres) {
      for (int u = 0; u < depth.width; ++u) z_row[u] = depthAt(drow, u, DepthEncoding::kFloat32Metres);
    } else {
      for (int u = 0; u < depth.width; ++u) z_row[u] = depthAt(drow, u, DepthEncoding::kUint16Millimetres);
    }
    locateDepthRow(config_, rows_, cols_, tf, depth.width, v - intrinsics.cy, intrinsics, z_row, cell_.data(),
                   point_height_.data());
    scatterMax(cell_.data(), point_height_.data(), width, static_cast<std::int32_t>(v * width), best_.data(),
               winner_.data());
  }
  finish(out, [&color, width](std::size_t, std::int32_t w, std::uint8_t* c) {
    if (color.data == nullptr) {
      c[0] = c[1] = c[2] = 0;
      return;
    }
    const std::size_t v = static_cast<std::size_t>(w) / width, u = static_cast<std::size_t>(w) % width;
    const std::uint8_t* src = color.data + v * color.step + 3 * u;
    c[0] = color.bgr ? src[2] : src[0];
    c[1] = src[1];
    c[2] = color.bgr ? src[0] : src[2];
  });
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
