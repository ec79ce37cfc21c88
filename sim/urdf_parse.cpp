#include "sim/urdf_parse.h"

#include <console_bridge/console.h>
#include <tinyxml.h>
#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Dense>
#include <cmath>
#include <fstream>
#include <mutex>
#include <sstream>

namespace dca::sim {
namespace {

// urdfdom reports why it rejects a file only through console_bridge: collect those messages while parsing.
class Capture : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) {
      if (!messages.empty()) messages += "; ";
      messages += text;
    }
  }
  std::string messages;
};

std::mutex& capture_mutex() {
  static std::mutex m;
  return m;
}

void collect_lines(const TiXmlElement* robot, std::map<std::string, std::string>& lines) {
  for (const TiXmlElement* e = robot->FirstChildElement(); e; e = e->NextSiblingElement()) {
    const std::string kind = e->Value();
    if (kind != "link" && kind != "joint") continue;
    const char* name = e->Attribute("name");
    if (!name) continue;
    lines.emplace(kind + ":" + name, std::to_string(e->Row()) + ":" + std::to_string(e->Column()));
  }
}

double subtree_mass(const urdf::Link& link) {
  double m = link.inertial ? link.inertial->mass : 0.0;
  for (const auto& child : link.child_links) m += subtree_mass(*child);
  return m;
}

void check_inertias(const ParsedUrdf& p) {
  std::vector<urdf::LinkSharedPtr> links;
  p.model->getLinks(links);
  for (const auto& link : links) {
    if (!link->inertial) continue;
    const urdf::Inertial& in = *link->inertial;
    const auto bad = [&](const std::string& why) { throw UrdfError(p.where("link", link->name) + ": " + why); };
    if (!std::isfinite(in.mass) || in.mass < 0) bad("mass " + std::to_string(in.mass) + " is not a mass");
    Eigen::Matrix3d I;
    I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
    if (!I.allFinite()) bad("inertia has a non-finite entry");
    const Eigen::Vector3d m = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I).eigenvalues();
    const double tol = 1e-9 * std::max(1.0, m.cwiseAbs().maxCoeff());
    std::ostringstream moments;
    moments << "principal moments " << m(0) << ", " << m(1) << ", " << m(2);
    if (m.minCoeff() < -tol) bad("inertia is impossible: " + moments.str() + " (one is negative)");
    if (m(0) + m(1) < m(2) - tol)
      bad("inertia is impossible: " + moments.str() + " violate the triangle inequality");
  }
  std::vector<urdf::LinkSharedPtr> all;
  p.model->getLinks(all);
  for (const auto& link : all) {
    const auto& j = link->parent_joint;
    if (!j || j->type == urdf::Joint::FIXED) continue;
    if (!(subtree_mass(*link) > 0))
      throw UrdfError(p.where("joint", j->name) + ": moves link '" + link->name + "', which carries no mass");
  }
}

}  // namespace

std::string ParsedUrdf::where(const char* kind, const std::string& name) const {
  const auto it = lines.find(std::string(kind) + ":" + name);
  return file + (it == lines.end() ? "" : ":" + it->second) + ": " + kind + " '" + name + "'";
}

ParsedUrdf parse_urdf_string(const std::string& text, const std::string& name) {
  ParsedUrdf p;
  p.file = name;
  TiXmlDocument doc;
  doc.Parse(text.c_str());
  if (doc.Error())
    throw UrdfError(name + ":" + std::to_string(doc.ErrorRow()) + ":" + std::to_string(doc.ErrorCol()) +
                    ": not well-formed XML: " + doc.ErrorDesc());
  const TiXmlElement* robot = doc.FirstChildElement("robot");
  if (!robot) throw UrdfError(name + ": no <robot> element: not a URDF file");
  collect_lines(robot, p.lines);
  {
    std::lock_guard<std::mutex> lock(capture_mutex());
    Capture capture;
    console_bridge::OutputHandler* previous = console_bridge::getOutputHandler();
    console_bridge::useOutputHandler(&capture);
    p.model = urdf::parseURDF(text);
    console_bridge::useOutputHandler(previous);
    if (!p.model)
      throw UrdfError(name + ": not a valid URDF: " +
                      (capture.messages.empty() ? std::string("urdfdom rejected it") : capture.messages));
  }
  check_inertias(p);
  return p;
}

ParsedUrdf parse_urdf_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UrdfError(path + ": cannot open the URDF file");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_urdf_string(text.str(), path);
}

}  // namespace dca::sim
