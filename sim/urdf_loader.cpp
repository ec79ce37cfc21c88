#include "sim/urdf_loader.h"

#include <urdf_model/model.h>

#include <algorithm>
#include <cmath>

namespace dca::sim {
namespace {

SimTK::Transform to_transform(const urdf::Pose& p) {
  const SimTK::Quaternion q(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z);
  return SimTK::Transform(SimTK::Rotation(q), SimTK::Vec3(p.position.x, p.position.y, p.position.z));
}

// The minimal rotation taking unit vector `from` onto unit vector `to`; a half turn about `flip` if opposite.
SimTK::Rotation align(const SimTK::Vec3& from, const SimTK::Vec3& to, const SimTK::Vec3& flip) {
  const SimTK::Vec3 c = SimTK::cross(from, to);
  const double s = c.norm(), d = SimTK::dot(from, to);
  if (s < 1e-12) {
    if (d > 0) return SimTK::Rotation();
    return SimTK::Rotation(SimTK::Pi, SimTK::UnitVec3(flip));
  }
  return SimTK::Rotation(std::atan2(s, d), SimTK::UnitVec3(c / s));
}

SimTK::MassProperties mass_properties(const urdf::Link& link) {
  if (!link.inertial) return SimTK::MassProperties(0, SimTK::Vec3(0), SimTK::Inertia(0));
  const urdf::Inertial& in = *link.inertial;
  const SimTK::Transform X_LC = to_transform(in.origin);  // inertial frame, at the mass centre
  const SimTK::Mat33 I_C(in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz);
  // Re-express the central inertia in the link frame, then shift it to the link origin.
  const SimTK::Mat33 R = X_LC.R().asMat33();
  const SimTK::Mat33 I_L_about_C = R * I_C * ~R;
  const SimTK::Inertia central(SimTK::SymMat33(I_L_about_C(0, 0), I_L_about_C(1, 0), I_L_about_C(1, 1),
                                               I_L_about_C(2, 0), I_L_about_C(2, 1), I_L_about_C(2, 2)));
  const SimTK::Vec3 com = X_LC.p();
  return SimTK::MassProperties(in.mass, com, central.shiftFromMassCenter(com, in.mass));
}

double stop_stiffness(const urdf::Link& child, const LoaderOptions& o, const SimTK::Vec3& axis_in_child,
                      bool rotational) {
  // Explicit integration of a stop is stable while sqrt(k / inertia) * period stays well below 1: limit k by
  // the child link's own inertia about the axis (a lower bound of what the joint carries).
  const SimTK::MassProperties mp = mass_properties(child);
  double inertia = mp.getMass();
  if (rotational) inertia = std::max(1e-6, ~axis_in_child * (mp.getInertia().toMat33() * axis_in_child));
  return std::min(o.stop_stiffness, 0.2 * inertia / (o.period * o.period));
}

// URDF <visual> boxes, cylinders and spheres as decorations (seen only with a visualizer).
void add_visuals(const urdf::Link& link, SimTK::Body& body) {
  for (const auto& v : link.visual_array) {
    if (!v || !v->geometry) continue;
    const SimTK::Transform X = to_transform(v->origin);
    switch (v->geometry->type) {
      case urdf::Geometry::BOX: {
        const auto& b = static_cast<const urdf::Box&>(*v->geometry);
        body.addDecoration(X, SimTK::DecorativeBrick(SimTK::Vec3(b.dim.x / 2, b.dim.y / 2, b.dim.z / 2)));
        break;
      }
      case urdf::Geometry::CYLINDER: {  // Simbody's cylinders lie along y, URDF's along z
        const auto& c = static_cast<const urdf::Cylinder&>(*v->geometry);
        body.addDecoration(X * SimTK::Transform(SimTK::Rotation(SimTK::Pi / 2, SimTK::XAxis)),
                           SimTK::DecorativeCylinder(c.radius, c.length / 2));
        break;
      }
      case urdf::Geometry::SPHERE:
        body.addDecoration(X, SimTK::DecorativeSphere(static_cast<const urdf::Sphere&>(*v->geometry).radius));
        break;
      default:
        break;
    }
  }
}

struct Builder {
  SimTK::SimbodyMatterSubsystem& matter;
  SimTK::GeneralForceSubsystem& forces;
  const ParsedUrdf& urdf;
  const LoaderOptions& options;
  LoadedUrdf out;

