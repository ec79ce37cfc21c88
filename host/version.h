#pragma once
#include <string_view>

namespace dca {

/// The release, as in `dca --version` ("0.1.0").
std::string_view version();

}  // namespace dca
