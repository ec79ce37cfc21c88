// The URDF -> Simbody loader: body poses equal forward kinematics computed from the URDF alone (Eigen), and
// every kind of invalid URDF gives an error naming the file and the link or joint.
#include <gtest/gtest.h>
#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "worlds/door/door_model.h"
#include "sim/urdf_bodies.h"
#include "sim/urdf_parse.h"
#include "tests/support/temp_dir.h"

namespace {

using Coordinates = std::map<std::string, std::vector<double>>;

Eigen::Isometry3d pose(const urdf::Pose& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z).toRotationMatrix();
  T.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  return T;
}

// The joint's motion at q, in the joint frame, from the URDF's definitions only.
Eigen::Isometry3d motion(const urdf::Joint& j, const std::vector<double>& q) {
  const Eigen::Vector3d axis = Eigen::Vector3d(j.axis.x, j.axis.y, j.axis.z).normalized();
  Eigen::Isometry3d M = Eigen::Isometry3d::Identity();
  switch (j.type) {
    case urdf::Joint::REVOLUTE:
    case urdf::Joint::CONTINUOUS:
      M.linear() = Eigen::AngleAxisd(q.at(0), axis).toRotationMatrix();
      break;
    case urdf::Joint::PRISMATIC:
      M.translation() = q.at(0) * axis;
      break;
    case urdf::Joint::PLANAR: {  // (angle, x, y) in the plane; the test models use axis +z, so no alignment
      EXPECT_LT((axis - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
      M.linear() = Eigen::AngleAxisd(q.at(0), Eigen::Vector3d::UnitZ()).toRotationMatrix();
      M.translation() = Eigen::Vector3d(q.at(1), q.at(2), 0);
      break;
    }
    default:
      break;
  }
  return M;
}

Eigen::Isometry3d fk(const urdf::ModelInterface& model, const std::string& link, const Coordinates& q) {
  const urdf::LinkConstSharedPtr l = model.getLink(link);
  const urdf::JointSharedPtr& j = l->parent_joint;
  if (!j) return Eigen::Isometry3d::Identity();
  const auto it = q.find(j->name);
  const std::vector<double> zero(3, 0.0);
  return fk(model, j->parent_link_name, q) * pose(j->parent_to_joint_origin_transform) *
         motion(*j, it == q.end() ? zero : it->second);
}

// A file in a folder of this process's own, removed with everything in it when the process ends.
std::string temp_file(const std::string& name, const std::string& text) {
  static const dca::test::TempDir dir("urdf_loader_test");
  const auto path = std::filesystem::path(dir.path()) / ("dca_urdf_loader_test_" + name);
  std::ofstream(path) << text;
  return path.string();
}

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void expect_poses_match(const std::string& path, const Coordinates& q) {
  dca::sim::UrdfBodies bodies(path);
  for (const auto& [joint, values] : q) bodies.set_q(joint, values);
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(read(path));
  ASSERT_TRUE(model);
  std::vector<urdf::LinkSharedPtr> links;
  model->getLinks(links);
  ASSERT_GT(links.size(), 3u);
  for (const auto& l : links) {
    const Eigen::Isometry3d expected = fk(*model, l->name, q), got = bodies.link_pose(l->name);
    EXPECT_LT((expected.matrix() - got.matrix()).cwiseAbs().maxCoeff(), 1e-9) << l->name << "\nexpected\n"
        << expected.matrix() << "\ngot\n" << got.matrix();
  }
}

const std::string kModels = DCA_SIM_MODELS_DIR;

TEST(UrdfLoaderTest, RobotBodyPosesEqualUrdfForwardKinematics) {
  const Coordinates q = {{"base_joint", {-0.7, 0.3, 1.2}}, {"arm_joint_1", {0.4}},  {"arm_joint_2", {-0.9}},
                         {"arm_joint_3", {2.1}},           {"arm_joint_4", {-0.5}}, {"arm_joint_5", {0.8}},
                         {"arm_joint_6", {-2.5}},          {"finger_left_joint", {0.02}},
                         {"finger_right_joint", {0.035}}};
  expect_poses_match(kModels + "/mobile_manipulator.urdf", q);
  expect_poses_match(kModels + "/mobile_manipulator.urdf", {});
}

TEST(UrdfLoaderTest, DoorBodyPosesEqualUrdfForwardKinematics) {
  dca::sim::DoorParams p;
  p.width = 0.83;
  const std::string path = temp_file("door.urdf", dca::sim::door_urdf(p));
  expect_poses_match(path, {{"door_hinge", {1.1}}, {"door_handle_joint", {0.4}}});
}

TEST(UrdfLoaderTest, CommittedDoorModelIsTheNominalGeneratedOne) {
  EXPECT_EQ(read(kModels + "/door.urdf"), dca::sim::door_urdf(dca::sim::DoorParams{}));
}

TEST(UrdfLoaderTest, RobotMassIsThePartsSum) {
  dca::sim::UrdfBodies bodies(kModels + "/mobile_manipulator.urdf");
  EXPECT_NEAR(bodies.total_mass(), 90 + 10 + 17.4 + 4.8 + 0.82 + 0.34 + 0.09 + 0.25 + 0.6 + 0.1, 1e-9);
  EXPECT_EQ(bodies.joints().size(), 9u);
}

// The error message of loading `text` (as a file), or "" if it loads.
std::string error_of(const std::string& name, const std::string& text) {
  try {
    dca::sim::UrdfBodies bodies(temp_file(name, text));
  } catch (const dca::sim::UrdfError& e) {
    return e.what();
  }
  return "";
}

std::string link(const std::string& name, const std::string& ixx = "0.1") {
  return "<link name=\"" + name + "\"><inertial><mass value=\"1\"/><inertia ixx=\"" + ixx +
         "\" ixy=\"0\" ixz=\"0\" iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/></inertial></link>";
}

std::string joint(const std::string& name, const std::string& type, const std::string& parent,
                  const std::string& child) {
  return "<joint name=\"" + name + "\" type=\"" + type + "\"><parent link=\"" + parent + "\"/><child link=\"" +
         child + "\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>";
}

TEST(UrdfLoaderTest, MissingFileIsNamed) {
  try {
    dca::sim::UrdfBodies bodies("/nonexistent/robot.urdf");
    FAIL() << "loaded a missing file";
  } catch (const dca::sim::UrdfError& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/robot.urdf: cannot open the URDF file");
  }
}

TEST(UrdfLoaderTest, BadXmlGivesLineAndColumn) {
  const std::string e = error_of("bad.urdf", "<robot name=\"r\">\n  <link name=\"a\">\n</robot>\n");
  EXPECT_NE(e.find("dca_urdf_loader_test_bad.urdf:"), std::string::npos) << e;
  EXPECT_NE(e.find("not well-formed XML"), std::string::npos) << e;
  EXPECT_NE(e.find(":3:"), std::string::npos) << e;  // the mismatched </robot> on line 3
}

TEST(UrdfLoaderTest, UnknownJointTypeNamesTheJoint) {
  const std::string e = error_of("type.urdf", "<robot name=\"r\">" + link("a") + link("b") +
                                                  joint("wobble", "helical", "a", "b") + "</robot>");
  EXPECT_NE(e.find("type.urdf: not a valid URDF"), std::string::npos) << e;
  EXPECT_NE(e.find("wobble"), std::string::npos) << e;
}

TEST(UrdfLoaderTest, ImpossibleInertiaNamesTheLinkAndLine) {
  const std::string e = error_of("inertia.urdf", "<robot name=\"r\">\n" + link("a") + "\n" + link("forearm", "0.5") +
                                                     "\n" + joint("j", "revolute", "a", "forearm") + "</robot>");
  EXPECT_NE(e.find("inertia.urdf:3:1: link 'forearm': inertia is impossible"), std::string::npos) << e;
  EXPECT_NE(e.find("triangle inequality"), std::string::npos) << e;
  const std::string neg = error_of("negative.urdf", "<robot name=\"r\">" + link("a") + link("b", "-0.1") +
                                                        joint("j", "revolute", "a", "b") + "</robot>");
  EXPECT_NE(neg.find("link 'b': inertia is impossible"), std::string::npos) << neg;
}

TEST(UrdfLoaderTest, DisconnectedLinkIsNamed) {
  const std::string e = error_of("island.urdf", "<robot name=\"r\">" + link("a") + link("b") + link("island") +
                                                    joint("j", "revolute", "a", "b") + "</robot>");
  EXPECT_NE(e.find("island.urdf: not a valid URDF"), std::string::npos) << e;
  EXPECT_NE(e.find("island"), std::string::npos) << e;
}

TEST(UrdfLoaderTest, MovingMasslessLinkNamesTheJoint) {
  const std::string e = error_of("massless.urdf", "<robot name=\"r\">" + link("a") +
                                                      "<link name=\"ghost\"/>" +
                                                      joint("spin", "continuous", "a", "ghost") + "</robot>");
  EXPECT_NE(e.find("massless.urdf:1:"), std::string::npos) << e;
  EXPECT_NE(e.find("joint 'spin': moves link 'ghost', which carries no mass"), std::string::npos) << e;
}

TEST(UrdfLoaderTest, NotAUrdfAtAll) {
  EXPECT_NE(error_of("html.urdf", "<html/>").find("html.urdf: no <robot> element"), std::string::npos);
}

}  // namespace
