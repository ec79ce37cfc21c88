#pragma once
// The files dca ships that a controller may read (the loading process's: dca resolves these for a package).
#include <string>

namespace dca {

/// The directory of the URDF models: $DCA_MODELS_DIR if set; else <exe>/../share/dca/models when it exists
/// (an installed dca); else the source tree's worlds/door/models (a build tree).
std::string models_dir();

}  // namespace dca
