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
  if (!named(m.type).empty()) throw std::invalid_argument("controller type '" + m.type + "' registered twice");
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

std::vector<const Registry::Entry*> Registry::named(std::string_view type) const {
  std::vector<const Entry*> hits;
  const auto dot = type.rfind('.');
  const std::string_view package = dot == std::string_view::npos ? std::string_view() : type.substr(0, dot);
  const std::string_view bare = dot == std::string_view::npos ? type : type.substr(dot + 1);
  for (const auto& e : entries_)
    if (e.manifest.type == bare && (dot == std::string_view::npos || e.manifest.package == package))
      hits.push_back(&e);
  return hits;
}

const Manifest* Registry::manifest(std::string_view type) const {
  const auto hits = named(type);
  return hits.size() == 1 ? &hits.front()->manifest : nullptr;
}

std::string Registry::ambiguous(std::string_view type) const {
  const auto hits = named(type);
  if (hits.size() < 2) return "";
  std::string packages, choices;
  for (std::size_t i = 0; i < hits.size(); ++i) {
    const std::string& p = hits[i]->manifest.package;
    packages += (i == 0 ? "" : i + 1 == hits.size() ? " and " : ", ") + p;
    choices += (i == 0 ? "" : " or ") + p + "." + std::string(type);
  }
  return "type '" + std::string(type) + "' is defined by packages " + packages + ": write " + choices;
}

std::vector<const Manifest*> Registry::all() const {
  std::vector<const Manifest*> v;
  for (const auto& e : entries_) v.push_back(&e.manifest);
  std::sort(v.begin(), v.end(), [](const Manifest* a, const Manifest* b) {
    return a->type != b->type ? a->type < b->type : a->package < b->package;
  });
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
  // Two packages may define one name (a system then writes lab.PD); a built-in's name is dca's alone.
  for (const auto& e : staged.entries_)
    for (const Entry* had : named(e.manifest.type))
      if (had->manifest.package.empty() || had->manifest.package == package) {
        *error = "type '" + e.manifest.type + "' is defined by both " +
                 (had->manifest.package.empty() ? std::string("dca (a built-in type)")
                                                : "package '" + had->manifest.package + "'") +
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
  const auto hits = named(type);
  if (hits.size() > 1) throw std::invalid_argument(ambiguous(type));
  if (hits.empty()) throw std::invalid_argument(unknown_type(type));
  ctx.manifest = &hits.front()->manifest;
  return hits.front()->factory(ctx);
}

std::unique_ptr<Controller> Registry::create_or_stand_in(std::string_view type, const ControllerContext& ctx) const {
  const Manifest* m = manifest(type);
  if (!m) throw std::invalid_argument(named(type).empty() ? unknown_type(type) : ambiguous(type));
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
