// The daemon's package store (host/package_store.h): versions installed and rolled back on disk, refusals, the
// requests on a daemon's channel, and the search path its children inherit.
#include "host/package_store.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "host/daemon.h"
#include "tests/support/channel_pair.h"
#include "tests/support/temp_dir.h"

namespace {

using namespace std::chrono_literals;
using namespace dca::test;
using dca::PackageStore;

// A fake package file: an ELF header, then `tag` (a different tag is another version).
std::string elf(const std::string& tag) { return std::string("\x7f" "ELF", 4) + "\x02\x01\x01 " + tag; }

std::string read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

bool exists(const std::string& p) { return std::filesystem::exists(p); }

TEST(PackageVersion, IsTheFirst16HexDigitsOfTheSha256) {
  // SHA-256("abc") = ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad
  EXPECT_EQ(dca::package_version("abc"), "ba7816bf8f01cfea");
  EXPECT_EQ(dca::package_file_version("/nonexistent/x.dca.so"), "");
}

TEST(PackageStore, InstallKeepsTheReplacedVersionAndRollbackSwapsThem) {
  TempDir tmp("pkgstore");
  PackageStore s("h1", tmp.path() + "/packages", "off");
  std::string error;
  const auto v1 = s.install("lab", elf("one"), &error);
  ASSERT_TRUE(v1) << error;
  EXPECT_EQ(v1->version, dca::package_version(elf("one")));
  EXPECT_EQ(v1->previous, "") << "none was installed before";
  const std::string cur = tmp.path() + "/packages/current/lab.dca.so";
  const std::string prev = tmp.path() + "/packages/previous/lab.dca.so";
  EXPECT_EQ(read(cur), elf("one"));
  EXPECT_FALSE(exists(prev));
  struct stat st{};
  ASSERT_EQ(::stat(cur.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0644u) << "the loader refuses a group- or world-writable package";
  ASSERT_EQ(::stat((tmp.path() + "/packages/current").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0755u);

  const auto v2 = s.install("lab", elf("two"), &error);
  ASSERT_TRUE(v2) << error;
  EXPECT_EQ(v2->previous, v1->version);
  EXPECT_EQ(read(cur), elf("two"));
  EXPECT_EQ(read(prev), elf("one"));
  EXPECT_FALSE(exists(cur + ".tmp"));

  const auto again = s.install("lab", elf("two"), &error);
  ASSERT_TRUE(again) << error;
  EXPECT_TRUE(again->unchanged);
  EXPECT_EQ(read(prev), elf("one")) << "the same file again keeps the previous";

  const auto back = s.rollback("lab", &error);
  ASSERT_TRUE(back) << error;
  EXPECT_EQ(back->version, v1->version);
  EXPECT_EQ(back->previous, v2->version);
  EXPECT_EQ(read(cur), elf("one"));
  EXPECT_EQ(read(prev), elf("two"));
  const auto forth = s.rollback("lab", &error);
  ASSERT_TRUE(forth) << error;
  EXPECT_EQ(read(cur), elf("two")) << "a second rollback undoes the first";
}

TEST(PackageStore, RollingBackTheFirstInstallLeavesNoneInstalled) {
  TempDir tmp("pkgstore");
  PackageStore s("h1", tmp.path() + "/packages", "off");
  std::string error;
  ASSERT_TRUE(s.install("lab", elf("one"), &error)) << error;
  const auto back = s.rollback("lab", &error);
  ASSERT_TRUE(back) << error;
  EXPECT_EQ(back->version, "");
  EXPECT_EQ(back->previous, dca::package_version(elf("one")));
  EXPECT_FALSE(exists(tmp.path() + "/packages/current/lab.dca.so")) << "the search path's file is loaded again";
  // a new install after that replaces nothing: the bad one is forgotten
  const auto v = s.install("lab", elf("three"), &error);
  ASSERT_TRUE(v) << error;
  EXPECT_EQ(v->previous, "");
  EXPECT_FALSE(exists(tmp.path() + "/packages/previous/lab.dca.so"));
}

TEST(PackageStore, RefusesNamesThatAreNoWordsFilesThatAreNoLibrariesAndEverythingWithoutAStore) {
  TempDir tmp("pkgstore");
  PackageStore s("h1", tmp.path() + "/packages", "off");
  std::string error;
  EXPECT_FALSE(s.install("../etc/x", elf("one"), &error));
  EXPECT_NE(error.find("package_install of '../etc/x' on host h1: a package name is a word"), std::string::npos)
      << error;
  EXPECT_FALSE(s.install("lab", "#!/bin/sh\nrm -rf /", &error));
  EXPECT_NE(error.find("not a shared library (no ELF header in its 18 bytes)"), std::string::npos) << error;
  EXPECT_FALSE(s.rollback("lab", &error));
  EXPECT_NE(error.find("no version of it was installed here"), std::string::npos) << error;
  EXPECT_FALSE(exists(tmp.path() + "/packages/current/lab.dca.so"));

  PackageStore none("h2", "", "no package store on host h2 (its daemon runs without a state directory)");
  EXPECT_FALSE(none.install("lab", elf("one"), &error));
  EXPECT_NE(error.find("no package store on host h2"), std::string::npos) << error;
}

// Through a daemon's channel: install, status (what a node would load), rollback; its children then search
// the store first.
TEST(PackageStore, ADaemonInstallsReportsAndRollsBackAndItsChildrenSearchTheStoreFirst) {
  TempDir tmp("pkgstore");
  ::unsetenv("DCA_CONTROLLER_PATH");
  dca::Loop loop;
  dca::DaemonOptions o;
  o.host = "h1";
  o.key = kKey;
  o.state_dir = tmp.path() + "/state";
  o.allow.allow("/bin/sh");
  dca::Daemon d(loop.io(), o);
  std::string error;
  ASSERT_TRUE(d.start(&error)) << error;
  Channel::Ptr ch;
  Channel::connect(loop.io(), d.address(), ChannelOptions{kKey}, [&](Channel::Ptr c, const std::string&) { ch = c; });
  ASSERT_TRUE(loop.run_until([&] { return ch != nullptr; }, 20s));
  std::vector<Message> events;
  ch->on_message([&](const Message& m) { events.push_back(m); });
  const auto call = [&](const std::string& type, Value payload) {
    Response got;
    bool done = false;
    ch->request(Message{type, 0, std::move(payload)}, 10s, [&](Response r) {
      got = std::move(r);
      done = true;
    });
    EXPECT_TRUE(loop.run_until([&] { return done; }, 15s));
    return got;
  };
  // the system's own packages/ folder holds version one
  const std::string sys = tmp.path() + "/sys";
  std::filesystem::create_directories(sys + "/packages");
  ::chmod(sys.c_str(), 0755);
  ::chmod((sys + "/packages").c_str(), 0755);
  std::ofstream(sys + "/packages/lab.dca.so", std::ios::binary) << elf("one");
  auto r = call("package_status", Value::map().set("name", "lab").set("system_dir", sys));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["loads"]["version"].as_string(), dca::package_version(elf("one")));
  EXPECT_EQ(r.message.payload["packages"].as_array().size(), 0u);

  r = call("package_install", Value::map().set("name", "lab").set("data", elf("two")));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["version"].as_string(), dca::package_version(elf("two")));
  EXPECT_EQ(r.message.payload["host"].as_string(), "h1");
  r = call("package_status", Value::map().set("name", "lab").set("system_dir", sys));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["loads"]["version"].as_string(), dca::package_version(elf("two")));
  EXPECT_EQ(r.message.payload["loads"]["file"].as_string(), tmp.path() + "/state/packages/current/lab.dca.so");
  ASSERT_EQ(r.message.payload["packages"].as_array().size(), 1u);
  EXPECT_EQ(r.message.payload["packages"].as_array()[0]["version"].as_string(), dca::package_version(elf("two")));

