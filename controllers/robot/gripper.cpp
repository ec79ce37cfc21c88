#include "controllers/robot/gripper.h"

#include <cmath>

#include "controllers/registry.h"

namespace dca::robot {

Manifest GripperControl::Describe() {
  return {"GripperControl", "opens or closes the gripper; DONE when open, or holding something",
          {device(vector_port("State", 1, "0 open, 1 closed, 2 moving, 3 grasping"), "gripper.state")},
          {device(vector_port("Cmd", 1, "0 open, 1 close"), "gripper.cmd")},
          {ParamSpec::Required("action", "string", "open or close"),
           ParamSpec::Optional("timeout", "number", "3", "ABORTED when not done after this many seconds"),
           PeriodParam()},
          Ending::DoneOrAborted()};
}
GripperControl::GripperControl(const ControllerContext& ctx)
    : PeriodicController(ctx), state_in_(input("State")), cmd_(output("Cmd")), timeout_(positive("timeout")) {
  const std::string a = text("action");
  if (a != "open" && a != "close") throw bad_param("action must be \"open\" or \"close\", got \"" + a + "\"");
  close_ = a == "close";
  cmd_value_[0] = close_ ? 1.0 : 0.0;
}
void GripperControl::Run(const msgpack::object& init) {
  seen_moving_ = false;
  cmd_.write(cmd_value_);
  PeriodicController::Run(init);
}
void GripperControl::MainCalc() {
  cmd_.write(cmd_value_);
  if (state_in_.take_latest() && state_in_.vector().size() == 1) {
    const int s = static_cast<int>(std::lround(state_in_.vector()[0]));
    if (s == 2) seen_moving_ = true;
    if (!close_ && s == 0) return Done(std::string_view("open"));
    if (close_ && s == 3) return Done(std::string_view("grasping"));
    if (close_ && s == 1) return Abort("the gripper closed on nothing: no handle between the fingers");
  }
  if (to_seconds(now() - started()) > timeout_)
    Abort(std::string("the gripper did not ") + (close_ ? "close" : "open") + " within " + text("timeout") + " s");
}

DCA_REGISTER_CONTROLLER(GripperControl);

}  // namespace dca::robot
