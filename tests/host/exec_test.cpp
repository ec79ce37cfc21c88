#include "host/exec.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "host/loop.h"

namespace {

using namespace std::chrono_literals;
using dca::AllowList;
using dca::Executer;
using dca::ExitStatus;

// The process group of `pid` from /proc, or -1 when the process does not exist (reaped); *state gets its state
// letter (Z for a zombie).
int pgrp_of(pid_t pid, char* state = nullptr) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(f, line)) return -1;
  const auto close = line.rfind(')');
  std::istringstream rest(line.substr(close + 2));
  std::string st;
  int ppid = 0, pgrp = 0;
  rest >> st >> ppid >> pgrp;
  if (state != nullptr) *state = st.empty() ? '?' : st[0];
  return pgrp;
}

// Every live process (zombies excluded: a killed grandchild is an orphan that init reaps) in group `pgrp`.
std::vector<pid_t> members_of_group(pid_t pgrp) {
  std::vector<pid_t> out;
  for (const auto& e : std::filesystem::directory_iterator("/proc")) {
    const std::string n = e.path().filename();
    if (n.find_first_not_of("0123456789") != std::string::npos) continue;
    const pid_t pid = std::stoi(n);
    char state = '?';
    if (pgrp_of(pid, &state) == pgrp && state != 'Z') out.push_back(pid);
  }
  return out;
}

class ExecTest : public ::testing::Test {
 protected:
  ExecTest() {
    allow_.allow("/bin/sh");
    allow_.allow("/bin/sleep");
  }
  // Runs argv to its end; returns how it ended.
  ExitStatus run(Executer& ex, const std::vector<std::string>& argv) {
    ExitStatus got;
    bool done = false;
    std::string error;
    auto child = ex.spawn(argv, [&](Executer::ChildId, const ExitStatus& s) { got = s, done = true; }, &error);
    EXPECT_TRUE(child) << error;
    if (!child) return got;
    EXPECT_TRUE(loop_.run_until([&] { return done; }, 20s));
    EXPECT_EQ(got.pid, child->pid);
    return got;
  }
  dca::Loop loop_;
  AllowList allow_;
};

TEST_F(ExecTest, ReportsTheExitCode) {
  Executer ex(loop_.io(), allow_);
  const auto s = run(ex, {"/bin/sh", "-c", "exit 3"});
  EXPECT_TRUE(s.exited);
  EXPECT_EQ(s.code, 3);
  EXPECT_EQ(s.str(), "exit code 3");
  EXPECT_EQ(ex.running(), 0u);
}

// With on_stderr, the child's stderr comes line by line, every line before its exit: an empty line, a line
// longer than kMaxLine in pieces, the unended last one; its stdout stays the parent's.
TEST_F(ExecTest, StderrComesLineByLineBeforeTheExit) {
  Executer ex(loop_.io(), allow_);
  std::vector<std::string> lines;
  bool done = false;
  std::string error;
  const std::string script = "echo out; printf 'one\\n\\ntwo\\n' >&2; head -c 5000 /dev/zero | tr '\\0' x >&2; "
                             "printf '\\nlast' >&2; exit 4";
  auto child = ex.spawn(
      {"/bin/sh", "-c", script},
      [&](Executer::ChildId, const ExitStatus& s) {
        lines.push_back("exit " + std::to_string(s.code));
        done = true;
      },
      &error, [&](Executer::ChildId, const std::string& line) { lines.push_back(line); });
  ASSERT_TRUE(child) << error;
  ASSERT_TRUE(loop_.run_until([&] { return done; }, 20s));
  const std::vector<std::string> want = {"one", "", "two", std::string(Executer::kMaxLine, 'x'),
                                         std::string(5000 - Executer::kMaxLine, 'x'), "last", "exit 4"};
  EXPECT_EQ(lines, want);
}

// A child that writes lines as fast as it can: every one is read, none is lost in the pipe.
TEST_F(ExecTest, EveryLineOfAFloodIsRead) {
  Executer ex(loop_.io(), allow_);
  std::size_t n = 0;
  bool done = false;
  std::string error;
  auto child = ex.spawn(
      {"/bin/sh", "-c", "i=0; while [ $i -lt 20000 ]; do echo \"line $i\" >&2; i=$((i+1)); done"},
      [&](Executer::ChildId, const ExitStatus&) { done = true; }, &error,
      [&](Executer::ChildId, const std::string&) { ++n; });
  ASSERT_TRUE(child) << error;
  ASSERT_TRUE(loop_.run_until([&] { return done; }, 60s));
  EXPECT_EQ(n, 20000u);
}

