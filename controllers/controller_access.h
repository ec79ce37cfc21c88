#pragma once
// What dca's own code may do to a controller beyond its public operations (dca/controller.h befriends this):
// never part of the SDK.
#include <string>
#include <utility>

#include <dca/controller.h>

namespace dca {

/// A parameter's range as its check says it: "positive", "at least 0", "in [0, 1]", "in (0, 1]", "at most 5",
/// "above 2"; "" when it has none (controllers/controller.cpp; dca check quotes it through core.types()).
std::string range_text(const ParamSpec& p);

struct ControllerAccess {
  /// One MainCalc, outside the timer (benchmarks and tests).
  static void main_calc(Controller& c) { c.MainCalc(); }
  /// Makes configure() and start() fail with "<Type> <name>: <why>" (the registry's stand-in).
  static void set_broken(Controller& c, std::string why) { c.broken_ = std::move(why); }
};

}  // namespace dca
