#pragma once
// A daemon's store of controller package versions (docs/deploy.md, "Rolling upgrade of a package"): the package
// files a rolling upgrade installed on this host, each the version its nodes load now, and the one it replaced.
//
//   <state dir>/packages/current/NAME.dca.so    what a `dca node --package NAME` started by this daemon loads:
//                                                the daemon puts this folder first on its DCA_CONTROLLER_PATH
//                                                (inherited by every child) once it holds a package
//   <state dir>/packages/previous/NAME.dca.so   the version it replaced, kept for a rollback
//
// A version is the first 16 hex digits of the file's SHA-256. Requests (any authenticated daemon channel):
//   package_install {name, data}     -> ok {name, version, previous, unchanged, host}  `data`: the file's bytes
//                                       (an ELF shared object); written beside, then renamed over current (a node
//                                       starting meanwhile loads the old or the new file, never half of one); the
//                                       file it replaced becomes previous. previous "" : none was installed here
//                                       (the search path's file is loaded again after a rollback)
//   package_rollback {name}          -> ok {name, version, previous, host}  current and previous swapped
//                                       (version "" : none installed now); a second rollback undoes the first
//   package_status {name?, system_dir?} -> ok {host, dir, packages = [{name, version, previous}],
//                                       loads = {file, version}}  `loads`: the file a node of this host would
//                                       load for NAME with --system-dir system_dir, and its version
// Errors name the host, the package and the file. Nothing in a request is run: the bytes are only written.
#include <optional>
#include <string>
#include <string_view>

#include "host/net/channel.h"

namespace dca {

/// The first 16 hex digits of the SHA-256 of `bytes`: a package version.
std::string package_version(std::string_view bytes);
/// The version of the file at `path`, "" when it cannot be read.
std::string package_file_version(const std::string& path);

class PackageStore {
 public:
  /// `dir` "" : no store; every request is answered with the error `off`.
  PackageStore(std::string host, std::string dir, std::string off);

  /// Puts <dir>/current first on this process's DCA_CONTROLLER_PATH when it holds a package.
  void start();
  /// Answers a package_* request; false for any other type.
  bool handle(const Channel::Ptr& ch, const wire::Message& m);

  struct Versions {
    std::string version, previous;
    bool unchanged = false;
  };
  /// Installs `data` as package `name`. nullopt with *error when refused or not written.
  std::optional<Versions> install(const std::string& name, std::string_view data, std::string* error);
  /// Swaps current and previous of `name`. nullopt with *error when neither exists.
  std::optional<Versions> rollback(const std::string& name, std::string* error);

  const std::string& dir() const { return dir_; }

 private:
  std::string current(const std::string& name) const;
  std::string previous(const std::string& name) const;
  bool on_path();
  wire::Value status(const wire::Value& payload) const;

  std::string host_, dir_, off_;
  bool on_path_ = false;
};

}  // namespace dca
