#include "app/sim_robot.h"

#include <chrono>
#include <cstdio>

#include "app/node_run.h"
#include "host/loop.h"
#include "host/node.h"
#include "sim/device_node.h"
#include "sim/urdf/joint_world.h"

namespace dca::app {
namespace {

void print_lines(const char* prefix, const std::vector<std::string>& lines) {
  for (const auto& l : lines) std::printf("%s%s\n", prefix, l.c_str());
}

int serve(const RobotSimOptions& o, sim::JointWorld& world) {
  Loop loop;
  sim::DeviceNodeOptions dno;
  dno.sync_period = o.sync_period;
  dno.tick_timeout_ms = o.tick_timeout_ms;
  dno.realtime = o.realtime;
  dno.duration = o.duration;
  dno.trace = o.trace;
  dno.record = o.record, dno.record_period = o.record_period;
  sim::DeviceNode dn(loop, world, dno);
  NodeOptions no;
  no.name = o.name;
  no.daemon = o.daemon;
  no.key_file = o.key;
  no.host = o.host;
  auto node = dn.make_node(no);
  const auto wall0 = std::chrono::steady_clock::now();
  bool ready = false;
  std::string failure;
  run_node(loop, *node, [&] {
    std::printf("dca sim: world ready (%s): %s, period %g s\n", o.name.c_str(), world.describe().c_str(), world.period());
    print_lines("dca sim: warning: ", world.warnings());
    std::fflush(stdout);
    if (o.go) dn.go();
  }, &ready, &failure);
  node->shutdown(failure.empty() ? "world exiting" : "start-up failed");
  if (!failure.empty()) {
    std::fprintf(stderr, "dca sim: %s\n", failure.c_str());
    return 1;
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  print_lines("dca sim: ", world.summary());
  std::printf("dca sim: simulated %.3f s in %.3f s wall\n", to_seconds(dn.now()), wall);
  return node->exit_code();
}

std::vector<PortSpec> as_ports(const std::vector<sim::DeviceSignal>& signals) {
  std::vector<PortSpec> out;
  out.reserve(signals.size());
  for (const auto& x : signals) out.push_back(vector_port(x.name, x.size, x.units));
  return out;
}

int run_here(const RobotSimOptions& o, sim::JointWorld& world) {
  const double end = o.duration > 0 ? o.duration : 1.0;
  std::printf("dca sim: %s, period %g s, no commands\n", world.describe().c_str(), world.period());
  print_lines("dca sim: warning: ", world.warnings());
  const auto wall0 = std::chrono::steady_clock::now();
  while (world.time() < end - 1e-9) world.step();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  for (std::size_t j = 0; j < world.state().size(); ++j)
    std::printf("joint %s: position %.6f, velocity %.6f, effort %.3f\n", world.description().joints[j].name.c_str(),
                world.state()[j].position, world.state()[j].velocity, world.state()[j].effort);
  print_lines("", world.summary());
  std::printf("simulated %.3f s in %.3f s wall, %ld steps\n", world.time(), wall, world.ticks());
  return 0;
}

}  // namespace

bool is_robot_world(const std::string& spec) { return sim::is_robot_world(spec); }

int sim_robot(const RobotSimOptions& o) {
  if (o.serve && o.daemon.empty()) {
    std::fprintf(stderr, "dca sim: --serve needs --daemon ADDR\n");
    return 2;
  }
  if (!o.serve && !o.record.empty()) {
    std::fprintf(stderr, "dca sim: --record with a URDF world goes with --serve (dca run --sim ROBOT.urdf --record)\n");
    return 2;
  }
  try {
    auto world = sim::make_robot_world(o.world, o.period);
    return o.serve ? serve(o, *world) : run_here(o, *world);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dca sim: %s\n", e.what());
    return 1;
  }
}

bool robot_world_signals(const std::string& spec, std::vector<PortSpec>* outputs, std::vector<PortSpec>* inputs,
                         std::string* error) {
  std::string where;  // "" for the URDF's errors, which name FILE:LINE:COL
  try {
    sim::RobotWorldSpec s;
    if (!sim::parse_world_spec(spec, &s, error)) return false;
    sim::RobotDescription d = sim::load_description(s.file);
    *outputs = as_ports(sim::joint_sensor_signals(d));
    *inputs = as_ports(sim::joint_command_signals(d));
    // the mock's options (dead=J,...) are checked by building it: cheap, no physics
    where = "world '" + spec + "': ";
    if (s.mock) sim::make_mock_world(std::move(d), 1e-3, s.lag, s.dead);
    return true;
  } catch (const std::exception& e) {
    *error = where + e.what();
    return false;
  }
}

int print_world_ports(const std::string& spec) {
  try {
    sim::RobotWorldSpec s;
    std::string error;
    if (!sim::parse_world_spec(spec, &s, &error)) throw std::invalid_argument(error);
    const sim::RobotDescription d = sim::load_description(s.file);
    std::printf("world %s: robot '%s', %zu moving joints%s\n", spec.c_str(), d.name.c_str(), d.joints.size(),
                d.declared ? "" : " (no <ros2_control> joints: the default effort command on every joint)");
    for (const auto& p : sim::joint_command_signals(d))
      std::printf("    in     %-40s vector[%u] %s\n", p.name.c_str(), p.size, p.units.c_str());
    for (const auto& p : sim::joint_sensor_signals(d))
      std::printf("    out    %-40s vector[%u] %s\n", p.name.c_str(), p.size, p.units.c_str());
    print_lines("    warning: ", d.warnings);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dca types: %s\n", e.what());
    return 1;
  }
}

}  // namespace dca::app
