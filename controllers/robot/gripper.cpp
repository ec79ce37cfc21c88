#include "controllers/robot/gripper.h"

#include <cmath>

#include <dca/registry.h>

namespace dca::robot {

namespace {
using Vec1 = Eigen::Matrix<double, 1, 1>;
const InSpec<Vec1> kState{.name = "State", .units = "0 open, 1 closed, 2 moving, 3 grasping", .device = "gripper.state"};
const OutSpec<Vec1> kCmd{.name = "Cmd", .units = "0 open, 1 close", .device = "gripper.cmd"};
const Param<std::string> kAction{.name = "action", .doc = "open or close", .allowed = {"open", "close"}};
const Param<double> kTimeout{.name = "timeout", .doc = "ABORTED when not done after this many seconds", .def = 3,
                             .above = 0};
}  // namespace

Manifest GripperControl::Describe() {
  return {.type = "GripperControl", .doc = "opens or closes the gripper; DONE when open, or holding something",
          .inputs = {kState}, .outputs = {kCmd}, .params = {kAction, kTimeout, PeriodParam()},
          .ends = Ending::DoneOrAborted()};
}
GripperControl::GripperControl(const ControllerContext& ctx)
    : PeriodicController(ctx), state_in_(port(kState)), cmd_(port(kCmd)), timeout_(param(kTimeout)),
      close_(param(kAction) == "close") {
  cmd_value_[0] = close_ ? 1.0 : 0.0;
}
void GripperControl::on_start(const msgpack::object&) {
  seen_moving_ = false;
  cmd_.write(cmd_value_);
}
void GripperControl::MainCalc() {
  cmd_.write(cmd_value_);
  if (state_in_.read(state_) == Read::New) {
    const int s = static_cast<int>(std::lround(state_[0]));
    if (s == 2) seen_moving_ = true;
    if (!close_ && s == 0) return Done(std::string_view("open"));
    if (close_ && s == 3) return Done(std::string_view("grasping"));
    if (close_ && s == 1) return Abort("the gripper closed on nothing: no handle between the fingers");
  }
  if (to_seconds(now() - started()) > timeout_)
    Abort(std::string("the gripper did not ") + (close_ ? "close" : "open") + " within " + text(kTimeout) + " s");
}

DCA_REGISTER_CONTROLLER(GripperControl);

}  // namespace dca::robot
