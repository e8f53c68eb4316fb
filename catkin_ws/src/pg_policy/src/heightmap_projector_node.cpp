// heightmap_projector_node: camera data -> pg_msgs/Heightmap on /pg/heightmap (DESIGN.md section 5), in the config's
// world frame (`world`), stamped with the source stamp. The projection itself is the ROS-free HeightmapProjector.
//
// Params (private): ~input "cloud" (default: /camera/depth/color/points, sensor_msgs/PointCloud2 XYZRGB) or "depth"
// (ApproximateTime sync of /camera/color/image_raw rgb8|bgr8, /camera/aligned_depth_to_color/image_raw 32FC1 m|16UC1
// mm, /camera/color/camera_info); ~workspace_config (default: $(find pg_description)/config/workspace.yaml).
// Transform world <- source frame: tf2 at the source stamp (waiting up to 0.5 s of wall time, so a paused /clock cannot
// block it), else the latest one; none -> ROS_WARN_THROTTLE and no output. Subscribers use queue_size 1: never lags.
// Also /pg/heightmap/color (sensor_msgs/Image rgb8, the heightmap's colour layer) while someone subscribes (rviz).
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <pcl_conversions/pcl_conversions.h>
#include <pg_core/workspace_config.h>
#include <pg_msgs/Heightmap.h>
#include <ros/package.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <cstring>
#include <memory>
#include <string>

#include "pg_policy/heightmap_projector.h"

namespace enc = sensor_msgs::image_encodings;
using sensor_msgs::CameraInfoConstPtr;
using sensor_msgs::ImageConstPtr;

