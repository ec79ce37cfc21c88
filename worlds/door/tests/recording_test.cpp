// Recording a run as CSV and as MCAP, and `dca plot` drawing it with gnuplot.
#include "worlds/door/recording.h"

#include "host/codec/mcap.h"
#include "tests/support/temp_dir.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

namespace {

namespace fs = std::filesystem;

// In a folder of this process's own (ctest runs the cases of this file in parallel, each in its own process),
// removed with everything in it when the process ends.
fs::path temp(const std::string& name) {
  static const dca::test::TempDir dir("recorder_test");
  return fs::path(dir.path()) / name;
}

std::vector<std::string> lines(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

// A short recorded run: the base drives forward 0.5 s.
fs::path record_run() {
  const fs::path csv = temp("run.csv");
  dca::sim::World w(dca::sim::door_world());
  dca::sim::DoorRecording r(csv.string());
  dca::sim::Commands c;
  c.base_vel = {0.2, 0, 0};
  w.set_commands(c);
  r.record(w.sensors(), 0);
  for (int i = 1; i <= 500; ++i) {
    w.step();
    if (i % 10 == 0) r.record(w.sensors(), 0);
  }
  std::string error;
  EXPECT_TRUE(r.recorder().close(&error)) << error;
  return csv;
}

TEST(RecorderTest, WritesOneRowPerRecordWithTheDocumentedColumns) {
  const auto rows = lines(record_run());
  ASSERT_EQ(rows.size(), 52u);
  EXPECT_EQ(rows[0], dca::sim::csv_header());
  const auto count = [](const std::string& s) { return std::count(s.begin(), s.end(), ','); };
  EXPECT_EQ(count(rows[1]), count(rows[0]));
  std::istringstream last(rows.back());
  std::vector<double> v;
  for (std::string cell; std::getline(last, cell, ',');) v.push_back(std::stod(cell));
  ASSERT_EQ(v.size(), 22u);
  EXPECT_NEAR(v[0], 0.5, 1e-9);       // time
  EXPECT_NEAR(v[7], 0.1, 2e-3);       // base_x after 0.5 s at 0.2 m/s
  EXPECT_NEAR(v[16], 0.0, 1e-3);      // door_angle
  EXPECT_EQ(v[21], 0.0);              // phase
}

TEST(RecorderTest, UnwritableFileIsNamed) {
  try {
    dca::sim::DoorRecording r("/nonexistent/dir/run.csv");
    FAIL() << "opened an impossible path";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("/nonexistent/dir/run.csv: cannot write the recording", 0), 0u)
        << e.what();
  }
}

// A file over 1 GiB (sparse here: no disk) is refused by its size before a byte is read: a 3 GiB file took 14 s
// and 4.1 GiB of memory, then a wrong error.
TEST(RecorderTest, McapToCsvRefusesAFileOverOneGiBByItsSize) {
  const fs::path huge = temp("huge.mcap");
  { std::ofstream(huge) << "x"; }
  fs::resize_file(huge, (std::uintmax_t{3} << 30) + 1);
  std::string error;
  EXPECT_FALSE(dca::sim::mcap_to_csv(huge.string(), temp("huge.csv").string(), &error));
  EXPECT_EQ(error, huge.string() + ": 3221225473 bytes: dca reads recordings of at most 1 GiB");
  fs::remove(huge);
}

TEST(RecorderTest, DcaSimRecordsAndDcaPlotDraws) {
  const fs::path csv = temp("cli.csv"), png = temp("cli.png"), script = temp("cli_script.txt");
  std::ofstream(script) << "0 base 0.1 0 0\n0.3 gripper close\n1 end\n";
  fs::remove(png);
  const std::string exe = DCA_TEST_EXE;
  const std::string out = temp("cli.out").string();
  ASSERT_EQ(std::system((exe + " sim --world-opt script=" + script.string() + " --record " + csv.string() + " > " + out).c_str()), 0);
  const auto printed = lines(out);
  ASSERT_FALSE(printed.empty());
  EXPECT_EQ(printed.back(), "recorded " + csv.string() + ": 101 rows");
  EXPECT_EQ(lines(csv).size(), 102u);  // header, t = 0, and every 10 ms to 1 s
  ASSERT_EQ(std::system((exe + " plot " + csv.string() + " -o " + png.string() + " > /dev/null").c_str()), 0);
  EXPECT_TRUE(fs::exists(png));
  EXPECT_NE(std::system((exe + " sim --bogus 2> /dev/null").c_str()), 0);
}

}  // namespace

