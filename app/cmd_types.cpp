// `dca types [TYPE...]`: every controller type with its ports and parameters (the registry's manifests).
#include <cstdio>
#include <string>

#include "controllers/registry.h"
#include "app/subcommand.h"

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

int cmd_types(std::span<char* const> args) {
  const auto& reg = dca::Registry::global();
  if (args.empty()) {
    for (const auto* m : reg.all()) print(*m);
    return 0;
  }
  int rc = 0;
  for (const char* a : args) {
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
               "usage: dca types [TYPE...]\n\n"
               "Lists every registered controller type (or the named ones): its signature as written in a .dca\n"
               "file (the first argument is the host), its parameters, and its input and output ports with\n"
               "type (scalar, vector[N], vectorx, value) and units, and how a run ends by itself (never, done, aborted,\n"
               "done or aborted; `dca check --verify` uses it). Exit code 1 if a named type is unknown.",
               cmd_types);
