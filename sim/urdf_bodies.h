#pragma once
// A URDF loaded into a Simbody system, seen through Eigen: set joint coordinates, read link poses.
// C++17-clean (no Simbody types): used by tests and tools that check the loader.
#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

namespace dca::sim {

/// A URDF file as Simbody bodies on Ground (the root link at the origin). Throws UrdfError on bad input. Not
/// copyable (it owns its Simbody system through impl_).
class UrdfBodies {
 public:
  /// Loads and validates `path` and builds the Simbody system.
  explicit UrdfBodies(const std::string& path);
  ~UrdfBodies();

  /// Names of the moving joints, parents first.
  std::vector<std::string> joints() const;
  /// Sets a joint's coordinates (1 for revolute/prismatic, 3 (angle, x, y) for planar, 7 for floating).
  void set_q(const std::string& joint, const std::vector<double>& q);
  /// The link's frame in Ground at the coordinates set so far.
  Eigen::Isometry3d link_pose(const std::string& link) const;
  /// Total mass of all bodies (kg).
  double total_mass() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dca::sim
