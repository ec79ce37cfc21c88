#include "door/add_velocity.h"

#include <dca/registry.h>

namespace dca::door {

namespace {
const InSpec<robot::Vec9> kIn1 = robot::VelIn("In1"), kIn2 = robot::VelIn("In2"), kIn3 = robot::VelIn("In3");
const OutSpec<robot::Vec9> kOut = robot::VelOut("Out");
}  // namespace

Manifest AddVelocity::Describe() {
  return {.type = "AddVelocity", .doc = "fuses three velocity commands: Out = In1 + In2 + In3",
          .inputs = {kIn1, kIn2, kIn3}, .outputs = {kOut}, .params = {PeriodParam()}, .ends = Ending::Never()};
}
AddVelocity::AddVelocity(const ControllerContext& ctx)
    : PeriodicController(ctx), in_{port(kIn1), port(kIn2), port(kIn3)}, out_(port(kOut)) {}
void AddVelocity::MainCalc() {
  robot::Vec9 sum = robot::Vec9::Zero();
  for (int i = 0; i < 3; ++i) {
    if (in_[i].read(v_[i]) != Read::New) v_[i].setZero();
    sum += v_[i];
  }
  out_.write(sum);
}

DCA_REGISTER_CONTROLLER(AddVelocity);

}  // namespace dca::door