  // a child started now has the store first on its search path
  r = call("spawn", Value::map().set("argv", Value::Array{"/bin/sh", "-c", "echo \"path=$DCA_CONTROLLER_PATH\" >&2"}));
  ASSERT_TRUE(r.ok()) << r.error;
  ASSERT_TRUE(loop.run_until([&] {
    for (const auto& e : events) if (e.type == "exit") return true;
    return false;
  }, 20s));
  std::string said;
  for (const auto& e : events)
    if (e.type == "output") said += e.payload["line"].as_string();
  EXPECT_EQ(said, "path=" + tmp.path() + "/state/packages/current");

  r = call("package_rollback", Value::map().set("name", "lab"));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["version"].as_string(), "");
  r = call("package_status", Value::map().set("name", "lab").set("system_dir", sys));
  EXPECT_EQ(r.message.payload["loads"]["version"].as_string(), dca::package_version(elf("one")));

  r = call("package_install", Value::map().set("name", "lab").set("data", 42));
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.error, "package_install on host h1: data must be the package file's bytes");
  d.stop();
}

// The store outlives its daemon: a daemon started again on the same state folder searches it first at once.
TEST(PackageStore, AStoreThatHoldsAPackageIsOnTheSearchPathFromTheStart) {
  TempDir tmp("pkgstore");
  std::string error;
  {
    PackageStore s("h1", tmp.path() + "/packages", "off");
    ASSERT_TRUE(s.install("lab", elf("one"), &error)) << error;
  }
  ::setenv("DCA_CONTROLLER_PATH", "/opt/lab", 1);
  PackageStore again("h1", tmp.path() + "/packages", "off");
  again.start();
  EXPECT_STREQ(std::getenv("DCA_CONTROLLER_PATH"), (tmp.path() + "/packages/current:/opt/lab").c_str());
  TempDir empty("pkgstore");
  ::setenv("DCA_CONTROLLER_PATH", "/opt/lab", 1);
  PackageStore none("h1", empty.path() + "/packages", "off");
  none.start();
  EXPECT_STREQ(std::getenv("DCA_CONTROLLER_PATH"), "/opt/lab") << "an empty store changes nothing";
  ::unsetenv("DCA_CONTROLLER_PATH");
}

}  // namespace
