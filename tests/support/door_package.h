#pragma once
// The door package's types in a test's registry: tests of the door library link its objects (the package's
// code and entry point, controllers/CMakeLists.txt) and add its types as the loader does after dlopen.
#include <stdexcept>
#include <string>

#include <dca/package.h>

extern "C" const dca::PackageEntry* dca_package_entry_v1();

namespace dca::testing {

/// Adds the door package's types to Registry::global() (once).
inline void add_door_types() {
  static const bool added = [] {
    Registry staged;
    dca_package_entry_v1()->add_types(staged);
    std::string error;
    if (!Registry::global().adopt(std::move(staged), "door", &error)) throw std::logic_error(error);
    return true;
  }();
  (void)added;
}

}  // namespace dca::testing
