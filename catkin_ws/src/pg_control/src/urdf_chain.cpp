#include "pg_control/urdf_chain.h"

#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/jntarray.hpp>
#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace pg_control {
namespace {

KDL::Vector toKdl(const urdf::Vector3& v) { return KDL::Vector(v.x, v.y, v.z); }

KDL::Frame toKdl(const urdf::Pose& p) {
  return KDL::Frame(KDL::Rotation::Quaternion(p.rotation.x, p.rotation.y, p.rotation.z, p.rotation.w),
                    toKdl(p.position));
}

// The KDL joint of a URDF joint, expressed in the parent link frame (as kdl_parser does).
KDL::Joint toKdlJoint(const urdf::Joint& joint) {
  const KDL::Frame origin = toKdl(joint.parent_to_joint_origin_transform);
  switch (joint.type) {
    case urdf::Joint::FIXED:
      return KDL::Joint(joint.name, KDL::Joint::Fixed);
    case urdf::Joint::REVOLUTE:
    case urdf::Joint::CONTINUOUS:
      return KDL::Joint(joint.name, origin.p, origin.M * toKdl(joint.axis), KDL::Joint::RotAxis);
    case urdf::Joint::PRISMATIC:
      return KDL::Joint(joint.name, origin.p, origin.M * toKdl(joint.axis), KDL::Joint::TransAxis);
    default:
      throw std::runtime_error("URDF joint '" + joint.name + "' has a type KDL chains here do not support");
  }
}

}  // namespace

UrdfModelPtr parseUrdf(const std::string& xml, const std::string& source) {
  UrdfModelPtr model = urdf::parseURDF(xml);
  if (!model) throw std::runtime_error("cannot parse URDF from " + source);
  return model;
}

UrdfModelPtr loadUrdfFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open URDF file " + path);
  std::stringstream text;
  text << in.rdbuf();
  return parseUrdf(text.str(), path);
}

UrdfChain chainFromUrdf(const urdf::ModelInterface& model, const std::string& root_link, const std::string& tip_link) {
  if (!model.getLink(root_link)) throw std::runtime_error("URDF has no link '" + root_link + "'");
  urdf::LinkConstSharedPtr link = model.getLink(tip_link);
  if (!link) throw std::runtime_error("URDF has no link '" + tip_link + "'");

  std::vector<urdf::JointConstSharedPtr> joints;  // tip to root
  while (link->name != root_link) {
    const urdf::JointConstSharedPtr joint = link->parent_joint;
    if (!joint) throw std::runtime_error("URDF link '" + tip_link + "' is not below '" + root_link + "'");
    joints.push_back(joint);
    link = model.getLink(joint->parent_link_name);
    if (!link) throw std::runtime_error("URDF joint '" + joint->name + "' has no parent link");
  }
  std::reverse(joints.begin(), joints.end());

  constexpr double kInf = std::numeric_limits<double>::infinity();
  UrdfChain out;
  for (const auto& joint : joints) {
    out.chain.addSegment(
        KDL::Segment(joint->child_link_name, toKdlJoint(*joint), toKdl(joint->parent_to_joint_origin_transform)));
    out.segment_names.push_back(joint->child_link_name);
    if (joint->type == urdf::Joint::FIXED) continue;
    out.joint_names.push_back(joint->name);
    const bool bounded = joint->type != urdf::Joint::CONTINUOUS && joint->limits;
    out.lower.push_back(bounded ? joint->limits->lower : -kInf);
    out.upper.push_back(bounded ? joint->limits->upper : kInf);
    out.velocity.push_back(joint->limits && joint->limits->velocity > 0.0 ? joint->limits->velocity : kInf);
  }
  return out;
}

Eigen::Isometry3d fixedTransform(const urdf::ModelInterface& model, const std::string& root_link,
                                 const std::string& tip_link) {
  const UrdfChain c = chainFromUrdf(model, root_link, tip_link);
  if (!c.joint_names.empty()) {
    throw std::runtime_error("URDF: movable joint '" + c.joint_names.front() + "' between '" + root_link + "' and '" +
                             tip_link + "'");
  }
  KDL::ChainFkSolverPos_recursive fk(c.chain);
  KDL::Frame f = KDL::Frame::Identity();
  fk.JntToCart(KDL::JntArray(0), f);
  return toEigen(f);
}

Eigen::Isometry3d toEigen(const KDL::Frame& f) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    t.translation()(r) = f.p(r);
    for (int c = 0; c < 3; ++c) t.linear()(r, c) = f.M(r, c);
  }
  return t;
}

KDL::Frame toKdl(const Eigen::Isometry3d& t) {
  const Eigen::Matrix3d& m = t.linear();
  return KDL::Frame(KDL::Rotation(m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2)),
                    KDL::Vector(t.translation().x(), t.translation().y(), t.translation().z()));
}

}  // namespace pg_control
