#pragma once
// The baseline of the URDF world's benchmark (tests/bench/urdf_world_bench.cpp): the same URDF in Simbody with
// gravity and the loader's forces only, stepped by the same integrator (sim/urdf/integrate.h), with no ports,
// no servos and no safety layer. C++17-clean.
#include <memory>
#include <string>

namespace dca::sim {

class BareUrdf {
 public:
  /// Loads `path` (sim/urdf/description.h's checks) and builds its system. Throws UrdfError.
  BareUrdf(const std::string& path, double period);
  ~BareUrdf();
  BareUrdf(const BareUrdf&) = delete;
  BareUrdf& operator=(const BareUrdf&) = delete;
  /// One period.
  void step();
  /// The first coordinate of the system (to keep the work observable).
  double q0() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dca::sim
