#include <dca/registry.h>

#include "controllers/controller_access.h"

#include <algorithm>
#include <set>
#include <stdexcept>

namespace dca {

namespace {

// What a node hosts in place of a controller whose constructor threw (Registry::create_or_stand_in).
class StandIn final : public Controller {
 public:
  StandIn(const ControllerContext& ctx, const std::string& why) : Controller(ctx) {
    ControllerAccess::set_broken(*this, "its constructor failed: " + why);
  }
};

}  // namespace

Registry& Registry::global() {
  static Registry r;
  return r;
}

void Registry::add(Manifest m, Factory f) {
  if (manifest(m.type)) throw std::invalid_argument("controller type '" + m.type + "' registered twice");
  for (const auto* ports : {&m.inputs, &m.outputs}) {
    std::set<std::string> seen;
    for (const auto& p : *ports)
      if (!seen.insert(p.name).second)
        throw std::invalid_argument("controller type '" + m.type + "' declares port '" + p.name + "' twice");
  }
  for (std::size_t i = 0; i + 1 < m.params.size(); ++i)
    if (m.params[i].variadic)
      throw std::invalid_argument("controller type '" + m.type + "': only the last parameter may be variadic");
  entries_.push_back({std::move(m), std::move(f)});
}

const Manifest* Registry::manifest(std::string_view type) const {
  for (const auto& e : entries_)
    if (e.manifest.type == type) return &e.manifest;
  return nullptr;
}

std::vector<const Manifest*> Registry::all() const {
  std::vector<const Manifest*> v;
  for (const auto& e : entries_) v.push_back(&e.manifest);
  std::sort(v.begin(), v.end(), [](const Manifest* a, const Manifest* b) { return a->type < b->type; });
  return v;
}

std::string Registry::unknown_type(std::string_view type) const {
  std::string m = "unknown controller type '" + std::string(type) + "'; types are: ";
  bool first = true;
  for (const auto* e : all()) {
    m += (first ? "" : ", ") + e->type;
    first = false;
  }
  return m;
}

bool Registry::adopt(Registry&& staged, const std::string& package, std::string* error) {
  for (const auto& e : staged.entries_)
    if (const Manifest* had = manifest(e.manifest.type)) {
      *error = "type '" + e.manifest.type + "' is defined by both " +
               (had->package.empty() ? std::string("dca (a built-in type)") : "package '" + had->package + "'") +
               " and package '" + package + "'";
      return false;
    }
  for (auto& e : staged.entries_) {
    e.manifest.package = package;
    entries_.push_back(std::move(e));
  }
  staged.entries_.clear();
  return true;
}

std::unique_ptr<Controller> Registry::create(std::string_view type, ControllerContext ctx) const {
  for (const auto& e : entries_)
    if (e.manifest.type == type) {
      ctx.manifest = &e.manifest;
      return e.factory(ctx);
    }
  throw std::invalid_argument(unknown_type(type));
}

std::unique_ptr<Controller> Registry::create_or_stand_in(std::string_view type, const ControllerContext& ctx) const {
  const Manifest* m = manifest(type);
  if (!m) throw std::invalid_argument(unknown_type(type));
  try {
    return create(type, ctx);
  } catch (const std::invalid_argument&) {
    throw;  // a bad parameter (the documented constructor error): the node's start fails, naming it
  } catch (const std::exception& e) {
    ControllerContext c = ctx;
    c.manifest = m;
    // its parameters passed the base's checks (else std::invalid_argument, above)
    return std::make_unique<StandIn>(c, e.what());
  }
}

}  // namespace dca
