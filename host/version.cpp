#include "host/version.h"

#include "dca/version.h"

namespace dca {

std::string_view version() { return DCA_VERSION_STRING; }

}  // namespace dca
