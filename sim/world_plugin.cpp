#include "sim/world_plugin.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace dca::sim {
namespace {

std::vector<WorldPlugin>& registry() {
  static std::vector<WorldPlugin> plugins;
  return plugins;
}

// The number `s` is, when all of it is one finite number.
bool as_number(const std::string& s, double* out) {
  if (s.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

const char* kind_word(WorldOption::Kind k) {
  switch (k) {
    case WorldOption::Kind::number: return "NUMBER";
    case WorldOption::Kind::integer: return "INTEGER";
    case WorldOption::Kind::flag: return "true|false";
    case WorldOption::Kind::text: return "TEXT";
  }
  return "";
}

std::string range_of(const WorldOption& o) {
  if (!(o.min < o.max)) return "";
  std::ostringstream s;
  s << " (" << o.min << "-" << o.max << ")";
  return s.str();
}

// `value` checked as option `o` takes it: "" or what is wrong.
std::string check_value(const WorldOption& o, std::string* value) {
  const std::string what = "world option " + o.name + " ";
  if (o.kind == WorldOption::Kind::flag) {
    if (*value == "" || *value == "1" || *value == "true") *value = "true";
    else if (*value == "0" || *value == "false") *value = "false";
    else return what + "is a flag: " + o.name + ", " + o.name + "=true or " + o.name + "=false";
    return "";
  }
  if (o.kind == WorldOption::Kind::text) return value->empty() ? what + "needs a value: " + o.name + "=TEXT" : "";
  double v = 0;
  if (!as_number(*value, &v) || (o.kind == WorldOption::Kind::integer && v != std::floor(v)))
    return what + "needs " + (o.kind == WorldOption::Kind::integer ? "an integer" : "a number") + range_of(o) +
           ", not '" + *value + "'";
  if (o.min < o.max && (v < o.min || v > o.max)) return what + "is out of its range" + range_of(o) + ": " + *value;
  return "";
}

}  // namespace

double WorldOptionValues::number(const std::string& name, double fallback) const {
  const auto it = values_.find(name);
  double v = fallback;
  return it != values_.end() && as_number(it->second, &v) ? v : fallback;
}

bool WorldOptionValues::flag(const std::string& name) const {
  const auto it = values_.find(name);
  return it != values_.end() && it->second == "true";
}

std::string WorldOptionValues::text(const std::string& name, const std::string& fallback) const {
  const auto it = values_.find(name);
  return it != values_.end() ? it->second : fallback;
}

WorldRegistration::WorldRegistration(WorldPlugin plugin) { registry().push_back(std::move(plugin)); }

const WorldPlugin* find_world(const std::string& spec) {
  for (const auto& p : registry())
    if (!p.name.empty() && p.name == spec) return &p;
  for (const auto& p : registry())
    if (p.accepts && p.accepts(spec)) return &p;
  return nullptr;
}

std::vector<const WorldPlugin*> worlds() {
  std::vector<const WorldPlugin*> out;
  for (const auto& p : registry()) out.push_back(&p);
  std::sort(out.begin(), out.end(), [](const WorldPlugin* a, const WorldPlugin* b) { return a->name < b->name; });
  return out;
}

std::string default_world() {
  if (const char* env = std::getenv("DCA_WORLD"); env != nullptr && *env != '\0') return env;
  for (const WorldPlugin* p : worlds())
    if (!p->name.empty()) return p->name;
  return "";
}

bool parse_world_options(const WorldPlugin& plugin, const std::vector<std::string>& texts, WorldOptionValues* out,
                         std::string* error) {
  for (const auto& text : texts) {
    const auto eq = text.find('=');
    const std::string key = text.substr(0, eq);
    std::string value = eq == std::string::npos ? "" : text.substr(eq + 1);
    const auto it = std::find_if(plugin.options.begin(), plugin.options.end(),
                                 [&](const WorldOption& o) { return o.name == key; });
    if (it == plugin.options.end()) {
      std::string names;
      for (const auto& o : plugin.options) names += (names.empty() ? "" : ", ") + o.name;
      *error = "world '" + plugin.name + "' has no option '" + key + "'" +
               (names.empty() ? " (it takes none)" : " (its options: " + names + ")");
      return false;
    }
    if (eq == std::string::npos && it->kind != WorldOption::Kind::flag) {
      *error = "world option " + key + " needs a value: " + key + "=" + kind_word(it->kind);
      return false;
    }
    if (std::string why = check_value(*it, &value); !why.empty()) {
      *error = why;
      return false;
    }
    out->set(key, value);
  }
  return true;
}

std::string world_options_help(const WorldPlugin& plugin) {
  std::string out;
  for (const auto& o : plugin.options) {
    std::string left = "  " + o.name + (o.kind == WorldOption::Kind::flag ? "" : std::string("=") + kind_word(o.kind));
    if (left.size() < 26) left.resize(26, ' ');
    out += left + " " + o.help + range_of(o) + "\n";
  }
  return out;
}

std::unique_ptr<DeviceWorld> make_world(const WorldSetup& setup) {
  const WorldPlugin* p = find_world(setup.spec);
  if (p == nullptr || !p->make) throw std::invalid_argument("no world '" + setup.spec + "'");
  return p->make(setup);
}

}  // namespace dca::sim
