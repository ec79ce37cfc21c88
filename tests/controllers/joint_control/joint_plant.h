#pragma once
// Joints for joint_control's unit tests: a mock of N joints fed to a ControllerUnderTest's device inputs (Q<i>,
// Qd<i>) and moved by its commands (Cmd<i>) once per tick, as the mock hardware moves them (docs/robots.md, "The
// mock"): a position command is where the joint goes, through a first-order lag (0: at once); a velocity command
// is integrated; an effort command accelerates a unit inertia.
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include <dca/testing/controller.h>

namespace dca::joint_control::testing {

enum class Drive { Position, Velocity, Effort };

struct Joints {
  dca::testing::ControllerUnderTest& c;
  Eigen::VectorXd q, qd;
  Drive drive = Drive::Position;
  double lag = 0;       // s (position drive)
  double period = 0.01;  // s
  int dead = -1;        // a joint that ignores its commands, or -1

  static Eigen::VectorXd one(double v) { return Eigen::VectorXd::Constant(1, v); }

  /// The joints' state to the controller's inputs.
  void feed() {
    for (Eigen::Index i = 0; i < q.size(); ++i) {
      c.set("Q" + std::to_string(i + 1), one(q(i)));
      c.set("Qd" + std::to_string(i + 1), one(qd(i)));
    }
  }
  /// One tick: the state fed, one MainCalc, the joints moved by the commands it wrote.
  void tick() {
    feed();
    c.step();
    for (Eigen::Index i = 0; i < q.size(); ++i) {
      if (i == dead) {
        qd(i) = 0;
        continue;
      }
      const double u = c.get_vector("Cmd" + std::to_string(i + 1))(0), before = q(i);
      if (drive == Drive::Position) q(i) += (u - q(i)) * (lag > 0 ? period / (lag + period) : 1.0);
      if (drive == Drive::Velocity) q(i) += u * period;
      if (drive == Drive::Effort) q(i) += (qd(i) + u * period) * period;
      qd(i) = drive == Drive::Effort ? qd(i) + u * period : (q(i) - before) / period;
    }
  }
};

/// Why a controller of `type` with `params` is refused (the exception's text), or "(accepted)".
inline std::string refusal(std::string_view type, const std::vector<std::string>& params) {
  try {
    dca::testing::ControllerUnderTest c(type, params);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace dca::joint_control::testing
