#pragma once
// World plug-ins (docs/worlds.md): what `dca sim`, `dca check` and `dca types` know of a world. A world registers
// itself once (a static WorldRegistration in its own folder, worlds/NAME/), naming its options and how it is
// built; the world process serves whatever DeviceWorld it builds (sim/device_node.h). Nothing outside a world's
// folder knows a world by name: the run machinery passes `--world-opt KEY=VALUE` through, and the world checks
// them here. C++17-clean.
//
// A world is chosen by its spec: a registered name (e.g. the door world's) or a spec a plug-in accepts (the URDF
// worlds: ROBOT.urdf, mock:ROBOT.urdf?...). Options are declared with a kind (number with a range, integer, flag,
// text) and a help line; values arrive as text and are checked before anything is built.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "sim/device_world.h"

namespace dca::sim {

/// One option of a world: `--world-opt NAME=VALUE` (a flag: `--world-opt NAME`, or NAME=true|false).
struct WorldOption {
  enum class Kind { number, integer, flag, text };
  std::string name;
  Kind kind = Kind::number;
  std::string help;
  double min = 0, max = 0;  ///< number, integer: the closed range when min < max
};

/// Checked option values, by name (flags "true" / "false"; numbers as given).
class WorldOptionValues {
 public:
  bool has(const std::string& name) const { return values_.count(name) != 0; }
  double number(const std::string& name, double fallback) const;
  bool flag(const std::string& name) const;
  std::string text(const std::string& name, const std::string& fallback = "") const;
  void set(const std::string& name, const std::string& value) { values_[name] = value; }
  const std::map<std::string, std::string>& all() const { return values_; }

 private:
  std::map<std::string, std::string> values_;
};

/// What building a world takes.
struct WorldSetup {
  std::string spec;              ///< as given to --world
  std::uint64_t seed = 0;        ///< --seed (a world without randomness ignores it)
  double period = 1e-3;          ///< s, the step
  WorldOptionValues options;     ///< checked against the plug-in's options
};

/// `dca sim --world SPEC` without --serve: the world stepped in this process.
struct LocalRun {
  double duration = -1;          ///< s (-1: the world's own default)
  bool realtime = false;
  std::string record;            ///< a file to record to ("" none)
  double record_period = 0.01;
  RecordOptions recording;       ///< an MCAP recording's compression and split
};

/// A world plug-in.
struct WorldPlugin {
  std::string name;              ///< the spec that names it ("" for a plug-in that accepts specs)
  std::string summary;           ///< one line for `dca sim --help`
  std::vector<WorldOption> options;
  /// Whether this plug-in takes `spec` (a plug-in without a name; e.g. files ending in .urdf).
  std::function<bool(const std::string& spec)> accepts;
  /// Builds the world. Throws std::invalid_argument (a bad spec or option) or another std::exception (e.g. the
  /// model's file:line error).
  std::function<std::unique_ptr<DeviceWorld>(const WorldSetup&)> make;
  /// The world's signals without simulating it (outputs, inputs), for `dca check` and `dca types`; throws as make.
  std::function<void(const WorldSetup&, std::vector<DeviceSignal>* sensors, std::vector<DeviceSignal>* commands)>
      signals;
  /// Runs the world here (no --serve): the exit code. Unset: the world is stepped with no commands.
  std::function<int(const WorldSetup&, const LocalRun&)> run_local;
  /// Lines about the world as loaded, for `dca types --world` (e.g. the robot's name and its loading warnings,
  /// each "warning: ..."). Optional; throws as make.
  std::function<std::vector<std::string>(const WorldSetup&)> about;
};

/// Registers a plug-in (at static initialisation: `static const WorldRegistration r{plugin};`).
struct WorldRegistration {
  explicit WorldRegistration(WorldPlugin plugin);
};

/// The plug-in for `spec`, or nullptr.
const WorldPlugin* find_world(const std::string& spec);
/// The names of the registered worlds (sorted), and the plug-ins themselves.
std::vector<const WorldPlugin*> worlds();
/// The world used where none is named (`dca sim`, `dca check` without --sim): $DCA_WORLD when set, else the
/// first registered world that has a name in sorted order; "" when none is.
std::string default_world();

/// Checks `key=value` option texts for `plugin`: false with *error naming the option and what it takes.
bool parse_world_options(const WorldPlugin& plugin, const std::vector<std::string>& texts, WorldOptionValues* out,
                         std::string* error);
/// The option lines of `plugin` for a usage text ("  door_width=NUMBER   the door's width (0.5-1.5)").
std::string world_options_help(const WorldPlugin& plugin);

/// Builds the world `setup.spec` names (its plug-in found, the options already checked): throws
/// std::invalid_argument for an unknown world.
std::unique_ptr<DeviceWorld> make_world(const WorldSetup& setup);

}  // namespace dca::sim
