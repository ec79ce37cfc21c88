// Loading controller packages (controllers/packages.h) from the test packages of tests/packages/ and the door
// package: found by name on a search path, their types in the registry under their package, and every error a
// controller author meets named with the package, the file and what is wrong.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "controllers/packages.h"
#include "host/port.h"
#include <dca/registry.h>
#include <dca/package.h>
#include <dca/version.h>
#include "host/paths.h"
#include "tests/support/controller_fixture.h"
#include "tests/support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using dca::Registry;

std::string packages_dir() { return DCA_TEST_PACKAGES_DIR; }

// Loads `name` from the test packages' folder: the error ("" when it loaded).
std::string load_error(const std::string& name) {
  std::string error;
  const auto* p = dca::load_package(name, {packages_dir()}, &error);
  return p ? "" : error;
}

TEST(PackagesTest, LoadsAPackageByNameAndMarksItsTypes) {
  ASSERT_FALSE(packages_dir().empty());
  EXPECT_EQ(Registry::global().manifest("PkgScale"), nullptr);
  std::string error;
  const auto* p = dca::load_package("pkg_ok", {"/nonexistent", packages_dir()}, &error);
  ASSERT_NE(p, nullptr) << error;
  EXPECT_EQ(p->name, "pkg_ok");
  EXPECT_EQ(p->version, DCA_VERSION_STRING);
  EXPECT_EQ(p->types, std::vector<std::string>{"PkgScale"});
  const auto* m = Registry::global().manifest("PkgScale");
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->package, "pkg_ok");
  EXPECT_EQ(Registry::global().manifest("Gain")->package, "");
  // loaded once: the same package again
  EXPECT_EQ(dca::load_package("pkg_ok", {packages_dir()}, &error), p);
  EXPECT_EQ(dca::loaded_packages().size(), 1u);
}

TEST(PackagesTest, NotFoundNamesEveryPathSearched) {
  const std::string e = load_error("nosuch");
  EXPECT_NE(e.find("package 'nosuch' not found"), std::string::npos) << e;
  EXPECT_NE(e.find(packages_dir() + "/nosuch.dca.so"), std::string::npos) << e;
  EXPECT_NE(e.find("DCA_CONTROLLER_PATH"), std::string::npos) << e;
}

TEST(PackagesTest, ANameIsAWordNeverAPath) {
  for (const std::string bad : {"../pkg_ok", "/tmp/x", "a.b", "", "pkg ok"}) {
    const std::string e = load_error(bad);
    EXPECT_NE(e.find("is not a package name"), std::string::npos) << bad << ": " << e;
  }
}

TEST(PackagesTest, ALinkLeadingOutsideTheSearchPathIsNeverLoaded) {
  dca::test::TempDir dir("packages");
  fs::create_symlink(packages_dir() + "/pkg_ok.dca.so", dir.path() + "/evil.dca.so");
  std::string error;
  EXPECT_EQ(dca::load_package("evil", {dir.path()}, &error), nullptr);
  EXPECT_NE(error.find("leads outside " + dir.path()), std::string::npos) << error;
  EXPECT_EQ(Registry::global().manifest("PkgScale"), nullptr);
}

// Loading a package runs its code: its file and its folder must be writable by their owner only, and that owner
// this user or root.
TEST(PackagesTest, AFileOrFolderOthersMayWriteIsNeverLoaded) {
  dca::test::TempDir dir("packages");
  const std::string file = dir.path() + "/pkg_ok.dca.so";
  fs::copy_file(packages_dir() + "/pkg_ok.dca.so", file);
  fs::permissions(dir.path(), fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec);
  fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write | fs::perms::others_write);
  std::string error;
  EXPECT_FALSE(dca::find_package("pkg_ok", {dir.path()}, &error));
  EXPECT_EQ(error, "package 'pkg_ok': " + fs::canonical(file).string() + " is group- or world-writable (not loaded)");
  fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write);
  fs::permissions(dir.path(), fs::perms::owner_all | fs::perms::group_all);
  EXPECT_FALSE(dca::find_package("pkg_ok", {dir.path()}, &error));
  EXPECT_EQ(error, "package 'pkg_ok': " + fs::canonical(dir.path()).string() + " is group- or world-writable (not loaded)");
  fs::permissions(dir.path(), fs::perms::owner_all);
  EXPECT_TRUE(dca::find_package("pkg_ok", {dir.path()}, &error)) << error;
}