TEST_F(ExecTest, ReportsTheSignalByName) {
  Executer ex(loop_.io(), allow_);
  const auto s = run(ex, {"/bin/sh", "-c", "ulimit -c 0; kill -SEGV $$"});
  EXPECT_FALSE(s.exited);
  EXPECT_EQ(s.signal, SIGSEGV);
  EXPECT_EQ(s.signal_name(), "SIGSEGV");
  EXPECT_EQ(s.str(), "killed by SIGSEGV");
}

TEST_F(ExecTest, KillsOnRequest) {
  Executer ex(loop_.io(), allow_);
  ExitStatus got;
  bool done = false;
  std::string error;
  auto child = ex.spawn({"/bin/sleep", "100"}, [&](Executer::ChildId, const ExitStatus& s) { got = s, done = true; },
                        &error);
  ASSERT_TRUE(child) << error;
  EXPECT_EQ(pgrp_of(child->pid), child->pid) << "the child leads its own process group";
  ASSERT_TRUE(ex.kill(child->id, SIGKILL, &error)) << error;
  ASSERT_TRUE(loop_.run_until([&] { return done; }, 20s));
  EXPECT_EQ(got.signal_name(), "SIGKILL");
  EXPECT_EQ(pgrp_of(child->pid), -1) << "reaped: no zombie";
  EXPECT_FALSE(ex.kill(child->id, SIGKILL, &error));
  EXPECT_NE(error.find("no running child"), std::string::npos) << error;
}

TEST_F(ExecTest, RefusesWhatIsNotAllowed) {
  Executer ex(loop_.io(), AllowList::defaults());
  std::string error;
  EXPECT_FALSE(ex.spawn({"/bin/sh", "-c", "exit 0"}, {}, &error));
  EXPECT_NE(error.find("not allowed: '/bin/sh' is not on this daemon's allow-list"), std::string::npos) << error;
  EXPECT_FALSE(ex.spawn({"dca", "lua", "x.lua"}, {}, &error));
  EXPECT_NE(error.find("allows only some subcommands"), std::string::npos) << error;
  EXPECT_FALSE(ex.spawn({"sh", "-c", "true"}, {}, &error));
  EXPECT_NE(error.find("absolute path"), std::string::npos) << error;
  EXPECT_FALSE(ex.spawn({}, {}, &error));
  // The default allows dca's own node, supervise and sim ("dca" is this executable: here the test binary).
  EXPECT_TRUE(AllowList::defaults().resolve({"dca", "node"}, &error)) << error;
  EXPECT_TRUE(AllowList::defaults().resolve({"/proc/self/exe", "sim"}, &error)) << error;
  EXPECT_FALSE(AllowList::defaults().resolve({"dca"}, &error));
}

TEST_F(ExecTest, ANodeLoadsPackagesByNameOnly) {
  // a controller package is a name on the node's own search path, never a path (controllers/packages.h)
  std::string error;
  const auto allow = AllowList::defaults();
  EXPECT_TRUE(allow.resolve({"dca", "node", "--package", "door", "--system-dir", "/a/b", "--", "x"}, &error)) << error;
  EXPECT_FALSE(allow.resolve({"dca", "node", "--package", "../evil"}, &error));
  EXPECT_NE(error.find("not allowed: --package '../evil' is not a package name"), std::string::npos) << error;
  EXPECT_FALSE(allow.resolve({"dca", "node", "--package", "/tmp/evil.so"}, &error));
  EXPECT_FALSE(allow.resolve({"dca", "node", "--system-dir", "rel"}, &error));
  EXPECT_NE(error.find("--system-dir 'rel' is not absolute"), std::string::npos) << error;
  // after "--" come the controller's own arguments
  EXPECT_TRUE(allow.resolve({"dca", "node", "--", "--package", "../x"}, &error)) << error;
  // read in option/value pairs as `dca node` reads them: a "--" given as a value ends nothing
  EXPECT_FALSE(allow.resolve({"dca", "node", "--name", "--", "--system-dir", "rel"}, &error));
  EXPECT_NE(error.find("--system-dir 'rel' is not absolute"), std::string::npos) << error;
  EXPECT_FALSE(allow.resolve({"dca", "node", "--type", "T", "--name", "--", "--package", "../evil"}, &error));
  EXPECT_TRUE(allow.resolve({"dca", "node", "--type", "T", "--", "--system-dir", "rel"}, &error)) << error;
}

