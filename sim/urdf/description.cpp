#include "sim/urdf/description.h"

#include <tinyxml.h>
#include <urdf_model/model.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "sim/urdf/sensors.h"

namespace dca::sim {
namespace {

namespace fs = std::filesystem;

bool moving(const std::string& type) { return type == "revolute" || type == "continuous" || type == "prismatic"; }

struct XmlJoint {
  std::string name, type, parent, child;
  const TiXmlElement* e;
};

// The checks on the XML, before urdfdom (see the header), and what only the XML says: ros2_control, meshes.
class XmlChecker {
 public:
  XmlChecker(const std::string& file, const std::string& dir) : file_(file), dir_(dir) {}

  void check(const TiXmlElement* robot) {
    collect(robot);
    check_joints();
    check_tree();
    check_inertials();
    meshes(robot);
  }
  const std::vector<XmlJoint>& joints() const { return joints_; }
  bool has_link(const std::string& name) const { return links_.count(name) > 0; }
  std::vector<std::string> warnings;

  // urdfdom's message `what` (which names no line, "[NAME]" at most) with the place of the joint or link it
  // names: "FILE:LINE:COL: joint 'NAME': ..." (the message as it is when it names none).
  std::string locate(const std::string& what, const std::string& file) const {
    for (auto open = what.find('['); open != std::string::npos; open = what.find('[', open + 1)) {
      const auto close = what.find(']', open);
      if (close == std::string::npos) break;
      const std::string name = what.substr(open + 1, close - open - 1);
      const std::string rest = what.compare(0, file.size() + 2, file + ": ") == 0 ? what.substr(file.size() + 2) : what;
      for (const auto& j : joints_)
        if (j.name == name) return at(j.e) + ": joint '" + name + "': " + rest;
      if (links_.count(name)) return at(links_.at(name)) + ": link '" + name + "': " + rest;
    }
    return what;
  }

  // "FILE:LINE:COL" of element `e`.
  std::string at(const TiXmlNode* e) const {
    return file_ + ":" + std::to_string(e->Row()) + ":" + std::to_string(e->Column());
  }
  [[noreturn]] void fail(const TiXmlNode* e, const std::string& what) const { throw UrdfError(at(e) + ": " + what); }

 private:
  static std::string attr(const TiXmlElement* e, const char* name) {
    const char* v = e ? e->Attribute(name) : nullptr;
    return v ? v : "";
  }

  void collect(const TiXmlElement* robot) {
    for (const TiXmlElement* e = robot->FirstChildElement(); e; e = e->NextSiblingElement()) {
      const std::string kind = e->Value();
      if (kind != "link" && kind != "joint") continue;
      const std::string name = attr(e, "name");
      if (name.empty()) fail(e, "a <" + kind + "> without a name");
      if (kind == "link") {
        if (!links_.emplace(name, e).second) fail(e, "link '" + name + "' is defined twice (first at " + at(links_[name]) + ")");
        continue;
      }
      const std::string parent = attr(e->FirstChildElement("parent"), "link");
      const std::string child = attr(e->FirstChildElement("child"), "link");
      for (const auto& j : joints_)
        if (j.name == name) fail(e, "joint '" + name + "' is defined twice (first at " + at(j.e) + ")");
      joints_.push_back({name, attr(e, "type"), parent, child, e});
    }
  }

  void check_joints() const {
    static const std::set<std::string> kTypes = {"fixed", "revolute", "continuous", "prismatic", "floating", "planar"};
    for (const auto& j : joints_) {
      const std::string who = "joint '" + j.name + "': ";
      if (!kTypes.count(j.type))
        fail(j.e, who + "type '" + j.type + "' is not supported (fixed, revolute, continuous, prismatic, floating, "
                        "planar)");
      if (j.parent.empty()) fail(j.e, who + "has no <parent link=\"...\"/>");
      if (j.child.empty()) fail(j.e, who + "has no <child link=\"...\"/>");
      if (!links_.count(j.parent)) fail(j.e, who + "its parent link '" + j.parent + "' is not defined");
      if (!links_.count(j.child)) fail(j.e, who + "its child link '" + j.child + "' is not defined");
    }
  }

