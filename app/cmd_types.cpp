// `dca types [--package NAME]... [--dir DIR] [TYPE...]`: every controller type with its ports and parameters (the
// registry's manifests): the built-ins and the controller packages on the search path, or the named packages.
#include <cstdio>
#include <string>
#include <vector>

#include "controllers/packages.h"
#include <dca/registry.h>
#include "app/subcommand.h"
#include "app/world_ports.h"
#include "host/paths.h"

namespace dca::cli::cmd_types {
namespace {

// "scalar", "vector[3]", "vectorx", "value", or a message port's ROS 2 type ("geometry_msgs/msg/Twist").
std::string port_type(const dca::PortSpec& p) {
  if (p.type == dca::PortType::Message) return p.message;
  std::string t(dca::to_string(p.type));
  if (p.type == dca::PortType::Vector) {
    t.push_back('[');
    t.append(std::to_string(p.size));
    t.push_back(']');
  }
  return t;
}

// "  (> 0)", "  (in [0, 1])", "  (one of: open, close)", or ""; then "  (live)" for a live parameter.
std::string range(const dca::ParamSpec& p) {
  std::string r;
  const auto n = [](double v) { return dca::format_number(v); };
  if (p.above) r += "> " + n(*p.above);
  if (p.min) r += (r.empty() ? ">= " : ", >= ") + n(*p.min);
  if (p.max) r += (r.empty() ? "<= " : ", <= ") + n(*p.max);
  for (std::size_t i = 0; i < p.allowed.size(); ++i) r += (i == 0 ? "one of: " : ", ") + p.allowed[i];
  return (r.empty() ? r : "  (" + r + ")") + (p.live ? "  (live)" : "");
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
  if (!m.ends.never_when.empty()) ends += " (never when " + m.ends.never_when + " is " + m.ends.never_value + ")";
  std::printf("    ends   %s\n", ends.c_str());
  for (const auto& p : m.params)
    std::printf("    param  %-10s %-8s %s%s\n", p.name.c_str(), p.type.c_str(), p.doc.c_str(), range(p).c_str());
  for (const auto& p : m.inputs)
    std::printf("    in     %-10s %-8s %s%s%s\n", p.name.c_str(), port_type(p).c_str(), p.units.c_str(),
                p.device.empty() ? "" : "  <- device ", p.device.c_str());
  for (const auto& p : m.outputs)
    std::printf("    out    %-10s %-8s %s%s%s\n", p.name.c_str(), port_type(p).c_str(), p.units.c_str(),
                p.device.empty() ? "" : "  -> device ", p.device.c_str());
}

// Loads `names` (every package on the search path when empty and `all`); says what failed unless `quiet`, which
// collects the failures in *failed instead. --> false on a failure
bool load(std::vector<std::string> names, const std::string& dir, bool all, std::string* failed = nullptr) {
  const auto dirs = dca::controller_dirs(dir);
  if (names.empty() && all) names = dca::available_packages(dirs);
  bool ok = true;
  for (const auto& n : names) {
    std::string error;
    if (dca::load_package(n, dirs, &error)) continue;
    if (failed) failed->append("\n  ").append(error);
    else std::fprintf(stderr, "dca types: %s\n", error.c_str());
    ok = false;
  }
  return ok;
}

// `dca types NAME...`: each named type, searched among the built-ins and every package on the search path (or the
// named packages); a package that does not load matters only when a type is not found.
int print_named(const std::vector<std::string>& types, const std::vector<std::string>& packages,
                const std::string& dir) {
  std::string failed;
  int rc = load(packages, dir, packages.empty(), packages.empty() ? &failed : nullptr) || packages.empty() ? 0 : 1;
  const auto& reg = dca::Registry::global();
  for (const auto& a : types) {
    bool found = false;  // every type of that name (several packages may define it), or the one of package.name
    for (const auto* m : reg.all())
      if (m->type == a || (!m->package.empty() && m->package + "." + m->type == a)) {
        print(*m);
        found = true;
      }
    if (found) continue;
    std::fprintf(stderr, "dca types: %s%s%s\n", reg.unknown_type(a).c_str(),
                 failed.empty() ? "" : "\npackages on the search path that did not load:", failed.c_str());
    rc = 1;
  }
  return rc;
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
    if (a == "--world") return dca::app::types_of_world(args[i + 1]);  // a world's ports
    if (a == "--package") packages.emplace_back(args[++i]);
    else if (a == "--dir") dir = args[++i];
    else types.push_back(a);
  }
  if (!types.empty()) return print_named(types, packages, dir);
  const int rc = load(packages, dir, true) ? 0 : 1;
  for (const auto* m : dca::Registry::global().all()) {
    bool listed = packages.empty();
    for (const auto& p : packages) listed = listed || m->package == p;
    if (listed) print(*m);
  }
  return rc;
}

}  // namespace

DCA_SUBCOMMAND("types", "every controller type with its ports and parameters",
               "usage: dca types [--package NAME]... [--dir DIR] [TYPE...]\n"
               "       dca types --world WORLD\n\n"
               "Lists every controller type (or the named ones): its signature as written in a .dca file (the\n"
               "first argument is the host), its package unless built in, its parameters with their ranges, its\n"
               "input and output ports with type (scalar, vector[N], vectorx, value) and units, and how a run ends\n"
               "by itself (never, done, aborted, done or aborted; `dca check --verify` uses it). The types are the\n"
               "built-in ones and those of every controller package on the search path ($DCA_CONTROLLER_PATH,\n"
               "<prefix>/lib/dca/controllers, DIR/packages with --dir DIR); with --package, that package's only.\n"
               "A named TYPE is searched in all of them. Exit code 1 if a named type is unknown (naming the\n"
               "packages that did not load) or, listing, a package does not load (each said on stderr).\n"
               "--world: the device ports of a world (`dca sim --worlds`; ROBOT.urdf, mock:ROBOT.urdf: docs/robots.md):\n"
               "its command inputs and state outputs (a URDF world's, its joints' interfaces) and the warnings of\n"
               "loading it; exit code 1 if it does not load.",
               cmd_types);

}  // namespace dca::cli::cmd_types
