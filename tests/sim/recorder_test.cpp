// Recording a run as CSV, and `dca plot` drawing it with gnuplot.
#include "sim/recorder.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

namespace {

namespace fs = std::filesystem;

// Per process: ctest runs the cases of this file in parallel, each in its own process.
fs::path temp(const std::string& name) {
  return fs::temp_directory_path() / ("dca_recorder_test_" + std::to_string(::getpid()) + "_" + name);
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
  dca::sim::Recorder r(csv.string());
  dca::sim::Commands c;
  c.base_vel = {0.2, 0, 0};
  w.set_commands(c);
  r.record(w.sensors(), 0);
  for (int i = 1; i <= 500; ++i) {
    w.step();
    if (i % 10 == 0) r.record(w.sensors(), 0);
  }
  std::string error;
  EXPECT_TRUE(r.close(&error)) << error;
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
    dca::sim::Recorder r("/nonexistent/dir/run.csv");
    FAIL() << "opened an impossible path";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("/nonexistent/dir/run.csv: cannot write the recording", 0), 0u)
        << e.what();
  }
}

TEST(RecorderTest, PlotMakesAPng) {
  const fs::path csv = record_run(), png = temp("run.png");
  fs::remove(png);
  std::string error;
  EXPECT_TRUE(dca::sim::plot_csv(csv.string(), png.string(), &error)) << error;
  EXPECT_EQ(error, "");
  std::ifstream in(png, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  EXPECT_GT(fs::file_size(png), 10000u);
  EXPECT_FALSE(fs::exists(png.string() + ".gnuplot"));
}

TEST(RecorderTest, PlotRejectsWhatIsNotARecording) {
  const fs::path bad = temp("bad.csv");
  std::ofstream(bad) << "a,b\n1,2\n";
  std::string error;
  EXPECT_FALSE(dca::sim::plot_csv(bad.string(), temp("bad.png").string(), &error));
  EXPECT_EQ(error, bad.string() + ":1: not a dca sim recording (unexpected header)");
  EXPECT_FALSE(dca::sim::plot_csv("/nonexistent.csv", temp("x.png").string(), &error));
  EXPECT_EQ(error, "/nonexistent.csv: cannot open the recording");
}

TEST(RecorderTest, DcaSimRecordsAndDcaPlotDraws) {
  const fs::path csv = temp("cli.csv"), png = temp("cli.png"), script = temp("cli_script.txt");
  std::ofstream(script) << "0 base 0.1 0 0\n0.3 gripper close\n1 end\n";
  fs::remove(png);
  const std::string exe = DCA_TEST_EXE;
  const std::string out = temp("cli.out").string();
  ASSERT_EQ(std::system((exe + " sim --script " + script.string() + " --record " + csv.string() + " > " + out).c_str()), 0);
  const auto printed = lines(out);
  ASSERT_FALSE(printed.empty());
  EXPECT_EQ(printed.back(), "recorded " + csv.string());
  EXPECT_EQ(lines(csv).size(), 102u);  // header, t = 0, and every 10 ms to 1 s
  ASSERT_EQ(std::system((exe + " plot " + csv.string() + " -o " + png.string() + " > /dev/null").c_str()), 0);
  EXPECT_TRUE(fs::exists(png));
  EXPECT_NE(std::system((exe + " sim --bogus 2> /dev/null").c_str()), 0);
}

}  // namespace
