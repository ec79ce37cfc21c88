#pragma once
// The fusion of the door's velocity commands.
#include <dca/robot/signals.h>

namespace dca::door {

/// AddVelocity(host, period=0.01): Out = In1 + In2 + In3 (Vel signals; an input not refreshed counts zero).
///   in  In1, In2, In3  vector[9] Vel
///   out Out            vector[9] Vel
class AddVelocity final : public PeriodicController {
  DCA_CONTROLLER(AddVelocity)
  void MainCalc() override;

  In<robot::Vec9> in_[3];
  Out<robot::Vec9> out_;
  robot::Vec9 v_[3];
};

}  // namespace dca::door
