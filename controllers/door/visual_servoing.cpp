#include "door/visual_servoing.h"

#include <cmath>

#include <dca/registry.h>
#include "door/ports.h"
#include "robot/model.h"

namespace dca::door {

namespace {
const InSpec<robot::Vec3> kFeature = robot::FeatureIn();
const Param<double> kServoSpeed{.name = "speed", .doc = "forward speed, m/s", .def = 0.25};
const Param<double> kServoGain{.name = "gain", .doc = "turn rate per radian of bearing error, 1/s", .def = 1.5};
const Param<double> kHfov{.name = "hfov", .doc = "the camera's horizontal field of view, rad", .def = 1.0471975511965976,
                          .above = 0};
const Param<double> kWidth{.name = "width", .doc = "the image's width, px", .def = 640, .above = 0};
const Param<double> kLost{.name = "lost", .doc = "ABORTED when the handle is not seen for this long, s", .def = 0.5,
                          .above = 0};
const Param<double> kHeight{.name = "height", .doc = "the image's height, px", .def = 480, .above = 0};
const Param<double> kHandleHeight{.name = "handle_height", .doc = "the handle's height above the floor, m", .def = 1};
const Param<double> kLateral{.name = "lateral", .doc = "the gripper's lateral position in the base frame (left +), m",
                             .def = -0.075};
}  // namespace

Manifest VisualServoing::Describe() {
  return {.type = "VisualServoing",
          .doc = "drives the robot towards the handle, lining the gripper up with it in the image",
          .inputs = {kFeature}, .outputs = {kVel},
          .params = {kServoSpeed, kServoGain, kHfov, kWidth, kLost, kHeight, kHandleHeight, kLateral, PeriodParam()},
          .ends = Ending::Aborted()};
}
VisualServoing::VisualServoing(const ControllerContext& ctx)
    : PeriodicController(ctx), feature_(port(kFeature)), vel_(port(kVel)), speed_(param(kServoSpeed)),
      gain_(param(kServoGain)), lost_(param(kLost)), handle_height_(param(kHandleHeight)), lateral_(param(kLateral)),
      camera_(robot::camera()) {
  const double width = param(kWidth);
  focal_ = (width / 2) / std::tan(param(kHfov) / 2);
  centre_u_ = width / 2;
  centre_v_ = param(kHeight) / 2;
}
robot::Vec9 VisualServoing::Law(double u, double speed, double gain, double focal_px, double centre_u) {
  // u grows to the right, which is -y of the base: a handle right of centre needs a negative yaw rate.
  const double bearing = std::atan2(u - centre_u, focal_px);
  Vec9 v = Vec9::Zero();
  v[6] = speed;
  v[8] = -gain * bearing;
  return v;
}
std::optional<Eigen::Vector2d> VisualServoing::Locate(double u, double v, const Eigen::Isometry3d& camera,
                                                      double focal_px, double centre_u, double centre_v,
                                                      double height) {
  // The pixel's ray in the camera frame (u right = -y, v down = -z), then in the base frame.
  const Eigen::Vector3d ray = camera.linear() * Eigen::Vector3d(1, -(u - centre_u) / focal_px, -(v - centre_v) / focal_px);
  const Eigen::Vector3d o = camera.translation();
  if (!(ray.z() < -1e-6) || !(height < o.z())) return std::nullopt;
  const double s = (height - o.z()) / ray.z();
  const Eigen::Vector3d p = o + s * ray;
  if (!(p.x() > 0)) return std::nullopt;
  return Eigen::Vector2d(p.x(), p.y());
}
robot::Vec9 VisualServoing::Steer(const Eigen::Vector2d& handle, double lateral, double speed, double gain) {
  Vec9 v = Vec9::Zero();
  v[6] = speed;
  v[8] = gain * std::atan2(handle.y() - lateral, handle.x());
  return v;
}
void VisualServoing::on_start(const msgpack::object&) {
  last_seen_ = now();
  v_.setZero();
}
void VisualServoing::MainCalc() {
  if (feature_.read(f_) == Read::New && f_[2] > 0.5) {
    last_seen_ = now();
    const auto handle = Locate(f_[0], f_[1], camera_, focal_, centre_u_, centre_v_, handle_height_);
    v_ = handle ? Steer(*handle, lateral_, speed_, gain_) : Law(f_[0], speed_, gain_, focal_, centre_u_);
  } else if (to_seconds(now() - last_seen_) > lost_) {
    vel_.write(Vec9::Zero().eval());
    return Abort("lost sight of the handle for more than " + text(kLost) + " s");
  }
  vel_.write(v_);
}

DCA_REGISTER_CONTROLLER(VisualServoing);

}  // namespace dca::door
