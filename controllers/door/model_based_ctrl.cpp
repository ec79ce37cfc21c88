#include "controllers/door/model_based_ctrl.h"

#include <cmath>

#include "controllers/registry.h"
#include "controllers/robot/model.h"

namespace dca::door {
namespace {
constexpr double kPi = 3.14159265358979323846;
}  // namespace

Manifest ModelBasedCtrl::Describe() {
  using P = ParamSpec;
  return {"ModelBasedCtrl", "pushes the door open along the circle estimated from the hand's path",
          {robot::PosePort("BasePose"), robot::JointsPort()}, {robot::VelPort()},
          {P::Number("speed", "0.15", "the hand's speed along the circle, m/s"),
           P::Number("angle", "75", "DONE when the door is open this far, degrees"),
           P::Number("radius", "0.75", "guessed distance from the hand to the hinge, m"),
           P::Optional("side", "string", "right", "the hinge's side seen from the robot: right or left"),
           P::Number("min_arc", "0.1", "the arc (rad) the hand must sweep before the estimate is used"),
           PeriodParam()},
          Ending::Done()};
}
ModelBasedCtrl::ModelBasedCtrl(const ControllerContext& ctx)
    : PeriodicController(ctx), pose_(input("BasePose")), joints_(input("Joints")), vel_(actuator("Vel")),
      arm_(robot::arm()), speed_(positive("speed")), target_(positive("angle") * kPi / 180),
      radius_(positive("radius")), min_arc_(positive("min_arc")) {
  const std::string side = text("side");
  if (side != "right" && side != "left") throw bad_param("side must be right or left, got '" + side + "'");
  side_ = side == "right" ? -1.0 : 1.0;
}
void ModelBasedCtrl::Init() {
  have_pose_ = have_q_ = started_ = false;
  est_.reset();
  v_.setZero();
}
bool ModelBasedCtrl::Plausible(const math::HingeEstimator& e, double prior_radius) {
  return e.fitted() && e.radius() > 0.5 * prior_radius && e.radius() < 2.0 * prior_radius;
}
void ModelBasedCtrl::MainCalc() {
  if (fresh(pose_, base_)) have_pose_ = true;
  if (fresh(joints_, q_)) have_q_ = true;
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
