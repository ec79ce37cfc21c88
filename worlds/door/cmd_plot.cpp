// `dca plot FILE.mcap|FILE.csv [-o FILE.png]`: draws a recording of the door world (`dca sim --record`) with gnuplot.
#include <cstdio>
#include <span>
#include <string>

#include "app/subcommand.h"
#include "worlds/door/recording.h"

namespace {

constexpr const char* kUsage =
    "usage: dca plot FILE.mcap|FILE.csv [-o FILE.png]\n\n"
    "Draws a recording made by `dca sim --record FILE` (MCAP or CSV) to a PNG (default: FILE.png): the\n"
    "door and handle angles, the wrist force and the base's position against time, and the base's path.\n"
    "Needs gnuplot (scripts/setup installs it).";

int cmd_plot(std::span<char* const> args) {
  std::string csv, png;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string a = args[i];
    if (a == "-o" || a == "--output") {
      if (i + 1 >= args.size()) {
        std::fprintf(stderr, "dca plot: %s needs a file\n%s\n", a.c_str(), kUsage);
        return 2;
      }
      png = args[++i];
    } else if (csv.empty() && !a.empty() && a[0] != '-') {
      csv = a;
    } else {
      std::fprintf(stderr, "dca plot: unexpected argument '%s'\n%s\n", a.c_str(), kUsage);
      return 2;
    }
  }
  if (csv.empty()) {
    std::fprintf(stderr, "%s\n", kUsage);
    return 2;
  }
  if (png.empty()) {
    png = csv;
    if (png.size() > 4 && png.compare(png.size() - 4, 4, ".csv") == 0) png.resize(png.size() - 4);
    if (dca::sim::is_mcap(png)) png.resize(png.size() - 5);
    png += ".png";
  }
  std::string error;
  if (!dca::sim::plot_csv(csv, png, &error)) {
    std::fprintf(stderr, "dca plot: %s\n", error.c_str());
    return 1;
  }
  std::printf("%s\n", png.c_str());
  return 0;
}

}  // namespace

DCA_SUBCOMMAND("plot", "draw a recording of `dca sim --record` to a PNG (gnuplot)", kUsage, cmd_plot);
