#include "controllers/door/add_velocity.h"

#include "controllers/registry.h"

namespace dca::door {

Manifest AddVelocity::Describe() {
  return {"AddVelocity", "fuses three velocity commands: Out = In1 + In2 + In3",
          {robot::VelPort("In1"), robot::VelPort("In2"), robot::VelPort("In3")},
          {robot::VelPort("Out")},
          {PeriodParam()},
          Ending::Never()};
}
AddVelocity::AddVelocity(const ControllerContext& ctx)
    : PeriodicController(ctx), in_{&input("In1"), &input("In2"), &input("In3")}, out_(output("Out")) {}
void AddVelocity::MainCalc() {
  robot::Vec9 sum = robot::Vec9::Zero();
  for (int i = 0; i < 3; ++i) {
    if (!fresh(*in_[i], v_[i])) v_[i].setZero();
    sum += v_[i];
  }
  out_.write(sum);
}

DCA_REGISTER_CONTROLLER(AddVelocity);

}  // namespace dca::door
