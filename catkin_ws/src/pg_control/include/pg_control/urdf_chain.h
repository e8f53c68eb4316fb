// KDL chains from the project's URDF, parsed with urdfdom only (ROS-free).
//
// Why not kdl_parser: on Debian its library links liburdf, which links roscpp (treeFromParam). The conversion below is
// the same as kdl_parser's (segment = child link, joint at the parent->joint origin, axis in the parent frame).
#ifndef PG_CONTROL_URDF_CHAIN_H
#define PG_CONTROL_URDF_CHAIN_H

#include <Eigen/Geometry>
#include <kdl/chain.hpp>
#include <memory>
#include <string>
#include <vector>

namespace urdf {
class ModelInterface;
}  // namespace urdf

namespace pg_control {

using UrdfModelPtr = std::shared_ptr<urdf::ModelInterface>;

// Parses URDF XML. Throws std::runtime_error (with `source` in the message) when it is not a valid URDF.
UrdfModelPtr parseUrdf(const std::string& xml, const std::string& source = "<robot_description>");
// Reads and parses a URDF file. Throws std::runtime_error naming the file.
UrdfModelPtr loadUrdfFile(const std::string& path);

// The serial chain root_link -> tip_link and its movable joints in chain order.
struct UrdfChain {
  KDL::Chain chain;                      // segments named after their child links
  std::vector<std::string> joint_names;  // movable joints, root to tip
  std::vector<double> lower;             // position limits (rad or m); +-inf for continuous joints
  std::vector<double> upper;
  std::vector<double> velocity;          // velocity limits (rad/s or m/s); +inf when the URDF gives none
  std::vector<std::string> segment_names;  // child link of every segment (fixed ones included)
};

// Builds the chain from `root_link` down to `tip_link`. Throws std::runtime_error when a link is missing, `tip_link`
// is not below `root_link`, or a joint type is not fixed/revolute/continuous/prismatic.
UrdfChain chainFromUrdf(const urdf::ModelInterface& model, const std::string& root_link, const std::string& tip_link);

// root_link <- tip_link for a chain of fixed joints only (e.g. world <- <arm>_base_link). Throws std::runtime_error
// like chainFromUrdf, or when a movable joint lies between the two links.
Eigen::Isometry3d fixedTransform(const urdf::ModelInterface& model, const std::string& root_link,
                                 const std::string& tip_link);

// KDL frame -> Eigen isometry (same units).
Eigen::Isometry3d toEigen(const KDL::Frame& f);
// Eigen isometry -> KDL frame.
KDL::Frame toKdl(const Eigen::Isometry3d& t);

}  // namespace pg_control

#endif  // PG_CONTROL_URDF_CHAIN_H
