// `dca types [--package NAME]... [--dir DIR] [TYPE...]`: every controller type with its ports and parameters (the
// registry's manifests): the built-ins and the controller packages on the search path, or the named packages.
#include <cstdio>
#include <string>
#include <vector>

#include "controllers/packages.h"
#include <dca/registry.h>
#include "app/sim_robot.h"
#include "app/subcommand.h"
#include "host/paths.h"

namespace {

std::string port_type(const dca::PortSpec& p) {
  std::string t(dca::to_string(p.type));
  if (p.type == dca::PortType::Vector) {
    t.push_back('[');
    t.append(std::to_string(p.size));
    t.push_back(']');
  }
  return t;
}

void print(const dca::Manifest& m) {
  std::string sig = m.type + "(host";
  for (const auto& p : m.params) {
    sig += ", " + p.name;
    if (p.variadic) sig += "...";
    else if (!p.required) sig.append("=").append(p.default_value.empty() ? std::string("\"\"") : p.default_value);
  }
  sig += ")";
  if (!m.package.empty()) sig += "    (package " + m.package + ")";
  std::printf("%s\n    %s\n", sig.c_str(), m.doc.c_str());
  std::string ends(dca::to_string(m.ends.kind));
  if (ends.empty()) ends = "undeclared (taken as: done or aborted)";
  if (!m.ends.after.empty()) ends += ", `" + m.ends.after + "` seconds after each start";
  std::printf("    ends   %s\n", ends.c_str());
  for (const auto& p : m.params)
    std::printf("    param  %-10s %-8s %s\n", p.name.c_str(), p.type.c_str(), p.doc.c_str());
  for (const auto& p : m.inputs)
    std::printf("    in     %-10s %-8s %s%s%s\n", p.name.c_str(), port_type(p).c_str(), p.units.c_str(),
                p.device.empty() ? "" : "  <- device ", p.device.c_str());
  for (const auto& p : m.outputs)
    std::printf("    out    %-10s %-8s %s%s%s\n", p.name.c_str(), port_type(p).c_str(), p.units.c_str(),
                p.device.empty() ? "" : "  -> device ", p.device.c_str());
}

// Loads `names` (every package on the search path when empty and `all`); says what failed. --> false on a failure
bool load(std::vector<std::string> names, const std::string& dir, bool all) {
  const auto dirs = dca::controller_dirs(dir);
  if (names.empty() && all) names = dca::available_packages(dirs);
  bool ok = true;
  for (const auto& n : names) {
    std::string error;
    if (!dca::load_package(n, dirs, &error)) {
      std::fprintf(stderr, "dca types: %s\n", error.c_str());
      ok = false;
    }
  }
  return ok;
}

int cmd_types(std::span<char* const> args) {
  std::vector<std::string> packages, types;
  std::string dir;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string a = args[i];
    if ((a == "--package" || a == "--dir" || a == "--world") && i + 1 >= args.size()) {
      std::fprintf(stderr, "dca types: %s needs a value\n", a.c_str());
      return 2;
    }
    if (a == "--world") return dca::app::print_world_ports(args[i + 1]);  // a robot world's ports
    if (a == "--package") packages.emplace_back(args[++i]);
    else if (a == "--dir") dir = args[++i];
    else types.push_back(a);
  }
  int rc = load(packages, dir, types.empty()) ? 0 : 1;
  const auto& reg = dca::Registry::global();
  if (types.empty()) {
    for (const auto* m : reg.all()) {
      bool listed = packages.empty();
      for (const auto& p : packages) listed = listed || m->package == p;
      if (listed) print(*m);
    }
    return rc;
  }
  for (const auto& a : types) {
    if (const auto* m = reg.manifest(a)) {
      print(*m);
    } else {
      std::fprintf(stderr, "dca types: %s\n", reg.unknown_type(a).c_str());
      rc = 1;
    }
  }
  return rc;
}

}  // namespace

DCA_SUBCOMMAND("types", "every controller type with its ports and parameters",
               "usage: dca types [--package NAME]... [--dir DIR] [TYPE...]\n"
               "       dca types --world ROBOT.urdf|mock:ROBOT.urdf\n\n"
               "Lists every controller type (or the named ones): its signature as written in a .dca file (the\n"
               "first argument is the host), its package unless built in, its parameters, its input and output\n"
               "ports with type (scalar, vector[N], vectorx, value) and units, and how a run ends by itself (never,\n"
               "done, aborted, done or aborted; `dca check --verify` uses it). The types are the built-in ones and\n"
               "those of every controller package on the search path ($DCA_CONTROLLER_PATH,\n"
               "<prefix>/lib/dca/controllers, DIR/packages with --dir DIR); with --package, that package's only.\n"
               "Exit code 1 if a named type is unknown or a package does not load (each said on stderr).\n"
               "--world: the device ports of the URDF world (docs/robots.md): the command inputs and state outputs\n"
               "its joints' interfaces give, and the warnings of loading it; exit code 1 if it does not load.",
               cmd_types);