TEST(PackagesTest, TwoPackagesMayDefineOneNameWhichIsThenQualified) {
  ASSERT_EQ(load_error("pkg_ok"), "");
  ASSERT_EQ(load_error("pkg_twin"), "");
  const auto& reg = Registry::global();
  const std::string both =
      "type 'PkgScale' is defined by packages pkg_ok and pkg_twin: write pkg_ok.PkgScale or pkg_twin.PkgScale";
  EXPECT_EQ(reg.manifest("PkgScale"), nullptr);
  EXPECT_EQ(reg.ambiguous("PkgScale"), both);
  ASSERT_NE(reg.manifest("pkg_ok.PkgScale"), nullptr);
  EXPECT_EQ(reg.manifest("pkg_ok.PkgScale")->package, "pkg_ok");
  ASSERT_NE(reg.manifest("pkg_twin.PkgScale"), nullptr);
  EXPECT_EQ(reg.manifest("pkg_twin.PkgScale")->package, "pkg_twin");
  EXPECT_EQ(reg.manifest("nosuch.PkgScale"), nullptr);
  EXPECT_EQ(reg.ambiguous("Gain"), "");
  try {
    (void)reg.create("PkgScale", {"/a", "h1", {}, nullptr, nullptr});
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), both);
  }
  const std::string b = load_error("pkg_builtin");  // a built-in's name stays dca's
  EXPECT_NE(b.find("type 'Gain' is defined by both dca (a built-in type) and package 'pkg_builtin'"), std::string::npos) << b;
}

TEST(PackagesTest, AMissingSymbolNamesTheLibraryAndTheSymbol) {
  const std::string e = load_error("pkg_missing");
  EXPECT_NE(e.find("package 'pkg_missing' (" + packages_dir() + "/pkg_missing.dca.so)"), std::string::npos) << e;
  EXPECT_NE(e.find("missing symbol 'dca::missing_for_tests(double)'"), std::string::npos) << e;
  EXPECT_EQ(e.find("dca-package-"), std::string::npos) << "the private copy is never named: " << e;
  EXPECT_EQ(Registry::global().manifest("PkgMissing"), nullptr);
}

TEST(PackagesTest, AnotherDcasPackageNamesBothVersions) {
  for (const std::string name : {"pkg_old", "pkg_old_missing"}) {  // loadable, and not even loadable
    const std::string e = load_error(name);
    EXPECT_NE(e.find("was built against dca 0.0.9; this is dca " DCA_VERSION_STRING
                     ": SDK headers sdk-0000000000000000 (package) vs sdk-" DCA_SDK_HASH " (this dca)"),
              std::string::npos) << e;
    EXPECT_NE(e.find("rebuild the package against this dca"), std::string::npos) << e;
  }
  EXPECT_EQ(Registry::global().manifest("PkgOld"), nullptr);
}

// The refusal names what differs, not two equal versions.
TEST(PackagesTest, ARefusalNamesWhatDiffersAndBothCompilers) {
  const std::string sdk = load_error("pkg_other_sdk");
  EXPECT_NE(sdk.find("was built against another dca " DCA_VERSION_STRING ": SDK headers sdk-0000000000000000 "
                     "(package) vs sdk-" DCA_SDK_HASH " (this dca) (built with "),
            std::string::npos) << sdk;
  EXPECT_EQ(sdk.find("standard library"), std::string::npos) << sdk;
  const std::string stdlib = load_error("pkg_other_stdlib");
  EXPECT_NE(stdlib.find(": standard library stdlib-libc++-14000 (package) vs stdlib-libstdc++-"), std::string::npos)
      << stdlib;
  EXPECT_NE(stdlib.find(", this dca with gcc-"), std::string::npos) << stdlib;
  EXPECT_EQ(dca::abi_differences(DCA_ABI_STAMP), "");
  EXPECT_EQ(Registry::global().manifest("PkgOtherSdk"), nullptr);
}

