// The generic URDF worlds as a world plug-in (sim/world_plugin.h; docs/robots.md): `--world ROBOT.urdf` (Simbody)
// and `--world mock:ROBOT.urdf[?lag=S&dead=J,...]` (mock hardware), their options in the spec; and
// `dca types --world WORLD`: the ports any world would have.
#include <cstdio>
#include <stdexcept>

#include "app/world_ports.h"
#include "host/port.h"
#include "sim/device_node.h"
#include "sim/urdf/joint_world.h"
#include "sim/world_plugin.h"

namespace dca::app {
namespace {

std::unique_ptr<sim::DeviceWorld> make(const sim::WorldSetup& setup) {
  return sim::make_robot_world(setup.spec, setup.period);
}

// The ports from the URDF (loaded, not simulated; a mock's options checked by building it: cheap, no physics).
void signals(const sim::WorldSetup& setup, std::vector<sim::DeviceSignal>* sensors,
             std::vector<sim::DeviceSignal>* commands) {
  sim::RobotWorldSpec s;
  std::string error;
  if (!sim::parse_world_spec(setup.spec, &s, &error)) throw std::invalid_argument(error);
  sim::RobotDescription d = sim::load_description(s.file);  // its errors name FILE:LINE:COL
  *sensors = sim::joint_sensor_signals(d);
  *commands = sim::joint_command_signals(d);
  try {
    if (s.mock) sim::make_mock_world(std::move(d), 1e-3, s.lag, s.dead);
  } catch (const std::exception& e) {
    throw std::invalid_argument("world '" + setup.spec + "': " + e.what());
  }
}

std::vector<std::string> about(const sim::WorldSetup& setup) {
  sim::RobotWorldSpec s;
  std::string error;
  if (!sim::parse_world_spec(setup.spec, &s, &error)) throw std::invalid_argument(error);
  const sim::RobotDescription d = sim::load_description(s.file);
  std::vector<std::string> out{"robot '" + d.name + "', " + std::to_string(d.joints.size()) + " moving joints" +
                               (d.declared ? "" : " (no <ros2_control> joints: the default effort command on every joint)")};
  for (const auto& w : d.warnings) out.push_back("warning: " + w);
  return out;
}

sim::WorldPlugin plugin() {
  sim::WorldPlugin p;
  p.summary = "the generic URDF world (docs/robots.md): Simbody, or mock hardware with mock:";
  p.accepts = [](const std::string& spec) { return sim::is_robot_world(spec); };
  p.make = make;
  p.signals = signals;
  p.about = about;
  return p;
}

const sim::WorldRegistration kUrdf{plugin()};

// `dca types --world WORLD`: the ports world WORLD serves (as `dca types` prints a controller's): the exit code.
int print_world_ports(const std::string& spec) {
  try {
    sim::WorldSetup setup;
    setup.spec = spec;
    const sim::WorldPlugin* p = sim::find_world(spec);
    if (p == nullptr) throw std::invalid_argument("no world '" + spec + "' (`dca sim --worlds` lists them)");
    std::vector<sim::DeviceSignal> sensors, commands;
    p->signals(setup, &sensors, &commands);
    const std::vector<std::string> lines = p->about ? p->about(setup) : std::vector<std::string>{p->summary};
    std::printf("world %s: %s\n", spec.c_str(), lines.empty() ? "" : lines[0].c_str());
    for (const auto& x : commands) std::printf("    in     %-40s vector[%u] %s\n", x.name.c_str(), x.size, x.units.c_str());
    std::printf("    in     %-40s vector[1] (above 0.5: the emergency stop)\n", sim::kEstopInput);
    for (const auto& x : sensors) std::printf("    out    %-40s vector[%u] %s\n", x.name.c_str(), x.size, x.units.c_str());
    for (std::size_t i = 1; i < lines.size(); ++i) std::printf("    %s\n", lines[i].c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dca types: %s\n", e.what());
    return 1;
  }
}

}  // namespace

int types_of_world(const std::string& spec) { return print_world_ports(spec); }

}  // namespace dca::app
