#include "app/subcommand.h"

#include <algorithm>
#include <cstring>

namespace dca::cli {
namespace {
std::vector<Subcommand>& registry() {
  static std::vector<Subcommand> r;  // function-local: safe from static-initialisation order
  return r;
}
}  // namespace

void add(const Subcommand& s) { registry().push_back(s); }

std::vector<Subcommand> all() {
  auto r = registry();
  std::sort(r.begin(), r.end(), [](const Subcommand& a, const Subcommand& b) { return std::strcmp(a.name, b.name) < 0; });
  return r;
}

const Subcommand* find(const std::string& name) {
  for (const auto& s : registry())
    if (name == s.name) return &s;
  return nullptr;
}

}  // namespace dca::cli
