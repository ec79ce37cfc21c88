#pragma once
// A controller package: a shared library of controller types, built outside (or inside) the dca tree against the
// installed SDK, that dca loads by name (docs/packages.md). An author writes controllers
// exactly as the built-ins (dca/controller.h, DCA_REGISTER_CONTROLLER in each .cpp) and builds them with
//   find_package(dca REQUIRED)
//   dca_add_controller_package(mylab SOURCES pid.cpp filter.cpp)
// which compiles every source with DCA_PACKAGE_NAME="mylab" and adds the entry point (cmake/dca_package_entry.cpp).
//
// Loading (controllers/packages.h) reads the entry point's plain C data first: the dca version and the ABI stamp
// the package was built with. Only when the version and every compared part of the stamp equal this dca's does it
// call `add_types`, so no code of a package
// built against another dca ever touches this one's objects. Until then the package's static initialisers only
// link their types into the package's own list (dca_package_links, hidden: every package has its own).
#include <dca/registry.h>
#include <dca/version.h>

#define DCA_PACKAGE_STR2(x) #x
#define DCA_PACKAGE_STR(x) DCA_PACKAGE_STR2(x)

// The parts of the ABI stamp, each "key-value" (a package's entry point may override them: tests build "another
// dca"'s packages that way).
#ifndef DCA_ABI_SDK
#define DCA_ABI_SDK "sdk-" DCA_SDK_HASH  // the SDK headers' hash (dca/version.h)
#endif
#ifndef DCA_ABI_STDLIB  // the standard library: its release and string ABI (libstdc++), or its version (libc++)
#if defined(_LIBCPP_VERSION)
#define DCA_ABI_STDLIB "stdlib-libc++-" DCA_PACKAGE_STR(_LIBCPP_VERSION)
#else
#define DCA_ABI_STDLIB \
  "stdlib-libstdc++-" DCA_PACKAGE_STR(_GLIBCXX_RELEASE) "-cxx11abi" DCA_PACKAGE_STR(_GLIBCXX_USE_CXX11_ABI)
#endif
#endif
#ifndef DCA_ABI_COMPILER  // the compiler: recorded and named in a refusal, never a reason for one (see below)
#if defined(__clang__)
#define DCA_ABI_COMPILER \
  "cc-clang-" DCA_PACKAGE_STR(__clang_major__) "." DCA_PACKAGE_STR(__clang_minor__) "." DCA_PACKAGE_STR(__clang_patchlevel__)
#else
#define DCA_ABI_COMPILER \
  "cc-gcc-" DCA_PACKAGE_STR(__GNUC__) "." DCA_PACKAGE_STR(__GNUC_MINOR__) "." DCA_PACKAGE_STR(__GNUC_PATCHLEVEL__)
#endif
#endif

/// What must match between dca and a package, as space-separated "key-value" parts: the SDK headers' hash, the
/// standard library (the types crossing the boundary are std::string, std::vector, std::function: laid out by it),
/// and the Eigen and msgpack versions. The compiler ("cc-...") is recorded too but not compared: GCC and Clang
/// share the Itanium C++ ABI on Linux, so a package built by clang++ against the same libstdc++ is accepted.
#define DCA_ABI_STAMP                                                                                             \
  DCA_ABI_SDK " " DCA_ABI_STDLIB " eigen-" DCA_PACKAGE_STR(EIGEN_WORLD_VERSION) "." DCA_PACKAGE_STR(             \
      EIGEN_MAJOR_VERSION) "." DCA_PACKAGE_STR(EIGEN_MINOR_VERSION) " msgpack-" MSGPACK_VERSION " " DCA_ABI_COMPILER

namespace dca {

/// A package's entry point's answer (plain C data: readable whatever the dca it was built against).
struct PackageEntry {
  const char* name;     ///< the package's name (DCA_PACKAGE_NAME)
  const char* version;  ///< the dca version it was built against
  const char* abi;      ///< the DCA_ABI_STAMP it was built with
  void (*add_types)(Registry& into);  ///< adds its types (throws std::invalid_argument for a bad manifest)
};

namespace package_detail {
/// One registered type of a package: a link of the package's own list.
struct Link {
  void (*add)(Registry&);
  Link* next;
};
/// Adds T to a registry.
template <class T>
void add(Registry& r) {
  r.add(T::Describe(), [](const ControllerContext& c) { return std::make_unique<T>(c); });
}
}  // namespace package_detail

}  // namespace dca

/// The name of a package's entry point, found with dlsym: `const dca::PackageEntry* dca_package_entry_v1()`.
#define DCA_PACKAGE_ENTRY_SYMBOL "dca_package_entry_v1"

#ifdef DCA_PACKAGE_NAME
extern "C" {
/// The package's list of types (defined by its entry point; hidden, so each package has its own).
__attribute__((visibility("hidden"))) extern dca::package_detail::Link* dca_package_links;
}

namespace {
// Links one type into the package's list at static-initialisation time (nothing of dca is called).
struct DcaPackageLinker {
  explicit DcaPackageLinker(dca::package_detail::Link& l) {
    l.next = dca_package_links;
    dca_package_links = &l;
  }
};
}  // namespace

/// Registers the controller class T (in a package: see the header comment).
#define DCA_REGISTER_CONTROLLER(T)                                                                   \
  static ::dca::package_detail::Link dca_package_link_##T{&::dca::package_detail::add<T>, nullptr}; \
  static const DcaPackageLinker dca_register_controller_##T{dca_package_link_##T}
#endif
