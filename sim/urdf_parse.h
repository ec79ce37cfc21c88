#pragma once
// Reading and validating URDF (urdfdom) with errors that name the file, the line and the link or joint.
// C++17-clean: no Simbody types.
#include <map>
#include <memory>
#include <stdexcept>
#include <string>

namespace urdf {
class ModelInterface;
}

namespace dca::sim {

/// An invalid or unreadable URDF. what() is "FILE[:LINE:COL]: [link|joint 'NAME': ]reason".
class UrdfError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A parsed, validated URDF with the file name it came from (for later messages) and the source line of
/// every link and joint element.
struct ParsedUrdf {
  std::shared_ptr<urdf::ModelInterface> model;  ///< urdfdom's tree (root link, joints, inertials)
  std::string file;                             ///< the name used in messages
  /// "FILE:LINE:COL: link 'NAME'" or "FILE:LINE:COL: joint 'NAME'" for messages about an element.
  std::string where(const char* kind, const std::string& name) const;
  /// Where every <link>/<joint> element starts: kind + ":" + name -> "LINE:COL".
  std::map<std::string, std::string> lines;
};

/// Reads and validates the URDF file at `path`. Throws UrdfError when the file is missing, is not well-formed
/// XML (with line and column), is not valid URDF (urdfdom's reason, e.g. an unknown joint type or a link with
/// no path to the root), has an impossible inertia (negative mass, non-positive-definite or violating the
/// triangle inequality) or a moving joint whose child link has no mass.
ParsedUrdf parse_urdf_file(const std::string& path);

/// Same for URDF text; `name` stands for the file in messages.
ParsedUrdf parse_urdf_string(const std::string& text, const std::string& name);

}  // namespace dca::sim