  // One parent per link, no cycle, one root.
  void check_tree() {
    for (const auto& j : joints_) {
      const auto [it, fresh] = parent_.emplace(j.child, &j);
      if (!fresh)
        fail(j.e, "joint '" + j.name + "': link '" + j.child + "' is already the child of joint '" + it->second->name +
                      "' (" + at(it->second->e) + "): a kinematic loop; URDF describes a tree");
    }
    for (const auto& j : joints_) {
      std::set<std::string> seen{j.child};
      for (std::string l = j.parent;; ) {
        if (!seen.insert(l).second)
          fail(j.e, "joint '" + j.name + "': a kinematic loop: following parents from link '" + j.child +
                        "' comes back to link '" + l + "'; URDF describes a tree");
        const auto up = parent_.find(l);
        if (up == parent_.end()) break;
        l = up->second->parent;
      }
    }
    std::vector<std::string> roots;
    for (const auto& [name, e] : links_)
      if (!parent_.count(name)) roots.push_back(name);
    if (roots.size() > 1) {
      const TiXmlElement* second = links_[roots[1]];
      fail(second, "link '" + roots[1] + "' is joined to nothing: the model has " + std::to_string(roots.size()) +
                       " root links ('" + roots[0] + "', '" + roots[1] + "'...), a URDF has one");
    }
  }

  void check_inertials() const {
    for (const auto& j : joints_) {
      if (j.type == "fixed") continue;
      const TiXmlElement* link = links_.at(j.child);
      if (!link->FirstChildElement("inertial"))
        fail(link, "link '" + j.child + "': has no <inertial>, but joint '" + j.name + "' (" + at(j.e) +
                       ") moves it: a moving link needs a mass");
    }
  }

  void meshes(const TiXmlElement* e) {
    for (const TiXmlElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
      if (std::string(c->Value()) == "mesh") {
        const std::string uri = attr(c, "filename");
        std::string searched;
        if (resolve_mesh(uri, dir_, &searched).empty())
          warnings.push_back(at(c) + ": mesh '" + uri + "' not found (" + searched + "): a visual only, left out");
      }
      meshes(c);
    }
  }

  std::string file_, dir_;
  std::map<std::string, const TiXmlElement*> links_;
  std::vector<XmlJoint> joints_;
  std::map<std::string, const XmlJoint*> parent_;  // child link -> its joint
};

// <param name="NAME">VALUE</param> children of `e`: name -> element.
std::map<std::string, const TiXmlElement*> params_of(const TiXmlElement* e) {
  std::map<std::string, const TiXmlElement*> out;
  for (const TiXmlElement* p = e->FirstChildElement("param"); p; p = p->NextSiblingElement("param"))
    if (const char* n = p->Attribute("name")) out[n] = p;
  return out;
}

std::string text_of(const TiXmlElement* e) {
  const char* t = e->GetText();
  std::string s = t ? t : "";
  const auto b = s.find_first_not_of(" \t\r\n"), l = s.find_last_not_of(" \t\r\n");
  return b == std::string::npos ? "" : s.substr(b, l - b + 1);
}

// Reads ros2_control tags into the joints' command interfaces and initial values.
class Ros2Control {
 public:
  Ros2Control(const XmlChecker& x, std::vector<JointSpec>& joints, std::vector<SensorSpec>& sensors)
      : x_(x), joints_(joints), sensors_(sensors) {}

  // Reads every <ros2_control> of `robot`: true if one declares a joint.
  bool read(const TiXmlElement* robot, std::vector<std::string>& warnings) {
    bool any = false;
    for (const TiXmlElement* rc = robot->FirstChildElement("ros2_control"); rc;
         rc = rc->NextSiblingElement("ros2_control")) {
      for (const TiXmlElement* e = rc->FirstChildElement(); e; e = e->NextSiblingElement()) {
        const std::string kind = e->Value();
        if (kind == "joint") {
          joint(e, warnings);
          any = true;
        } else if (kind == "sensor" && sensor(e)) {
          continue;
        } else if (kind != "hardware") {
          warnings.push_back(x_.at(e) + ": <" + kind + "> '" + std::string(e->Attribute("name") ? e->Attribute("name") : "") +
                             "' of ros2_control is not simulated: left out");
        }
      }
    }
    return any;
  }

 private:
  double number(const TiXmlElement* p, const std::string& what) const {
    const std::string s = text_of(p);
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (s.empty() || *end != '\0' || std::isnan(v)) x_.fail(p, what + ": '" + s + "' is not a number");
    return v;
  }