TEST_F(ExecTest, ArgvIsPassedAsIsNeverThroughAShell) {
  Executer ex(loop_.io(), allow_);
  // "$1" is a literal argument: if a shell parsed the argv, `; exit 9` would run.
  const auto s = run(ex, {"/bin/sh", "-c", "test \"$1\" = 'a b; exit 9' && exit 4", "sh", "a b; exit 9"});
  EXPECT_TRUE(s.exited);
  EXPECT_EQ(s.code, 4);
}

TEST_F(ExecTest, ChildInheritsNoDescriptor) {
  const int fd = ::open("/dev/null", O_RDONLY);  // deliberately without O_CLOEXEC
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::dup2(fd, 100), 100);
  Executer ex(loop_.io(), allow_);
  const auto s = run(ex, {"/bin/sh", "-c", "test -e /proc/self/fd/100 && exit 1; exit 0"});
  ::close(100);
  ::close(fd);
  EXPECT_TRUE(s.exited);
  EXPECT_EQ(s.code, 0) << "descriptor 100 leaked into the child";
}

TEST_F(ExecTest, StopLeavesNoChildNorGrandchild) {
  Executer ex(loop_.io(), allow_);
  std::string error;
  int callbacks = 0;
  // A child that ignores SIGTERM and has a grandchild in its group.
  auto stubborn = ex.spawn({"/bin/sh", "-c", "trap '' TERM; sleep 100 & wait"},
                           [&](Executer::ChildId, const ExitStatus&) { ++callbacks; }, &error);
  ASSERT_TRUE(stubborn) << error;
  auto plain = ex.spawn({"/bin/sleep", "100"}, [&](Executer::ChildId, const ExitStatus&) { ++callbacks; }, &error);
  ASSERT_TRUE(plain) << error;
  // Wait until the grandchild exists: /proc polled each millisecond, bounded (no loop event announces it, so
  // run_until would only look again at its deadline).
  for (int i = 0; i < 20000 && members_of_group(stubborn->pid).size() < 2; ++i) ::usleep(1000);
  ASSERT_GE(members_of_group(stubborn->pid).size(), 2u);
  ex.stop_all(100ms);
  EXPECT_EQ(ex.running(), 0u);
  // The children are reaped by stop_all; the grandchild got SIGKILL, and the kernel takes a moment to end it:
  // wait for that (bounded).
  for (int i = 0; i < 5000 && !members_of_group(stubborn->pid).empty(); ++i) ::usleep(1000);
  EXPECT_TRUE(members_of_group(stubborn->pid).empty()) << "no process left in the stubborn child's group";
  EXPECT_TRUE(members_of_group(plain->pid).empty());
  EXPECT_EQ(pgrp_of(stubborn->pid), -1);
  EXPECT_EQ(callbacks, 0) << "stop_all does not call on_exit";
  EXPECT_FALSE(ex.spawn({"/bin/sleep", "1"}, {}, &error));
  EXPECT_EQ(error, "the executer is stopping");
}

TEST_F(ExecTest, DestructionStopsChildren) {
  pid_t pid = 0;
  {
    Executer ex(loop_.io(), allow_);
    std::string error;
    auto c = ex.spawn({"/bin/sleep", "100"}, {}, &error);
    ASSERT_TRUE(c) << error;
    pid = c->pid;
  }
  EXPECT_EQ(pgrp_of(pid), -1);
}

TEST(SignalNameTest, NamesAndNumbers) {
  EXPECT_EQ(dca::signal_name(SIGSEGV), "SIGSEGV");
  EXPECT_EQ(dca::signal_name(SIGKILL), "SIGKILL");
  EXPECT_EQ(dca::signal_number("SIGKILL"), SIGKILL);
  EXPECT_EQ(dca::signal_number("term"), SIGTERM);
  EXPECT_EQ(dca::signal_number("9"), 9);
  EXPECT_EQ(dca::signal_number("NOPE"), 0);
}

}  // namespace
