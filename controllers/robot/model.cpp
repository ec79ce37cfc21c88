#include "robot/model.h"

#include <filesystem>
#include <stdexcept>

#include <dca/paths.h>

namespace dca::robot {

std::string urdf_path() { return (std::filesystem::path(models_dir()) / "mobile_manipulator.urdf").string(); }

math::Chain arm() {
  std::string error;
  auto chain = math::Chain::FromUrdfFile(urdf_path(), "base_link", "tool0", &error);
  if (!chain) throw std::invalid_argument(error);
  if (chain->dof() != 6)
    throw std::invalid_argument(urdf_path() + ": the arm base_link -> tool0 has " + std::to_string(chain->dof()) +
                                " movable joints, expected 6");
  return *chain;
}

Eigen::Isometry3d camera() {
  std::string error;
  auto chain = math::Chain::FromUrdfFile(urdf_path(), "base_link", "camera_link", &error);
  if (!chain) throw std::invalid_argument(error);
  if (chain->dof() != 0)
    throw std::invalid_argument(urdf_path() + ": the camera base_link -> camera_link has movable joints");
  return chain->Forward(math::JointVector(0));
}

Eigen::Vector3d tool_position(const math::Chain& arm, const Eigen::Matrix<double, 6, 1>& q) {
  math::JointVector jq = q;
  return arm.Forward(jq).translation();
}

}  // namespace dca::robot
