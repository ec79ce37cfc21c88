#include "door/model_based_ctrl.h"

#include <cmath>

#include <dca/registry.h>
#include "door/ports.h"
#include "robot/model.h"

namespace dca::door {
namespace {
constexpr double kPi = 3.14159265358979323846;

const InSpec<robot::Vec3> kBasePose = robot::PoseIn("BasePose");
const Param<double> kModelBasedSpeed{.name = "speed", .doc = "the hand's speed along the circle, m/s", .def = 0.15,
                                     .above = 0};
const Param<double> kAngle{.name = "angle", .doc = "DONE when the door is open this far, degrees", .def = 75,
                           .above = 0};
const Param<double> kRadius{.name = "radius", .doc = "guessed distance from the hand to the hinge, m", .def = 0.75,
                            .above = 0};
const Param<std::string> kSide{.name = "side", .doc = "the hinge's side seen from the robot: right or left",
                               .def = "right", .allowed = {"right", "left"}};
const Param<double> kMinArc{.name = "min_arc", .doc = "the arc (rad) the hand must sweep before the estimate is used",
                            .def = 0.1, .above = 0};
}  // namespace

Manifest ModelBasedCtrl::Describe() {
  return {.type = "ModelBasedCtrl", .doc = "pushes the door open along the circle estimated from the hand's path",
          .inputs = {kBasePose, kJoints}, .outputs = {kVel},
          .params = {kModelBasedSpeed, kAngle, kRadius, kSide, kMinArc, PeriodParam()}, .ends = Ending::Done()};
}
ModelBasedCtrl::ModelBasedCtrl(const ControllerContext& ctx)
    : PeriodicController(ctx), pose_(port(kBasePose)), joints_(port(kJoints)), vel_(port(kVel)), arm_(robot::arm()),
      speed_(param(kModelBasedSpeed)), target_(param(kAngle) * kPi / 180), radius_(param(kRadius)),
      min_arc_(param(kMinArc)), side_(param(kSide) == "right" ? -1.0 : 1.0) {}
void ModelBasedCtrl::on_configure() {
  have_pose_ = have_q_ = started_ = false;
  est_.reset();
  v_.setZero();
}
bool ModelBasedCtrl::Plausible(const math::HingeEstimator& e, double prior_radius) {
  return e.fitted() && e.radius() > 0.5 * prior_radius && e.radius() < 2.0 * prior_radius;
}
void ModelBasedCtrl::MainCalc() {
  if (pose_.read(base_) == Read::New) have_pose_ = true;
  if (joints_.read(q_) == Read::New) have_q_ = true;
  if (!have_pose_ || !have_q_) {
    vel_.write(v_);
    return;
  }
  const double c = std::cos(base_[2]), s = std::sin(base_[2]);
  const Eigen::Vector3d tool = robot::tool_position(arm_, q_);
  const Eigen::Vector2d hand(base_[0] + c * tool.x() - s * tool.y(), base_[1] + s * tool.x() + c * tool.y());
  if (!started_) {
    // The door's plane is across the robot's heading; the hinge lies `radius` to the `side`.
    start_ = hand;
    push_ = Eigen::Vector2d(c, s);
    const Eigen::Vector2d left(-s, c);
    prior_centre_ = hand + side_ * radius_ * left;
    est_.emplace(prior_centre_, radius_, min_arc_);
    started_ = true;
  }
  est_->Add(hand);
  // The circle: the fitted one once the hand has swept enough arc and the fit is plausible, else the prior.
  const bool fitted = Plausible(*est_, radius_);
  const Eigen::Vector2d centre = fitted ? est_->centre() : prior_centre_;
  // Push direction: the circle's tangent whose sense agrees with the push at the start.
  Eigen::Vector2d r0 = start_ - centre, r = hand - centre;
  Eigen::Vector2d t(-r.y(), r.x());
  if (t.norm() < 1e-9) t = push_;
  t.normalize();
  if (Eigen::Vector2d(-r0.y(), r0.x()).dot(push_) < 0) t = -t;
  if (!fitted && t.dot(push_) < 0.5) t = push_;
  const double opened = std::abs(std::atan2(r0.x() * r.y() - r0.y() * r.x(), r0.dot(r)));
  if (fitted && opened >= target_) {
    vel_.write(robot::Vec9::Zero().eval());
    return Done(opened * 180 / kPi);
  }
  v_.setZero();
  v_[0] = speed_ * (c * t.x() + s * t.y());  // world -> base frame
  v_[1] = speed_ * (-s * t.x() + c * t.y());
  vel_.write(v_);
}

DCA_REGISTER_CONTROLLER(ModelBasedCtrl);

}  // namespace dca::door