  // Adds `link`'s child joints: `body` carries `link`, with the link frame at X_BL on it.
  void add_children(const urdf::Link& link, SimTK::MobilizedBody& body, const SimTK::Transform& X_BL) {
    for (const auto& joint : link.child_joints) {
      const urdf::LinkConstSharedPtr child_ptr = urdf.model->getLink(joint->child_link_name);
      const urdf::Link& child = *child_ptr;
      const SimTK::Transform X_BJ = X_BL * to_transform(joint->parent_to_joint_origin_transform);
      SimTK::Vec3 axis(joint->axis.x, joint->axis.y, joint->axis.z);
      try {
        if (joint->type == urdf::Joint::FIXED && !child.inertial) {
          out.link_body[child.name] = body.getMobilizedBodyIndex();
          out.link_in_body[child.name] = X_BJ;
          add_children(child, body, X_BJ);
          continue;
        }
        SimTK::Body::Rigid rigid(mass_properties(child));
        add_visuals(child, rigid);
        const auto attach = [&](SimTK::MobilizedBody& m) {
          out.link_body[child.name] = m.getMobilizedBodyIndex();
          out.link_in_body[child.name] = SimTK::Transform();
          add_children(child, m, SimTK::Transform());
        };
        const auto need_axis = [&] {
          const double n = axis.norm();
          if (!(n > 1e-9)) throw UrdfError(urdf.where("joint", joint->name) + ": has a zero axis");
          axis /= n;
        };
        switch (joint->type) {
          case urdf::Joint::FIXED: {
            SimTK::MobilizedBody::Weld weld(body, X_BJ, rigid, SimTK::Transform());
            out.weld_body[joint->name] = weld.getMobilizedBodyIndex();
            attach(weld);
            break;
          }
          case urdf::Joint::REVOLUTE:
          case urdf::Joint::CONTINUOUS:
          case urdf::Joint::PRISMATIC: {
            need_axis();
            const bool slider = joint->type == urdf::Joint::PRISMATIC;
            const SimTK::Rotation R = slider ? align(SimTK::Vec3(1, 0, 0), axis, SimTK::Vec3(0, 0, 1))
                                             : align(SimTK::Vec3(0, 0, 1), axis, SimTK::Vec3(1, 0, 0));
            const SimTK::Transform X_JF(R, SimTK::Vec3(0)), X_CM(R, SimTK::Vec3(0));
            const SimTK::MobilizedBodyIndex index =
                slider ? SimTK::MobilizedBody::Slider(body, X_BJ * X_JF, rigid, X_CM).getMobilizedBodyIndex()
                       : SimTK::MobilizedBody::Pin(body, X_BJ * X_JF, rigid, X_CM).getMobilizedBodyIndex();
            SimTK::MobilizedBody& m = matter.updMobilizedBody(index);
            out.joints.push_back({joint->name, joint->type, m.getMobilizedBodyIndex(), 1, 1});
            if (joint->limits && joint->type != urdf::Joint::CONTINUOUS) {
              const double lo = joint->limits->lower, hi = joint->limits->upper;
              if (!(lo < hi))
                throw UrdfError(urdf.where("joint", joint->name) + ": limit lower " + std::to_string(lo) +
                                " is not below upper " + std::to_string(hi));
              SimTK::Force::MobilityLinearStop(forces, m, SimTK::MobilizerQIndex(0),
                                               stop_stiffness(child, options, axis, !slider),
                                               options.stop_dissipation, lo, hi);
            }
            if (joint->dynamics && joint->dynamics->damping > 0)
              SimTK::Force::MobilityLinearDamper(forces, m, SimTK::MobilizerUIndex(0), joint->dynamics->damping);
            attach(m);
            break;
          }
          case urdf::Joint::PLANAR: {
            need_axis();
            const SimTK::Rotation R = align(SimTK::Vec3(0, 0, 1), axis, SimTK::Vec3(1, 0, 0));
            SimTK::MobilizedBody::Planar m(body, X_BJ * SimTK::Transform(R, SimTK::Vec3(0)), rigid,
                                           SimTK::Transform(R, SimTK::Vec3(0)));
            out.joints.push_back({joint->name, joint->type, m.getMobilizedBodyIndex(), 3, 3});
            if (joint->dynamics && joint->dynamics->damping > 0)
              for (int i = 0; i < 3; ++i)
                SimTK::Force::MobilityLinearDamper(forces, m, SimTK::MobilizerUIndex(i), joint->dynamics->damping);
            attach(m);
            break;
          }
          case urdf::Joint::FLOATING: {
            SimTK::MobilizedBody::Free m(body, X_BJ, rigid, SimTK::Transform());
            out.joints.push_back({joint->name, joint->type, m.getMobilizedBodyIndex(), 7, 6});
            attach(m);
            break;
          }
          default:
            throw UrdfError(urdf.where("joint", joint->name) + ": unknown joint type");
        }
      } catch (const UrdfError&) {
        throw;
      } catch (const std::exception& e) {
        throw UrdfError(urdf.where("joint", joint->name) + ": Simbody rejects it: " + e.what());
      }
    }
  }
};

}  // namespace

const LoadedJoint* LoadedUrdf::joint(const std::string& name) const {
  for (const auto& j : joints)
    if (j.name == name) return &j;
  return nullptr;
}

SimTK::Transform LoadedUrdf::link_pose(const SimTK::SimbodyMatterSubsystem& matter, const SimTK::State& s,
                                       const std::string& link) const {
  const auto b = link_body.find(link);
  if (b == link_body.end()) throw UrdfError(file + ": no link '" + link + "'");
  return matter.getMobilizedBody(b->second).getBodyTransform(s) * link_in_body.at(link);
}

LoadedUrdf add_urdf(SimTK::SimbodyMatterSubsystem& matter, SimTK::GeneralForceSubsystem& forces,
                    const ParsedUrdf& urdf, SimTK::MobilizedBody& parent,
                    const SimTK::Transform& X_parent_root, const LoaderOptions& options) {
  Builder b{matter, forces, urdf, options, {}};
  b.out.file = urdf.file;
  const urdf::LinkConstSharedPtr root = urdf.model->getRoot();
  if (!root) throw UrdfError(urdf.file + ": no root link");
  const urdf::Link& r = *root;
  if (!r.inertial) {
    b.out.link_body[r.name] = parent.getMobilizedBodyIndex();
    b.out.link_in_body[r.name] = X_parent_root;
    b.add_children(r, parent, X_parent_root);
  } else {
    SimTK::Body::Rigid rigid(mass_properties(r));
    add_visuals(r, rigid);
    SimTK::MobilizedBody::Weld weld(parent, X_parent_root, rigid, SimTK::Transform());
    b.out.link_body[r.name] = weld.getMobilizedBodyIndex();
    b.out.link_in_body[r.name] = SimTK::Transform();
    b.add_children(r, weld, SimTK::Transform());
  }
  return b.out;
}

}  // namespace dca::sim