// GCC and Clang share the C++ ABI: only the standard library and the SDK must match (dca/package.h).
TEST(PackagesTest, AnotherCompilerWithTheSameStandardLibraryIsAccepted) {
  EXPECT_EQ(load_error("pkg_other_cc"), "");
  if (!fs::exists(packages_dir() + "/pkg_clang.dca.so")) GTEST_SKIP() << "no clang++: pkg_clang was not built";
  ASSERT_EQ(load_error("pkg_clang"), "");
  auto c = Registry::global().create("PkgClang", {"/c", "local", {"3"}, nullptr, nullptr});
  ASSERT_NE(c, nullptr);
  EXPECT_NE(c->ports().find_input("In"), nullptr);
  EXPECT_EQ(c->type(), "PkgClang");
}

TEST(PackagesTest, ALibraryWithoutTheEntryPointIsNoPackage) {
  const std::string e = load_error("pkg_none");
  EXPECT_NE(e.find("is not a dca controller package: it has no dca_package_entry_v1"), std::string::npos) << e;
}

TEST(PackagesTest, AFailedLoadMayBeTriedAgain) {
  EXPECT_NE(load_error("pkg_missing"), "");
  EXPECT_NE(load_error("pkg_missing"), "");
  EXPECT_TRUE(dca::loaded_packages().empty());
}