  // Applies the <param>s of `e` (a ros2_control joint or one of its command interfaces) to `c`.
  void apply(const TiXmlElement* e, CommandSpec& c, const std::string& who) const {
    for (const auto& [name, p] : params_of(e)) {
      const std::string what = who + ": <param name=\"" + name + "\">";
      if (name == "watchdog_ticks") {
        const double v = number(p, what);
        if (v < 0 || v != std::floor(v) || v > 1e9) x_.fail(p, what + ": a whole number of ticks, 0 or more");
        c.watchdog_ticks = static_cast<int>(v);
      } else if (name == "on_stale") {
        const std::string v = text_of(p);
        if (v != "hold" && v != "zero") x_.fail(p, what + ": 'hold' or 'zero', not '" + v + "'");
        c.on_stale = v == "hold" ? OnStale::hold : OnStale::zero;
      } else if (name == "min" || name == "max" || name == "p" || name == "i" || name == "d") {
        const double v = number(p, what);
        (name == "min" ? c.min : name == "max" ? c.max : name == "p" ? c.p : name == "i" ? c.i : c.d) = v;
      }
    }
  }

  void joint(const TiXmlElement* e, std::vector<std::string>& warnings) {
    const std::string name = e->Attribute("name") ? e->Attribute("name") : "";
    const std::string who = "ros2_control joint '" + name + "'";
    auto it = std::find_if(joints_.begin(), joints_.end(), [&](const JointSpec& j) { return j.name == name; });
    if (it == joints_.end()) x_.fail(e, who + ": no revolute, continuous or prismatic joint of that name");
    JointSpec& j = *it;
    for (const TiXmlElement* c = e->FirstChildElement("command_interface"); c;
         c = c->NextSiblingElement("command_interface"))
      command(j, e, c, who);
    for (const TiXmlElement* s = e->FirstChildElement("state_interface"); s; s = s->NextSiblingElement("state_interface")) {
      const std::string kind = s->Attribute("name") ? s->Attribute("name") : "";
      if (kind != "position" && kind != "velocity" && kind != "effort") {
        warnings.push_back(x_.at(s) + ": " + who + ": state interface '" + kind + "' is not simulated: left out");
        continue;
      }
      const auto ps = params_of(s);
      if (kind == "position" && ps.count("initial_value")) {
        j.initial = number(ps.at("initial_value"), who + ": initial_value");
        if (j.initial < j.limits.lower || j.initial > j.limits.upper)
          x_.fail(ps.at("initial_value"), who + ": initial_value " + text_of(ps.at("initial_value")) +
                                            " is outside the joint's limits");
      }
    }
  }

  void command(JointSpec& j, const TiXmlElement* e, const TiXmlElement* c, const std::string& who) {
    const std::string kind = c->Attribute("name") ? c->Attribute("name") : "";
    CommandSpec spec;
    if (kind == "position") spec.kind = JointInterface::position, spec.on_stale = OnStale::hold;
    else if (kind == "velocity") spec.kind = JointInterface::velocity;
    else if (kind == "effort") spec.kind = JointInterface::effort;
    else x_.fail(c, who + ": command interface '" + kind + "' is not supported (position, velocity, effort)");
    for (const auto& other : j.commands)
      if (other.kind == spec.kind) x_.fail(c, who + ": command interface '" + kind + "' is declared twice");
    spec.where = x_.at(c);
    apply(e, spec, who);  // the joint's params, then the interface's own
    apply(c, spec, who + " " + kind);
    if (spec.min > spec.max) x_.fail(c, who + " " + kind + ": min is above max");
    j.commands.push_back(spec);
  }

  // The kind of sensor `e` from its state interfaces, its groups into `s`: false when none is of a kind
  // simulated (the sensor is left out, with a warning).
  bool sensor_interfaces(const TiXmlElement* e, SensorSpec& s, const std::string& who) const {
    bool known = false;
    for (const TiXmlElement* i = e->FirstChildElement("state_interface"); i; i = i->NextSiblingElement("state_interface")) {
      const std::string name = i->Attribute("name") ? i->Attribute("name") : "";
      const auto dot = name.rfind('.');
      const std::string group = name.substr(0, dot == std::string::npos ? 0 : dot);
      const std::string component = dot == std::string::npos ? "" : name.substr(dot + 1);
      SensorKind k;
      if (!known && sensor_kind_of(group, &k)) s.kind = k, known = true;
      if (!known) continue;
      std::string expected;
      bool matched = false;
      for (const auto& g : sensor_groups(s.kind))
        for (const auto* c : g.components) {
          const std::string full = std::string(g.name) + "." + c;
          expected += (expected.empty() ? "" : ", ") + full;
          if (full != name) continue;
          matched = true;
          if (std::find(s.groups.begin(), s.groups.end(), g.name) == s.groups.end()) s.groups.push_back(g.name);
        }
      if (!matched)
        x_.fail(i, who + ": state interface '" + name + "' is not one of a " + to_string(s.kind) + " sensor (" +
                       expected + ")");
    }
    if (known) {  // canonical order
      std::vector<std::string> ordered;
      for (const auto& g : sensor_groups(s.kind))
        if (std::find(s.groups.begin(), s.groups.end(), g.name) != s.groups.end()) ordered.push_back(g.name);
      s.groups = ordered;
    }
    return known;
  }