class HeightmapProjectorNode {
 public:
  HeightmapProjectorNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, const pg_policy::ProjectorConfig& config)
      : projector_(config), listener_(tf_) {
    pub_ = nh.advertise<pg_msgs::Heightmap>("/pg/heightmap", 1);
    color_pub_ = nh.advertise<sensor_msgs::Image>("/pg/heightmap/color", 1);
    const std::string input = pnh.param<std::string>("input", "cloud");
    if (input == "depth") {
      color_sub_.subscribe(nh, "/camera/color/image_raw", 1);
      depth_sub_.subscribe(nh, "/camera/aligned_depth_to_color/image_raw", 1);
      info_sub_.subscribe(nh, "/camera/color/camera_info", 1);
      sync_ = std::make_unique<Sync>(SyncPolicy(5), color_sub_, depth_sub_, info_sub_);
      sync_->registerCallback(&HeightmapProjectorNode::onRgbd, this);
    } else {
      if (input != "cloud") ROS_WARN("~input '%s' unknown (cloud|depth): using cloud", input.c_str());
      cloud_sub_ = nh.subscribe("/camera/depth/color/points", 1, &HeightmapProjectorNode::onCloud, this);
    }
    ROS_INFO("heightmap_projector_node: %s input -> %s, %d x %d cells of %.4f m in '%s'",
             input == "depth" ? "depth" : "cloud", pub_.getTopic().c_str(), projector_.rows(), projector_.cols(),
             config.resolution, config.world_frame.c_str());
  }

 private:
  using SyncPolicy =
      message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::Image, sensor_msgs::CameraInfo>;
  using Sync = message_filters::Synchronizer<SyncPolicy>;

  // world <- frame at stamp, else the latest; false (with a throttled warning) when tf has neither.
  bool lookup(const std::string& frame, const ros::Time& stamp, Eigen::Isometry3d& out) {
    const std::string& world = projector_.config().world_frame;
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(0.5);
    ros::Time at = stamp;
    while (!tf_.canTransform(world, frame, at)) {
      if (ros::WallTime::now() > deadline || !ros::ok()) {
        at = ros::Time(0);  // latest available
        break;
      }
      ros::WallDuration(0.005).sleep();
    }
    try {
      out = tf2::transformToEigen(tf_.lookupTransform(world, frame, at));
      return true;
    } catch (const tf2::TransformException& e) {
      ROS_WARN_THROTTLE(5.0, "heightmap_projector_node: no transform %s <- %s: %s", world.c_str(), frame.c_str(),
                        e.what());
      return false;
    }
  }

  void onCloud(const sensor_msgs::PointCloud2ConstPtr& msg) {
    Eigen::Isometry3d world_from_cloud;
    if (!lookup(msg->header.frame_id, msg->header.stamp, world_from_cloud)) return;
    pcl::fromROSMsg(*msg, cloud_);
    projector_.project(cloud_, world_from_cloud, grid_);
    publish(msg->header.stamp);
  }

  void onRgbd(const ImageConstPtr& color, const ImageConstPtr& depth, const CameraInfoConstPtr& info) {
    pg_policy::DepthImageView d{depth->data.data(), static_cast<int>(depth->width), static_cast<int>(depth->height),
                                depth->step, pg_policy::DepthEncoding::kFloat32Metres};
    if (depth->encoding == enc::TYPE_16UC1 || depth->encoding == enc::MONO16) {
      d.encoding = pg_policy::DepthEncoding::kUint16Millimetres;
    } else if (depth->encoding != enc::TYPE_32FC1) {
      ROS_WARN_THROTTLE(5.0, "heightmap_projector_node: depth encoding '%s' not 32FC1|16UC1", depth->encoding.c_str());
      return;
    }
    const bool color_ok = (color->encoding == enc::RGB8 || color->encoding == enc::BGR8) &&
                          color->width == depth->width && color->height == depth->height;
    if (!color_ok || depth->is_bigendian || info->K[0] <= 0.0) {
      ROS_WARN_THROTTLE(5.0,
                        "heightmap_projector_node: need rgb8|bgr8 colour of the depth size, little-endian depth "
                        "and a calibrated camera_info; got colour %s %ux%u, depth %ux%u",
                        color->encoding.c_str(), color->width, color->height, depth->width, depth->height);
      return;
    }
    const pg_policy::ColorImageView c{color->data.data(), color->step, color->encoding == enc::BGR8};
    const pg_policy::CameraIntrinsics k{info->K[0], info->K[4], info->K[2], info->K[5]};
    const std::string& frame = depth->header.frame_id.empty() ? color->header.frame_id : depth->header.frame_id;
    Eigen::Isometry3d world_from_camera;
    if (!lookup(frame, depth->header.stamp, world_from_camera)) return;
    try {
      projector_.projectDepth(d, c, k, world_from_camera, grid_);
    } catch (const std::invalid_argument& e) {
      ROS_WARN_THROTTLE(5.0, "heightmap_projector_node: %s", e.what());
      return;
    }
    publish(depth->header.stamp);
  }

  static void fillImage(const std_msgs::Header& header, int rows, int cols, const std::string& encoding, int bpp,
                        const void* data, sensor_msgs::Image& img) {
    img.header = header;
    img.height = rows;
    img.width = cols;
    img.encoding = encoding;
    img.is_bigendian = 0;
    img.step = cols * bpp;
    img.data.resize(static_cast<std::size_t>(img.step) * rows);
    std::memcpy(img.data.data(), data, img.data.size());
  }

  void publish(const ros::Time& stamp) {
    const pg_policy::ProjectorConfig& cfg = projector_.config();
    pg_msgs::HeightmapPtr msg(new pg_msgs::Heightmap);
    msg->header.stamp = stamp;
    msg->header.frame_id = cfg.world_frame;
    msg->resolution = cfg.resolution;
    msg->x_min = cfg.bounds.x_min;
    msg->x_max = cfg.bounds.x_max;
    msg->y_min = cfg.bounds.y_min;
    msg->y_max = cfg.bounds.y_max;
    msg->z_min = cfg.bounds.z_min;
    msg->z_max = cfg.bounds.z_max;
    fillImage(msg->header, grid_.rows, grid_.cols, enc::RGB8, 3, grid_.color.data(), msg->color);
    fillImage(msg->header, grid_.rows, grid_.cols, enc::TYPE_32FC1, 4, grid_.height.data(), msg->height);
    fillImage(msg->header, grid_.rows, grid_.cols, enc::MONO8, 1, grid_.valid.data(), msg->valid);
    pub_.publish(msg);
    if (color_pub_.getNumSubscribers() > 0) color_pub_.publish(msg->color);  // for rviz's Image display
  }

  pg_policy::HeightmapProjector projector_;
  pg_policy::HeightmapGrid grid_;
  pcl::PointCloud<pcl::PointXYZRGB> cloud_;
  tf2_ros::Buffer tf_;
  tf2_ros::TransformListener listener_;
  ros::Publisher pub_;
  ros::Publisher color_pub_;
  ros::Subscriber cloud_sub_;
  message_filters::Subscriber<sensor_msgs::Image> color_sub_;
  message_filters::Subscriber<sensor_msgs::Image> depth_sub_;
  message_filters::Subscriber<sensor_msgs::CameraInfo> info_sub_;
  std::unique_ptr<Sync> sync_;
};

int main(int argc, char** argv) {
  ros::init(argc, argv, "heightmap_projector_node");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  const std::string path =
      pnh.param<std::string>("workspace_config", ros::package::getPath("pg_description") + "/config/workspace.yaml");
  std::unique_ptr<HeightmapProjectorNode> node;
  try {
    node = std::make_unique<HeightmapProjectorNode>(
        nh, pnh, pg_policy::ProjectorConfig::fromWorkspace(pg_core::WorkspaceConfig::fromFile(path)));
  } catch (const std::exception& e) {
    ROS_FATAL("heightmap_projector_node: %s", e.what());
    return 1;
  }
  ros::spin();
  return 0;
}
