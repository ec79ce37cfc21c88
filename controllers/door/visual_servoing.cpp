#include "controllers/door/visual_servoing.h"

#include <cmath>

#include "controllers/registry.h"
#include "controllers/robot/model.h"

namespace dca::door {

Manifest VisualServoing::Describe() {
  using P = ParamSpec;
  return {"VisualServoing", "drives the robot towards the handle, lining the gripper up with it in the image",
          {robot::FeaturePort()}, {robot::VelPort()},
          {P::Number("speed", "0.25", "forward speed, m/s"),
           P::Number("gain", "1.5", "turn rate per radian of bearing error, 1/s"),
           P::Number("hfov", "1.0471975511965976", "the camera's horizontal field of view, rad"),
           P::Number("width", "640", "the image's width, px"),
           P::Number("lost", "0.5", "ABORTED when the handle is not seen for this long, s"),
           P::Number("height", "480", "the image's height, px"),
           P::Number("handle_height", "1", "the handle's height above the floor, m"),
           P::Number("lateral", "-0.075", "the gripper's lateral position in the base frame (left +), m"),
           PeriodParam()},
          Ending::Aborted()};
}
VisualServoing::VisualServoing(const ControllerContext& ctx)
    : PeriodicController(ctx), feature_(input("Feature")), vel_(actuator("Vel")), speed_(number("speed")),
      gain_(number("gain")), lost_(positive("lost")), handle_height_(number("handle_height")),
      lateral_(number("lateral")), camera_(robot::camera()) {
  const double width = positive("width");
  focal_ = (width / 2) / std::tan(positive("hfov") / 2);
  centre_u_ = width / 2;
  centre_v_ = positive("height") / 2;
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
void VisualServoing::Run(const msgpack::object& init) {
  last_seen_ = now();
  v_.setZero();
  PeriodicController::Run(init);
}
void VisualServoing::MainCalc() {
  if (fresh(feature_, f_) && f_[2] > 0.5) {
    last_seen_ = now();
    const auto handle = Locate(f_[0], f_[1], camera_, focal_, centre_u_, centre_v_, handle_height_);
    v_ = handle ? Steer(*handle, lateral_, speed_, gain_) : Law(f_[0], speed_, gain_, focal_, centre_u_);
  } else if (to_seconds(now() - last_seen_) > lost_) {
    vel_.write(Vec9::Zero().eval());
    return Abort("lost sight of the handle for more than " + text("lost") + " s");
  }
  vel_.write(v_);
}

DCA_REGISTER_CONTROLLER(VisualServoing);

}  // namespace dca::door