namespace {

std::vector<double> numbers(const std::string& row) {
  std::vector<double> v;
  std::stringstream in(row);
  for (std::string cell; std::getline(in, cell, ',');) v.push_back(std::stod(cell));
  return v;
}

// The messages (JSON text; with `at`, " at <log time>" after each) on the channel after the world's seven in
// the MCAP file `path`, which must be its last and be named `topic`.
std::vector<std::string> eighth_channel(const fs::path& path, const std::string& topic, bool at = false) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  dca::mcap::Contents contents;
  std::string error;
  EXPECT_TRUE(dca::mcap::read(bytes.str(), &contents, &error)) << error;
  EXPECT_EQ(contents.channels.size(), 8u);
  EXPECT_EQ(contents.channels.count(8) ? contents.channels.at(8).topic : "", topic);
  std::vector<std::string> out;
  for (const auto& m : contents.messages)
    if (m.channel == 8) out.push_back(m.data + (at ? " at " + std::to_string(m.log_time) : ""));
  return out;
}

// The same run recorded as CSV and as MCAP (with two notes): the MCAP file holds one JSON channel per signal
// group plus /dca/events, and converted back to CSV it gives the CSV's rows.
TEST(RecorderTest, McapHoldsTheCsvsRowsAndTheNotes) {
  const fs::path csv = temp("both.csv"), mcap = temp("both.mcap"), back = temp("back.csv");
  {
    dca::sim::World w(dca::sim::door_world());
    dca::sim::DoorRecording a(csv.string()), b(mcap.string());
    dca::sim::Commands c;
    c.base_vel = {0.2, 0, 0.1};
    w.set_commands(c);
    for (int i = 0; i <= 300; ++i) {
      if (i % 10 == 0) {
        a.record(w.sensors(), 2);
        b.record(w.sensors(), 2);
      }
      if (i == 100) b.recorder().note(w.time(), "main.a: running", "main.a", "running");
      if (i == 200) b.recorder().note(w.time(), "say \"hi\"\n\\", "", "");
      w.step();
    }
    std::string error;
    ASSERT_TRUE(b.recorder().close(&error)) << error;
    EXPECT_EQ(b.recorder().summary().find(mcap.string() + ": 219 messages on 8 channels (/world/arm 31,"), 0u) << b.recorder().summary();
  }
  const auto events = eighth_channel(mcap, "/dca/events");
  std::string error;
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0], R"({"line":"main.a: running","path":"main.a","state":"running"})");
  EXPECT_EQ(events[1], R"({"line":"say \"hi\"\u000a\\","path":"","state":""})");
  ASSERT_TRUE(dca::sim::mcap_to_csv(mcap.string(), back.string(), &error)) << error;
  const auto want = lines(csv), got = lines(back);
  ASSERT_EQ(got.size(), want.size());
  EXPECT_EQ(got[0], dca::sim::csv_header());
  for (size_t i = 1; i < want.size(); ++i) {
    const auto w = numbers(want[i]), g = numbers(got[i]);
    ASSERT_EQ(g.size(), w.size());
    for (size_t k = 0; k < w.size(); ++k) EXPECT_NEAR(g[k], w[k], 1e-4) << "row " << i << " column " << k;
  }
  fs::remove(csv);
  fs::remove(mcap);
  fs::remove(back);
}

// A line a process wrote to its stderr goes on a channel of its own, /dca/log: {"path", "line"}.
TEST(RecorderTest, McapKeepsTheProcessesLinesOnDcaLog) {
  const fs::path mcap = temp("log.mcap");
  {
    dca::sim::World w(dca::sim::door_world());
    dca::sim::DoorRecording r(mcap.string());
    r.record(w.sensors(), 0);
    r.recorder().log(0.25, "main.ctl.filt", "tau \"clamped\"");
    std::string error;
    ASSERT_TRUE(r.recorder().close(&error)) << error;
  }
  EXPECT_EQ(eighth_channel(mcap, "/dca/log", true), std::vector<std::string>{R"({"path":"main.ctl.filt","line":"tau \"clamped\""} at 250000000)"});
  fs::remove(mcap);
}

}  // namespace
