#include "math/kinematics.h"

#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

#include <fstream>
#include <sstream>

namespace dca::math {
namespace {

Eigen::Isometry3d ToEigen(const urdf::Pose& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  t.linear() = Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z).normalized().toRotationMatrix();
  return t;
}

}  // namespace

Chain::Chain(std::vector<Joint> joints) : joints_(std::move(joints)) {
  for (size_t i = 0; i < joints_.size(); ++i)
    if (joints_[i].type != Joint::Type::kFixed) movable_.push_back(static_cast<int>(i));
  dof_ = static_cast<int>(movable_.size());
}

std::optional<Chain> Chain::FromUrdfFile(const std::string& path, const std::string& base_link,
                                         const std::string& tip_link, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = path + ": cannot open the URDF file";
    return std::nullopt;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  return FromUrdfString(ss.str(), path, base_link, tip_link, error);
}

std::optional<Chain> Chain::FromUrdfString(const std::string& xml, const std::string& name,
                                           const std::string& base_link, const std::string& tip_link,
                                           std::string* error) {
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(xml);
  if (!model) {
    *error = name + ": not a valid URDF document";
    return std::nullopt;
  }
  if (!model->getLink(base_link)) {
    *error = name + ": no link '" + base_link + "'";
    return std::nullopt;
  }
  urdf::LinkConstSharedPtr link = model->getLink(tip_link);
  if (!link) {
    *error = name + ": no link '" + tip_link + "'";
    return std::nullopt;
  }
  std::vector<Joint> reversed;
  while (link->name != base_link) {
    const urdf::JointSharedPtr& uj = link->parent_joint;
    if (!uj) {
      *error = name + ": link '" + tip_link + "' is not below link '" + base_link + "'";
      return std::nullopt;
    }
    if (static_cast<int>(reversed.size()) >= 4 * kMaxDof) {
      *error = name + ": chain from '" + base_link + "' to '" + tip_link + "' is too long";
      return std::nullopt;
    }
    Joint j;
    j.name = uj->name;
    j.origin = ToEigen(uj->parent_to_joint_origin_transform);
    j.axis = Eigen::Vector3d(uj->axis.x, uj->axis.y, uj->axis.z);
    switch (uj->type) {
      case urdf::Joint::REVOLUTE:
      case urdf::Joint::CONTINUOUS:
        j.type = Joint::Type::kRevolute;
        break;
      case urdf::Joint::PRISMATIC:
        j.type = Joint::Type::kPrismatic;
        break;
      case urdf::Joint::FIXED:
        j.type = Joint::Type::kFixed;
        break;
      default:
        *error = name + ": joint '" + uj->name + "' is not revolute, continuous, prismatic or fixed";
        return std::nullopt;
    }
    if (j.type != Joint::Type::kFixed) {
      if (j.axis.norm() < 1e-12) {
        *error = name + ": joint '" + uj->name + "' has a zero axis";
        return std::nullopt;
      }
      j.axis.normalize();
      if (uj->limits && uj->type != urdf::Joint::CONTINUOUS) {
        j.lower = uj->limits->lower;
        j.upper = uj->limits->upper;
      }
    }
    reversed.push_back(std::move(j));
    link = model->getLink(uj->parent_link_name);
    if (!link) {
      *error = name + ": joint '" + uj->name + "' names a missing parent link";
      return std::nullopt;
    }
  }
  std::vector<Joint> joints(reversed.rbegin(), reversed.rend());
  Chain chain(std::move(joints));
  if (chain.dof() > kMaxDof) {
    *error = name + ": chain has " + std::to_string(chain.dof()) + " movable joints, at most " +
             std::to_string(kMaxDof) + " are supported";
    return std::nullopt;
  }
  return chain;
}

std::vector<std::string> Chain::joint_names() const {
  std::vector<std::string> out;
  for (int i : movable_) out.push_back(joints_[static_cast<size_t>(i)].name);
  return out;
}

Eigen::Isometry3d Chain::Forward(const JointVector& q) const {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  int k = 0;
  for (const Joint& j : joints_) {
    t = t * j.origin;
    if (j.type == Joint::Type::kRevolute) {
      t.rotate(Eigen::AngleAxisd(q[k++], j.axis));
    } else if (j.type == Joint::Type::kPrismatic) {
      t.translate(j.axis * q[k++]);
    }
  }
  return t * tool_;
}

void Chain::Jacobian(const JointVector& q, JacobianMatrix* J) const {
  J->setZero(6, dof_);
  // First pass: joint frames and axes in the base frame; the tool position comes at the end.
  Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kMaxDof> points(3, dof_), axes(3, dof_);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  int k = 0;
  for (const Joint& j : joints_) {
    t = t * j.origin;
    if (j.type == Joint::Type::kFixed) continue;
    points.col(k) = t.translation();
    axes.col(k) = t.linear() * j.axis;
    if (j.type == Joint::Type::kRevolute) {
      t.rotate(Eigen::AngleAxisd(q[k], j.axis));
    } else {
      t.translate(j.axis * q[k]);
    }
    ++k;
  }
  const Eigen::Vector3d tip = (t * tool_).translation();
  k = 0;
  for (const Joint& j : joints_) {
    if (j.type == Joint::Type::kFixed) continue;
    if (j.type == Joint::Type::kRevolute) {
      J->block<3, 1>(0, k) = axes.col(k).cross(tip - points.col(k));
      J->block<3, 1>(3, k) = axes.col(k);
    } else {
      J->block<3, 1>(0, k) = axes.col(k);
    }
    ++k;
  }
}

Eigen::Isometry3d BasePose::ToIsometry() const {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(x, y, 0);
  t.rotate(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return t;
}

Eigen::Isometry3d MobileForward(const BasePose& base, const Chain& arm, const JointVector& q) {
  return base.ToIsometry() * arm.Forward(q);
}

void MobileJacobian(const BasePose& base, const Chain& arm, const JointVector& q, JacobianMatrix* J) {
  const int n = arm.dof();
  J->setZero(6, n + 3);
  JacobianMatrix arm_j;
  arm.Jacobian(q, &arm_j);
  const Eigen::Isometry3d tb = base.ToIsometry();
  const Eigen::Matrix3d R = tb.linear();
  const Eigen::Vector3d tool = tb * arm.Forward(q).translation();
  const Eigen::Vector3d r = tool - tb.translation();
  (*J)(0, 0) = 1.0;                                             // base vx
  (*J)(1, 1) = 1.0;                                             // base vy
  J->block<3, 1>(0, 2) = Eigen::Vector3d::UnitZ().cross(r);     // yaw rate moves the tool about the base
  J->block<3, 1>(3, 2) = Eigen::Vector3d::UnitZ();
  J->block(0, 3, 3, n) = R * arm_j.topRows<3>();
  J->block(3, 3, 3, n) = R * arm_j.bottomRows<3>();
}

}  // namespace dca::math
