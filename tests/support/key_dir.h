#pragma once
// Test and benchmark support: a temporary directory holding a fresh cluster key, as a daemon and its nodes
// need (`--key FILE`), removed with everything in it when the KeyDir goes.
#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

#include "host/net/auth.h"

namespace dca::test {

/// <temp>/dca-<prefix>-<pid>/ with a key file `key` in it.
class KeyDir {
 public:
  explicit KeyDir(const std::string& prefix)
      : dir(std::filesystem::temp_directory_path() / ("dca-" + prefix + "-" + std::to_string(::getpid()))),
        key_file((dir / "key").string()) {
    std::filesystem::create_directories(dir);
    if (auto k = auth::load_or_create_key(key_file, &error)) key = *k;
  }
  ~KeyDir() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  KeyDir(const KeyDir&) = delete;
  KeyDir& operator=(const KeyDir&) = delete;

  /// True when the key was made (else `error` says why).
  bool ok() const { return error.empty(); }

  std::filesystem::path dir;
  std::string key_file;
  auth::Key key;
  std::string error;
};

}  // namespace dca::test