  // Where force-torque sensor `s` measures: its fixed joint (param joint, else the fixed joint whose child is
  // frame_id) and that joint's child link.
  void sensor_joint(const TiXmlElement* e, const std::map<std::string, const TiXmlElement*>& ps, SensorSpec& s,
                    const std::string& who) const {
    const XmlJoint* found = nullptr;
    const TiXmlElement* at = ps.count("joint") ? ps.at("joint") : ps.count("frame_id") ? ps.at("frame_id") : e;
    if (at == e) x_.fail(e, who + ": a force_torque sensor needs <param name=\"joint\"> naming a fixed joint");
    const std::string name = text_of(at);
    for (const auto& j : x_.joints())
      if (ps.count("joint") ? j.name == name : j.child == name) found = &j;
    if (!found)
      x_.fail(at, who + (ps.count("joint") ? ": joint '" + name + "' is not a joint of the model"
                                           : ": frame_id '" + name + "' is the child link of no joint"));
    if (found->type != "fixed")
      x_.fail(at, who + ": joint '" + found->name + "' is " + found->type +
                      ": a force_torque sensor measures across a fixed joint (" + x_.at(found->e) + ")");
    if (ps.count("joint") && ps.count("frame_id") && text_of(ps.at("frame_id")) != found->child)
      x_.fail(ps.at("frame_id"), who + ": frame_id must be the joint's child link '" + found->child + "'");
    s.joint = found->name;
    s.link = found->child;
    if (ps.count("measure_direction")) {
      const std::string v = text_of(ps.at("measure_direction"));
      if (v != "child_to_parent" && v != "parent_to_child")
        x_.fail(ps.at("measure_direction"), who + ": measure_direction is child_to_parent or parent_to_child, not '" + v + "'");
      s.child_to_parent = v == "child_to_parent";
    }
  }

  // A <sensor>: false when it is of no kind simulated.
  bool sensor(const TiXmlElement* e) {
    SensorSpec s;
    s.name = e->Attribute("name") ? e->Attribute("name") : "";
    const std::string who = "ros2_control sensor '" + s.name + "'";
    if (!sensor_interfaces(e, s, who)) return false;
    if (s.name.empty()) x_.fail(e, "a ros2_control <sensor> without a name");
    for (const auto& other : sensors_)
      if (other.name == s.name) x_.fail(e, who + " is declared twice (first at " + other.where + ")");
    s.where = x_.at(e);
    const auto ps = params_of(e);
    if (s.kind == SensorKind::force_torque) {
      sensor_joint(e, ps, s, who);
    } else {
      const TiXmlElement* at = ps.count("link") ? ps.at("link") : ps.count("frame_id") ? ps.at("frame_id") : nullptr;
      if (!at) x_.fail(e, who + ": an " + to_string(s.kind) + " sensor needs <param name=\"frame_id\"> naming its link");
      s.link = text_of(at);
      if (!x_.has_link(s.link)) x_.fail(at, who + ": link '" + s.link + "' is not a link of the model");
    }
    sensors_.push_back(std::move(s));
    return true;
  }

