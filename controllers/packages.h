#pragma once
// Loading controller packages (dca/package.h) into the process's registry, by name, from the search path
// (host/paths.h: controller_dirs). What dca does with a package, not part of the SDK.
//
// A package `NAME` is the file `<dir>/NAME.dca.so` in the first directory of the search path that holds one. A
// name is a word ([A-Za-z_][A-Za-z0-9_]*), never a path, and the file found must resolve (symlinks followed)
// to a place inside its directory: a library outside the search path is never loaded. Loading is once per
// process and per name (a package stays loaded: its code may be running); a failed load may be tried again.
// The library loaded is a private copy of the file (docs/packages.md, "Rebuild and restart"): the file's bytes
// copied into a folder of its own (mode 0700) under $XDG_RUNTIME_DIR, else $TMPDIR, else /tmp, opened, then
// removed with its folder at once. So the file may be replaced, even in place (`cp new.so NAME.dca.so`), while
// the process runs its code, and nothing is left behind. Every check and message is about the file, never the copy.
// Errors name the package, the file and what is wrong: not found (every path searched), a type another package
// or a built-in defines (both named), a symbol the library needs and this dca lacks (the symbol), an ABI or
// version mismatch (both versions), a library that is no package.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace dca {

/// What a file was when it was read: package_changed compares it with the file on disk.
struct FileIdentity {
  std::uint64_t device = 0, inode = 0, size = 0;
  std::int64_t mtime_ns = 0;  ///< its last modification
  bool operator==(const FileIdentity&) const = default;
};

/// A package loaded into Registry::global().
struct LoadedPackage {
  std::string name;
  std::string file;     ///< the library loaded (resolved path of the file; the process runs a copy of it)
  FileIdentity identity;  ///< the file as it was copied
  std::string version;  ///< the dca version it was built against (this one's)
  std::vector<std::string> types;  ///< the types it defines, sorted
};

/// Whether `name` can name a package: [A-Za-z_][A-Za-z0-9_]*, at most 64 characters.
bool valid_package_name(std::string_view name);

/// The library of package `name` in `dirs` (see the header comment), or nullopt with *error naming every path
/// searched.
std::optional<std::string> find_package(const std::string& name, const std::vector<std::string>& dirs,
                                        std::string* error);

/// Finds package `name` in `dirs` and loads it (or returns it when already loaded): nullptr with *error.
const LoadedPackage* load_package(const std::string& name, const std::vector<std::string>& dirs, std::string* error);

/// Loads the library `file` as package `name` (no search: `find_package` already checked the place).
const LoadedPackage* load_package_file(const std::string& name, const std::string& file, std::string* error);

/// The names of the packages in `dirs` (files NAME.dca.so with a valid NAME), sorted, each once.
std::vector<std::string> available_packages(const std::vector<std::string>& dirs);

/// What differs between a package's ABI stamp (dca/package.h) and this dca's, by name ("SDK headers sdk-0 (package)
/// vs sdk-1 (this dca); standard library ..."), or "" when nothing compared does: the compiler is never compared.
std::string abi_differences(const std::string& package_abi);

/// Why package `name`, loaded in this process, is not what loading it from `dirs` would load now: "" when the file
/// found there is the one loaded, unchanged since (device, inode, size, modification time), or when `name` is not
/// loaded; else what differs, naming the file ("/p/pkg.dca.so changed on disk since this process loaded it").
std::string package_changed(const std::string& name, const std::vector<std::string>& dirs);

/// The packages loaded so far, in load order.
std::vector<const LoadedPackage*> loaded_packages();

}  // namespace dca