// Writes the bytes of `from` into the file `to` in place, as `cp from to` does: the same file (inode), truncated,
// then written.
void overwrite_in_place(const std::string& from, const std::string& to) {
  std::string bytes(fs::file_size(from), '\0');
  std::ifstream in(from, std::ios::binary);
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_FALSE(bytes.empty()) << from;
  struct stat before {}, after {};
  ASSERT_EQ(::stat(to.c_str(), &before), 0) << to;
  std::ofstream out(to, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  ASSERT_TRUE(out.good()) << to;
  ASSERT_EQ(::stat(to.c_str(), &after), 0) << to;
  ASSERT_EQ(after.st_ino, before.st_ino) << "the same file";
}

// The lines of /proc/self/maps that name `text`.
std::vector<std::string> mappings_of(const std::string& text) {
  std::ifstream maps("/proc/self/maps");
  std::vector<std::string> out;
  for (std::string line; std::getline(maps, line);)
    if (line.find(text) != std::string::npos) out.push_back(line);
  return out;
}

class PackagesRunTest : public dca::testing::ControllerFixture {};

// `cp new.so pkg_ok.dca.so` while pkg_ok is loaded: the file changes under the process (the same inode, truncated
// and written). The process runs a private copy of the file as it was at load (controllers/packages.cpp), so its
// instances are made and run, and loading again answers the loaded package: nothing crashes.
TEST_F(PackagesRunTest, AFileReplacedInPlaceLeavesTheLoadedCodeRunning) {
  dca::test::TempDir dir("packages");
  const std::string file = dir.path() + "/pkg_ok.dca.so";
  fs::copy_file(packages_dir() + "/pkg_ok.dca.so", file);
  std::string error;
  const auto* p = dca::load_package("pkg_ok", {dir.path()}, &error);
  ASSERT_NE(p, nullptr) << error;
  EXPECT_EQ(p->file, fs::canonical(file).string());  // the original named, never the copy
  overwrite_in_place(packages_dir() + "/variants/renamed/pkg_ok.dca.so", file);
  auto& c = make("PkgScale", {"3"}, "/scale");  // k = 3, a trigger on In
  auto& in = feed(dca::scalar_port("X"), "/scale", "In");
  ep.activate("s");
  ASSERT_EQ(started(c), "");
  in.write(2.0);
  EXPECT_DOUBLE_EQ(latest(c, "Out")[0], 6.0);  // the code loaded: its output is still Out
  EXPECT_EQ(dca::load_package("pkg_ok", {dir.path()}, &error), p) << error;
}

// The copy a package is loaded from lives in a folder of its own under $XDG_RUNTIME_DIR (else $TMPDIR, else /tmp),
// removed with the copy right after the load: the process maps a deleted file, and nothing is left behind.
TEST(PackagesTest, TheCopyLoadedIsGoneOnceLoaded) {
  dca::test::TempDir runtime("runtime");
  const char* old = std::getenv("XDG_RUNTIME_DIR");
  const std::string saved = old ? old : "";
  ::setenv("XDG_RUNTIME_DIR", runtime.path().c_str(), 1);
  const std::string e = load_error("pkg_ok");
  if (old) ::setenv("XDG_RUNTIME_DIR", saved.c_str(), 1);
  else ::unsetenv("XDG_RUNTIME_DIR");
  ASSERT_EQ(e, "");
  EXPECT_TRUE(fs::is_empty(runtime.path())) << "a copy or its folder was left in " << runtime.path();
  const auto maps = mappings_of(runtime.path() + "/");
  ASSERT_FALSE(maps.empty()) << "pkg_ok was not loaded from a copy under " << runtime.path();
  for (const auto& m : maps) {
    EXPECT_NE(m.find("/pkg_ok.dca.so (deleted)"), std::string::npos) << m;
  }
  EXPECT_TRUE(mappings_of(packages_dir() + "/pkg_ok.dca.so").empty()) << "the original file is mapped";
}

// What a process loaded against what it would load now: the file's identity (device, inode, size, modification
// time) at its load, and where the search path leads.
TEST(PackagesTest, APackageChangedOnDiskIsTold) {
  dca::test::TempDir dir("packages");
  const std::string file = dir.path() + "/pkg_ok.dca.so";
  fs::copy_file(packages_dir() + "/pkg_ok.dca.so", file);
  EXPECT_EQ(dca::package_changed("pkg_ok", {dir.path()}), "") << "not loaded: nothing to compare";
  std::string error;
  ASSERT_NE(dca::load_package("pkg_ok", {dir.path()}, &error), nullptr) << error;
  EXPECT_EQ(dca::package_changed("pkg_ok", {dir.path()}), "");
  overwrite_in_place(packages_dir() + "/variants/k3/pkg_ok.dca.so", file);
  const std::string real = fs::canonical(file).string();
  EXPECT_EQ(dca::package_changed("pkg_ok", {dir.path()}), real + " changed on disk since this process loaded it");
  EXPECT_EQ(dca::package_changed("pkg_ok", {packages_dir(), dir.path()}),
            packages_dir() + "/pkg_ok.dca.so would be loaded now, not " + real + " which this process loaded");
  fs::remove(file);
  EXPECT_NE(dca::package_changed("pkg_ok", {dir.path()}).find("package 'pkg_ok' not found"), std::string::npos);
}

TEST(PackagesTest, TheSearchPathIsTheVariableThePrefixThenTheSystemsFolder) {
  ::setenv("DCA_CONTROLLER_PATH", "/a:rel/b::/c", 1);
  const auto dirs = dca::controller_dirs("/sys/dir");
  ::unsetenv("DCA_CONTROLLER_PATH");
  ASSERT_EQ(dirs.size(), 5u);
  EXPECT_EQ(dirs[0], "/a");
  EXPECT_EQ(dirs[1], (fs::current_path() / "rel/b").string());
  EXPECT_EQ(dirs[2], "/c");
  EXPECT_EQ(dirs[3], (fs::path(dca::exe_dir()).parent_path() / "lib/dca/controllers").string());
  EXPECT_EQ(dirs[4], "/sys/dir/packages");
  std::vector<std::string> all{"pkg_builtin",   "pkg_init_throws", "pkg_missing",      "pkg_none",
                               "pkg_ok",        "pkg_old",         "pkg_old_missing",  "pkg_other_cc",
                               "pkg_other_sdk", "pkg_other_stdlib", "pkg_port_typo",   "pkg_positive",
                               "pkg_stderr",    "pkg_throws",      "pkg_twin"};
  if (fs::exists(packages_dir() + "/pkg_clang.dca.so")) all.insert(all.begin() + 1, "pkg_clang");
  EXPECT_EQ(dca::available_packages({packages_dir()}), all);
}

}  // namespace
