#pragma once
// The controller registry: type name -> manifest and factory. `dca types` lists it; `core.types()` gives it to
// Lua (dca check); the node creates its controller from it.
//
// Register a type in its .cpp with DCA_REGISTER_CONTROLLER(T): T needs `static Manifest Describe()` and a
// constructor `T(const ControllerContext&)`. The controllers library is linked whole-archive, so a registration
// in any .cpp below controllers/ is never dropped by the linker. In a controller package (compiled with
// DCA_PACKAGE_NAME, see dca/package.h) the same macro only links the type into the package's own list,
// touching nothing of dca's; the loader adds the list to the registry once the package's ABI stamp matched.
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <dca/controller.h>

namespace dca {

/// Every controller type of the process.
class Registry {
 public:
  /// Creates an instance from its context (ctx.manifest is filled in by create()).
  using Factory = std::function<std::unique_ptr<Controller>(const ControllerContext&)>;

  /// The process's registry (filled at static-initialisation time).
  static Registry& global();

  /// Adds a type. Throws std::invalid_argument if the name is taken or the manifest repeats a port name.
  void add(Manifest m, Factory f);
  /// The manifest of `type`, or nullptr. `type` is a type's name ("PD"), or qualified by its package ("lab.PD");
  /// a name two packages define is nullptr unless qualified (ambiguous() says so).
  const Manifest* manifest(std::string_view type) const;
  /// "type 'PD' is defined by packages lab and other: write lab.PD or other.PD" when `type` names the types of
  /// several packages; "" otherwise.
  std::string ambiguous(std::string_view type) const;
  /// Every manifest, sorted by type name, then package.
  std::vector<const Manifest*> all() const;
  /// A new instance of `type` (a name, or package.name). Throws std::invalid_argument for an unknown type (listing
  /// the known ones), a name several packages define (ambiguous()), or a bad parameter.
  std::unique_ptr<Controller> create(std::string_view type, ControllerContext ctx) const;
  /// As create(), except that a constructor that throws anything but std::invalid_argument (a bad parameter, which
  /// is passed on: the node's start fails naming it) gives a stand-in: a controller with the type's ports whose
  /// configure() and start() fail with "<Type> <name>: its constructor failed: <what>", so that the leaf starts and
  /// connects like any other and ends ABORTED with that reason when it runs (the node's factory, app/cmd_node.cpp).
  std::unique_ptr<Controller> create_or_stand_in(std::string_view type, const ControllerContext& ctx) const;
  /// "unknown controller type 'X'; types are: A, B, ..."
  std::string unknown_type(std::string_view type) const;
  /// Moves every type of `staged` (a package's, filled by its entry point) in, each marked with `package`. All or
  /// nothing: false, with *error naming both, when a type's name is a built-in's. Two packages may define the
  /// same name: a system then names the one it means as package.name.
  bool adopt(Registry&& staged, const std::string& package, std::string* error);

 private:
  struct Entry {
    Manifest manifest;
    Factory factory;
  };
  /// The entries `type` names (a name, or package.name).
  std::vector<const Entry*> named(std::string_view type) const;
  std::vector<Entry> entries_;
};

/// Registers T at static-initialisation time (see DCA_REGISTER_CONTROLLER).
template <class T>
struct RegisterController {
  RegisterController() {
    Registry::global().add(T::Describe(), [](const ControllerContext& c) { return std::make_unique<T>(c); });
  }
};

}  // namespace dca

#ifndef DCA_PACKAGE_NAME
/// Registers the controller class T under the type name in its manifest.
#define DCA_REGISTER_CONTROLLER(T) static const ::dca::RegisterController<T> dca_register_controller_##T
#else
#include <dca/package.h>
#endif
