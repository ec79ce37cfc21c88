#pragma once
// Test support: a fresh temporary directory, removed with everything in it when the TempDir goes.
#include <stdlib.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace dca::test {

/// <temp>/dca_<prefix>_XXXXXX, made by mkdtemp (path() is "" when it could not be made).
class TempDir {
 public:
  explicit TempDir(const std::string& prefix) {
    std::string tmpl = (std::filesystem::temp_directory_path() / ("dca_" + prefix + "_XXXXXX")).string();
    if (::mkdtemp(tmpl.data()) != nullptr) path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace dca::test
