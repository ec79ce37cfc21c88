#include "controllers/robot/model.h"

#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include "host/paths.h"

namespace dca::robot {

std::string urdf_path() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("DCA_MODELS_DIR"); env != nullptr && *env != '\0')
    return (fs::path(env) / "mobile_manipulator.urdf").string();
  // <lua dir> is <prefix>/share/dca/lua (installed) or <source>/lua: the models sit beside it.
  const fs::path lua = dca::lua_dir();
  std::error_code ec;
  for (const fs::path& p : {lua.parent_path() / "models" / "mobile_manipulator.urdf",
                            lua.parent_path() / "sim" / "models" / "mobile_manipulator.urdf"})
    if (fs::exists(p, ec)) return p.string();
  return (lua.parent_path() / "sim" / "models" / "mobile_manipulator.urdf").string();
}

math::Chain arm() {
  std::string error;
  auto chain = math::Chain::FromUrdfFile(urdf_path(), "base_link", "tool0", &error);
  if (!chain) throw std::invalid_argument(error);
  if (chain->dof() != 6)
    throw std::invalid_argument(urdf_path() + ": the arm base_link -> tool0 has " + std::to_string(chain->dof()) +
                                " movable joints, expected 6");
  return *chain;
}

Eigen::Isometry3d camera() {
  std::string error;
  auto chain = math::Chain::FromUrdfFile(urdf_path(), "base_link", "camera_link", &error);
  if (!chain) throw std::invalid_argument(error);
  if (chain->dof() != 0)
    throw std::invalid_argument(urdf_path() + ": the camera base_link -> camera_link has movable joints");
  return chain->Forward(math::JointVector(0));
}

Eigen::Vector3d tool_position(const math::Chain& arm, const Eigen::Matrix<double, 6, 1>& q) {
  math::JointVector jq = q;
  return arm.Forward(jq).translation();
}

}  // namespace dca::robot
