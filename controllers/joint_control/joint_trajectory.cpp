#include "joint_trajectory.h"

#include <cmath>
#include <cstdio>

#include <dca/registry.h>

namespace dca::joint_control {

namespace {
// At most this many waypoints (the plan's room is made at construction: MainCalc does not allocate for it).
constexpr std::size_t kMaxWaypoints = 64;

const InSpec<Eigen::VectorXd> kWaypoints{.name = "Waypoints", .units = "s, then rad or m per joint, per waypoint"};
const OutSpec<Eigen::VectorXd> kSetpoint{.name = "Setpoint", .units = "rad or m"};
const OutSpec<double> kReached{.name = "Reached", .units = "waypoints"};
const Param<double> kTolerance{.name = "tolerance",
                               .doc = "a waypoint is reached within this of it, slower than it per second",
                               .def = 0.01, .above = 0};
const Param<std::string> kTrajectoryInterface{
    .name = "interface", .doc = "the command interface", .def = "position", .allowed = {"position", "velocity"}};
const Param<double> kGain{.name = "gain", .doc = "velocity interface: gain on the position error (1/s)", .def = 2,
                          .min = 0};
const Param<double> kTimeout{.name = "timeout", .doc = "ABORTED when not at the last waypoint after this many s",
                             .def = 60, .above = 0};
const Param<std::vector<double>> kPlan{.name = "waypoints",
                                       .doc = "per waypoint: its time (s from the start), then a position per joint"};

// Minimum jerk from 0 to 1 over x in [0, 1]: the position and its derivative in x.
double smooth(double x) { return x * x * x * (10 + x * (-15 + 6 * x)); }
double smooth_rate(double x) { return 30 * x * x * (1 - x) * (1 - x); }

// A measured position for a message: four decimals.
std::string fixed4(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4f", v);
  return b;
}
}  // namespace

Manifest JointTrajectory::Describe() {
  Manifest m{.type = "JointTrajectory",
             .doc = "moves any arm's joints through timed waypoints; DONE(seconds) at the last, within tolerance",
             .params = {joints_param(), kTolerance, kTrajectoryInterface, kGain, kTimeout, PeriodParam(), kPlan},
             .ends = Ending::DoneOrAborted()};
  const Slots& s = slots(false);
  append(m.inputs, s.q);
  append(m.inputs, s.qd);
  m.inputs.push_back(kWaypoints);
  append(m.outputs, s.cmd);
  m.outputs.push_back(kSetpoint);
  m.outputs.push_back(kReached);
  return m;
}

JointTrajectory::JointTrajectory(const ControllerContext& ctx)
    : JointGroup(ctx, slots(false)), waypoints_in_(port(kWaypoints)), setpoint_out_(port(kSetpoint)),
      reached_out_(port(kReached)), tolerance_(param(kTolerance)), gain_(param(kGain)), timeout_(param(kTimeout)),
      velocity_(param(kTrajectoryInterface) == "velocity") {
  const std::vector<double> plan = param(kPlan);
  if (const std::string why = check(plan.data(), plan.size()); !why.empty())
    throw bad_param("parameter 'waypoints': " + why);
  given_ = plan;
  plan_.reserve(kMaxWaypoints * static_cast<std::size_t>(size() + 1));
  for (Eigen::VectorXd* v : {&from_, &setpoint_, &velocity_ref_, &cmd_}) *v = Eigen::VectorXd::Zero(size());
}

std::string JointTrajectory::check(const double* v, std::size_t n) const {
  const auto width = static_cast<std::size_t>(size() + 1);
  if (n % width != 0)
    return std::to_string(n) + " numbers are no whole waypoints of " + std::to_string(width) +
           " (a time, then a position for each of the " + std::to_string(size()) + " joints)";
  if (n / width > kMaxWaypoints) return "at most " + std::to_string(kMaxWaypoints) + " waypoints";
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return "number " + std::to_string(i + 1) + " is not finite";
  double before = 0;
  for (std::size_t k = 0; k < n / width; ++k) {
    const double t = v[k * width];
    if (t < before || (k > 0 && t == before))
      return "waypoint " + std::to_string(k + 1) + "'s time " + format_number(t) +
             (k == 0 ? " is negative" : " is not after the one before (" + format_number(before) + ")");
    before = t;
  }
  return "";
}

void JointTrajectory::load(const double* v, std::size_t n) {
  plan_.assign(v, v + n);
  count_ = n / static_cast<std::size_t>(size() + 1);
  next_ = 0;
  near_ = 0;
  from_ = setpoint_;
  segment_start_ = now();
  reached_out_.write(0);
}

void JointTrajectory::on_configure() {
  reset_state();
  holding_ = false;
  plan_.assign(given_.begin(), given_.end());  // each run follows the parameters' plan (none: waits for one)
  count_ = plan_.size() / static_cast<std::size_t>(size() + 1);
  next_ = 0;
  near_ = 0;
}

bool JointTrajectory::interpolate() {
  const auto width = static_cast<std::size_t>(size() + 1);
  const double t0 = next_ == 0 ? 0 : plan_[(next_ - 1) * width], t1 = plan_[next_ * width];
  const double span = t1 - t0, x = span > 0 ? to_seconds(now() - segment_start_) / span : 1;
  const Eigen::Map<const Eigen::VectorXd> to(&plan_[next_ * width + 1], size());
  if (x >= 1) {
    setpoint_ = to;
    velocity_ref_.setZero();
    return true;
  }
  setpoint_ = from_ + (to - from_) * smooth(x);
  velocity_ref_ = (to - from_) * (smooth_rate(x) / span);
  return false;
}

bool JointTrajectory::arrived() {
  const auto width = static_cast<std::size_t>(size() + 1);
  const Eigen::Map<const Eigen::VectorXd> to(&plan_[next_ * width + 1], size());
  const bool near = (q_ - to).cwiseAbs().maxCoeff() <= tolerance_ && qd_.cwiseAbs().maxCoeff() <= tolerance_;
  near_ = near ? near_ + 1 : 0;
  return near_ >= 2;
}

std::string JointTrajectory::late() const {
  if (next_ >= count_) return "no waypoints came within " + text(kTimeout) + " s";
  const auto width = static_cast<std::size_t>(size() + 1);
  const Eigen::Map<const Eigen::VectorXd> to(&plan_[next_ * width + 1], size());
  Eigen::Index worst = 0;
  (q_ - to).cwiseAbs().maxCoeff(&worst);
  return "waypoint " + std::to_string(next_ + 1) + " of " + std::to_string(count_) + " not reached within " +
         text(kTimeout) + " s: joint " + joints()[static_cast<std::size_t>(worst)] + " at " + fixed4(q_(worst)) +
         ", wanted " + format_number(to(worst)) + " (tolerance " + text(kTolerance) + ")";
}

void JointTrajectory::MainCalc() {
  if (!read_state()) {  // (a trajectory that came meanwhile stays new until read)
    if (to_seconds(now() - started()) > timeout_)
      Abort("no position of joint " + silent() + " within " + text(kTimeout) + " s: is the world serving it?");
    return;
  }
  if (!holding_) {  // the first tick with every joint's position: the setpoint starts there
    holding_ = true;
    setpoint_ = q_;
    from_ = q_;
    segment_start_ = now();
    reached_out_.write(0);
  }
  if (waypoints_in_.read(input_) == Read::New) {
    if (const std::string why = check(input_.data(), static_cast<std::size_t>(input_.size())); !why.empty())
      return Abort("input Waypoints: " + why);
    load(input_.data(), static_cast<std::size_t>(input_.size()));
  }
  velocity_ref_.setZero();
  if (next_ < count_ && interpolate() && arrived()) {
    reached_out_.write(static_cast<double>(++next_));
    from_ = setpoint_;
    segment_start_ = now();
    near_ = 0;
  }
  if (velocity_) cmd_ = velocity_ref_ + gain_ * (setpoint_ - q_);
  else cmd_ = setpoint_;
  command(cmd_);
  setpoint_out_.write(setpoint_);
  if (count_ > 0 && next_ == count_) return Done(to_seconds(now() - started()));
  if (to_seconds(now() - started()) > timeout_) Abort(late());
}

void JointTrajectory::on_halt() {
  if (!velocity_) return;
  cmd_.setZero();
  command(cmd_);
}

DCA_REGISTER_CONTROLLER(JointTrajectory);

}  // namespace dca::joint_control
