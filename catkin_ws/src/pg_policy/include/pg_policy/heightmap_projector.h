// Top-down workspace heightmap from a coloured point cloud or an aligned RGB-D image pair (DESIGN.md sections 3, 5).
// ROS-free core of heightmap_projector_node; must give the same heightmap as the numpy reference
// pg_core.heightmap.project / from_camera_cloud.
//
// Grid convention (VPG/ravens), all in the `world` frame, metres:
//   col = floor((x - x_min) / resolution), row = floor((y - y_min) / resolution),
//   rows = round((y_max - y_min) / resolution), cols = round((x_max - x_min) / resolution).
// A point is used when x, y, z are finite, 0 <= col < cols, 0 <= row < rows and z < z_max. Points below z_min are kept
// with height 0 (height = max(z - z_min, 0)), exactly as the numpy reference does (sensor noise under the table).
// Each cell keeps its HIGHEST point (explicit running max in double precision, no sorting); its colour is
// the colour of that point. Ties (equal heights): the LATER point in input order wins, as numpy's fancy assignment
// `color[flat[winner]] = rgb[winner]` does in the reference. Empty cells: height 0, colour (0, 0, 0), valid 0.
// A depth hole (0 or non-finite depth, a NaN point) is no point: a cell that receives no valid point is invalid,
// never table, whatever the reason (occlusion, no return, a sensor's invalid pixels along depth edges).
#ifndef PG_POLICY_HEIGHTMAP_PROJECTOR_H
#define PG_POLICY_HEIGHTMAP_PROJECTOR_H

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pg_core/workspace_config.h>

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace pg_policy {

// Workspace box around `world` (m).
struct WorkspaceBounds {
  double x_min = 0.0;
  double x_max = 0.0;
  double y_min = 0.0;
  double y_max = 0.0;
  double z_min = 0.0;
  double z_max = 0.0;
};

// The part of pg_description's config/workspace.yaml the projector needs: `workspace.{x,y,z}`,
// `heightmap.resolution`, `frames.world`. The file is read (and validated) only by pg_core::WorkspaceConfig; build
// this with fromWorkspace(pg_core::WorkspaceConfig::fromFile(path)), or fill it in directly (tests).
struct ProjectorConfig {
  WorkspaceBounds bounds;
  double resolution = 0.0;            // m per cell
  std::string world_frame = "world";  // frame the grid is laid out in

  // Copies the workspace box (m, `world`), the heightmap resolution (m per cell) and `frames.world`. Never throws
  // beyond std::bad_alloc: a WorkspaceConfig is valid once constructed.
  static ProjectorConfig fromWorkspace(const pg_core::WorkspaceConfig& workspace);
};

// Pinhole intrinsics (pixels, pixel-centre convention: pixel (u, v) centre at (u, v)), e.g. CameraInfo K.
struct CameraIntrinsics {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
};

// Depth image encodings accepted (REP 118): 32FC1 metres, 16UC1 millimetres. 0 or non-finite = no return.
enum class DepthEncoding { kFloat32Metres, kUint16Millimetres };

// Non-owning view of a depth image, row-major, `step` bytes per row, in the camera optical frame
// (x right, y down, z forward along the optical axis).
struct DepthImageView {
  const std::uint8_t* data = nullptr;
  int width = 0;
  int height = 0;
  std::size_t step = 0;  // bytes per row
  DepthEncoding encoding = DepthEncoding::kFloat32Metres;
};

// Non-owning view of an 8-bit 3-channel colour image aligned pixel-for-pixel with the depth image.
// data == nullptr: every point gets colour (0, 0, 0).
struct ColorImageView {
  const std::uint8_t* data = nullptr;
  std::size_t step = 0;  // bytes per row
  bool bgr = false;      // channel order bgr8 instead of rgb8
};

// Output grid, row-major (row = y index, col = x index), frame `world`.
struct HeightmapGrid {
  int rows = 0;
  int cols = 0;
  std::vector<std::uint8_t> color;  // rows * cols * 3, rgb8 of each cell's highest point, (0, 0, 0) where empty
  std::vector<float> height;        // rows * cols, metres above z_min (>= 0), 0 where empty
  std::vector<std::uint8_t> valid;  // rows * cols, 255 = at least one point fell in the cell, 0 = none
};

class HeightmapProjector {
 public:
  // Throws std::invalid_argument for a non-positive resolution or an empty box.
  explicit HeightmapProjector(const ProjectorConfig& config);

  const ProjectorConfig& config() const { return config_; }
  int rows() const { return rows_; }
  int cols() const { return cols_; }

  // Cloud path. `world_from_cloud` maps points of the cloud's frame into `world`. Organised or not; NaN points are
  // skipped. `out` is resized and overwritten (its buffers are reused across calls).
  void project(const pcl::PointCloud<pcl::PointXYZRGB>& cloud, const Eigen::Isometry3d& world_from_cloud,
               HeightmapGrid& out);
  HeightmapGrid project(const pcl::PointCloud<pcl::PointXYZRGB>& cloud, const Eigen::Isometry3d& world_from_cloud);

  // Raw-array path: `xyz` holds count * 3 floats (m, cloud frame), `rgb` count * 3 bytes (rgb8; may be nullptr).
  void projectArrays(const float* xyz, const std::uint8_t* rgb, std::size_t count,
                     const Eigen::Isometry3d& world_from_cloud, HeightmapGrid& out);

  // Depth-image path: back-projects every pixel, x = (u - cx) z / fx, y = (v - cy) z / fy (double precision, as
  // pg_sim.world.camera.depth_to_points), in row-major pixel order, then projects as above. `world_from_camera` maps
  // the optical frame of the (aligned) images into `world`. Throws std::invalid_argument for bad image views.
  void projectDepth(const DepthImageView& depth, const ColorImageView& color, const CameraIntrinsics& intrinsics,
                    const Eigen::Isometry3d& world_from_camera, HeightmapGrid& out);

  // The organised cloud (width x height, camera optical frame, NaN where no return) the depth path projects; for
  // tests and tools (the depth path itself does not build it).
  static pcl::PointCloud<pcl::PointXYZRGB> depthToCloud(const DepthImageView& depth, const ColorImageView& color,
                                                        const CameraIntrinsics& intrinsics);

 private:
  // Sizes and clears `out`, the per-cell running max and the per-point scratch for `scratch` points of a frame of
  // `points` points (throws std::invalid_argument above 2^31 - 1 points); finish() writes heights, validity and
  // the winners' colours, colour_of(cell index, winning point index, rgb out[3]).
  void begin(HeightmapGrid& out, std::size_t points, std::size_t scratch);
  template <class ColourOf>
  void finish(HeightmapGrid& out, ColourOf colour_of) const;

  ProjectorConfig config_;
  int rows_ = 0;
  int cols_ = 0;
  std::vector<double> best_;          // rows * cols: running max height (m above z_min), -inf where empty
  std::vector<std::int32_t> winner_;  // rows * cols: input index of each cell's highest point, -1 where empty
  std::vector<std::uint32_t> colour_;  // rows * cols: cloud path, packed 0x00RRGGBB of each cell's highest point
  std::vector<std::int32_t> cell_;    // per point of the current chunk: row * cols + col, -1 when not used
  std::vector<double> point_height_;  // per point of the current chunk: height above z_min (m, >= 0)
  std::vector<double> depth_row_;     // depth path: one image row in metres
};

}  // namespace pg_policy

#endif  // PG_POLICY_HEIGHTMAP_PROJECTOR_H
