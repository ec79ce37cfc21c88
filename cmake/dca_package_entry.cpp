// The entry point of a controller package (dca/package.h), added to its sources by
// dca_add_controller_package(): compiled with DCA_PACKAGE_NAME="<name>".
#include <dca/package.h>

// What the package says it was built against (tests override them to build a package "from another dca").
#ifndef DCA_PACKAGE_BUILT_VERSION
#define DCA_PACKAGE_BUILT_VERSION DCA_VERSION_STRING
#endif
#ifndef DCA_PACKAGE_BUILT_ABI
#define DCA_PACKAGE_BUILT_ABI DCA_ABI_STAMP
#endif

extern "C" {
dca::package_detail::Link* dca_package_links = nullptr;
}

namespace {

void add_types(dca::Registry& into) {
  for (auto* l = dca_package_links; l != nullptr; l = l->next) l->add(into);
}

const dca::PackageEntry kEntry{DCA_PACKAGE_NAME, DCA_PACKAGE_BUILT_VERSION, DCA_PACKAGE_BUILT_ABI, &add_types};

}  // namespace

// The same two strings, in the file's bytes, for a loader that cannot run this library (a symbol it lacks).
extern "C" __attribute__((used, visibility("hidden"))) const char dca_package_stamp[] =
    "\x7f" "dca-package-stamp\n" DCA_PACKAGE_BUILT_VERSION "\n" DCA_PACKAGE_BUILT_ABI "\n";

extern "C" __attribute__((visibility("default"))) const dca::PackageEntry* dca_package_entry_v1() { return &kEntry; }