  const XmlChecker& x_;
  std::vector<JointSpec>& joints_;
  std::vector<SensorSpec>& sensors_;
};

JointLimitSpec limits_of(const urdf::Joint& j) {
  JointLimitSpec l;
  const double inf = std::numeric_limits<double>::infinity();
  if (j.limits) {
    if (j.type != urdf::Joint::CONTINUOUS) l.lower = j.limits->lower, l.upper = j.limits->upper;
    l.velocity = j.limits->velocity > 0 ? j.limits->velocity : inf;
    l.effort = j.limits->effort > 0 ? j.limits->effort : inf;
  }
  if (j.safety) {
    l.soft = true;
    l.soft_lower = std::max(l.lower, j.safety->soft_lower_limit);
    l.soft_upper = std::min(l.upper, j.safety->soft_upper_limit);
    if (j.type == urdf::Joint::CONTINUOUS) l.soft_lower = -inf, l.soft_upper = inf;
    l.k_position = j.safety->k_position;
    l.k_velocity = j.safety->k_velocity;
  }
  return l;
}

std::vector<std::string> split_path(const char* v) {
  std::vector<std::string> out;
  std::stringstream s(v ? v : "");
  for (std::string d; std::getline(s, d, ':');)
    if (!d.empty()) out.push_back(d);
  return out;
}

}  // namespace

const char* to_string(JointInterface i) {
  switch (i) {
    case JointInterface::position: return "position";
    case JointInterface::velocity: return "velocity";
    case JointInterface::effort: return "effort";
  }
  return "?";
}

const char* to_string(SensorKind k) {
  switch (k) {
    case SensorKind::force_torque: return "force_torque";
    case SensorKind::imu: return "imu";
    case SensorKind::odometry: return "odometry";
  }
  return "?";
}

const JointSpec* RobotDescription::joint(const std::string& joint_name) const {
  for (const auto& j : joints)
    if (j.name == joint_name) return &j;
  return nullptr;
}

std::string resolve_mesh(const std::string& uri, const std::string& dir, std::string* searched) {
  std::error_code ec;
  const auto found = [&](const fs::path& p) { return fs::is_regular_file(p, ec); };
  const std::string pkg = "package://", file = "file://";
  if (uri.compare(0, pkg.size(), pkg) == 0) {
    const std::string rest = uri.substr(pkg.size());
    const std::string name = rest.substr(0, rest.find('/'));
    const std::string inside = rest.find('/') == std::string::npos ? "" : rest.substr(rest.find('/') + 1);
    std::vector<std::string> dirs = split_path(std::getenv("DCA_PACKAGE_PATH"));
    for (const auto& d : split_path(std::getenv("ROS_PACKAGE_PATH"))) dirs.push_back(d);
    *searched = dirs.empty() ? "no package search path: DCA_PACKAGE_PATH and ROS_PACKAGE_PATH are unset"
                             : "package '" + name + "' searched in";
    for (const auto& d : dirs) {
      if (!dirs.empty()) *searched += " " + d;
      if (found(fs::path(d) / name / inside)) return (fs::path(d) / name / inside).string();
      if (fs::path(d).filename() == name && found(fs::path(d) / inside)) return (fs::path(d) / inside).string();
    }
    return "";
  }
  std::string path = uri;
  if (uri.compare(0, file.size(), file) == 0) path = uri.substr(file.size());
  else if (uri.find("://") != std::string::npos) return *searched = "not a package:// or file:// URI", "";
  const fs::path p = fs::path(path).is_absolute() ? fs::path(path) : fs::path(dir) / path;
  *searched = "looked for " + p.string();
  return found(p) ? p.string() : "";
}

RobotDescription load_description_string(const std::string& text, const std::string& name, const std::string& dir,
                                         const DescriptionOptions& options) {
  TiXmlDocument doc;
  doc.Parse(text.c_str());
  if (doc.Error())
    throw UrdfError(name + ":" + std::to_string(std::max(1, doc.ErrorRow())) + ":" +
                    std::to_string(std::max(1, doc.ErrorCol())) + ": not well-formed XML: " + doc.ErrorDesc());
  const TiXmlElement* robot = doc.FirstChildElement("robot");
  if (!robot) throw UrdfError(name + ": no <robot> element: not a URDF file");
  XmlChecker x(name, dir);
  x.check(robot);
  RobotDescription d;
  try {
    d.urdf = parse_urdf_string(text, name);
  } catch (const UrdfError& e) {
    throw UrdfError(x.locate(e.what(), name));
  }
  d.name = robot->Attribute("name") ? robot->Attribute("name") : "";
  d.text = text;
  for (const auto& xj : x.joints()) {
    if (!moving(xj.type)) continue;
    const urdf::JointConstSharedPtr j = d.urdf.model->getJoint(xj.name);
    JointSpec s;
    s.name = xj.name;
    s.type = j->type;
    s.linear = j->type == urdf::Joint::PRISMATIC;
    s.limits = limits_of(*j);
    s.initial = std::clamp(0.0, s.limits.lower, s.limits.upper);
    s.where = x.at(xj.e);
    d.joints.push_back(std::move(s));
  }
  d.warnings = std::move(x.warnings);
  d.declared = Ros2Control(x, d.joints, d.sensors).read(robot, d.warnings);
  if (!d.declared)
    for (auto& j : d.joints) {
      CommandSpec c;
      c.kind = options.default_command;
      if (c.kind == JointInterface::position) c.on_stale = OnStale::hold;
      c.where = j.where;
      j.commands.push_back(c);
    }
  return d;
}

RobotDescription load_description(const std::string& path, const DescriptionOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UrdfError(path + ": cannot open the URDF file");
  std::ostringstream text;
  text << in.rdbuf();
  return load_description_string(text.str(), path, fs::path(path).parent_path().string(), options);
}

}  // namespace dca::sim
