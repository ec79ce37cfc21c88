#pragma once
// The robot's geometry, read from its URDF (the file `dca sim` loads): the arm chain and the camera's pose.
#include <Eigen/Geometry>
#include <string>

#include "math/kinematics.h"

namespace dca::robot {

/// The robot's URDF: mobile_manipulator.urdf in the models directory (dca::models_dir(), host/paths.h).
std::string urdf_path();
/// The arm chain base_link -> tool0 of the robot's URDF. Throws std::invalid_argument naming the file (a
/// controller's constructor lets it through: see dca/controller.h).
math::Chain arm();
/// The camera's pose (camera_link: x along the optical axis, y left, z up) in base_link, from the robot's URDF.
/// Throws std::invalid_argument naming the file.
Eigen::Isometry3d camera();
/// The tool's position in the base frame at joint angles `q`.
Eigen::Vector3d tool_position(const math::Chain& arm, const Eigen::Matrix<double, 6, 1>& q);

}  // namespace dca::robot
