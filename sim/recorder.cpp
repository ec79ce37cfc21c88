#include "sim/recorder.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <sys/wait.h>

namespace dca::sim {

const char* csv_header() {
  return "time,q1,q2,q3,q4,q5,q6,base_x,base_y,base_yaw,fx,fy,fz,tx,ty,tz,door_angle,handle_angle,"
         "gripper_width,gripper_state,laser,phase";
}

Recorder::Recorder(const std::string& path) : path_(path) {
  f_ = std::fopen(path.c_str(), "w");
  if (!f_) throw std::runtime_error(path + ": cannot write the recording: " + std::strerror(errno));
  std::fprintf(f_, "%s\n", csv_header());
}

Recorder::~Recorder() {
  try {
    close();
  } catch (const std::exception&) {
  }
}

void Recorder::record(const Sensors& s, int phase) {
  if (!f_) return;
  std::fprintf(f_, "%.4f", s.time);
  for (double q : s.arm_q) std::fprintf(f_, ",%.6f", q);
  std::fprintf(f_, ",%.6f,%.6f,%.6f", s.base_pose.x, s.base_pose.y, s.base_pose.yaw);
  for (double w : s.wrench) std::fprintf(f_, ",%.4f", w);
  std::fprintf(f_, ",%.6f,%.6f,%.5f,%d,%.5f,%d\n", s.door_angle, s.handle_angle, s.gripper_width,
               static_cast<int>(s.gripper), s.laser_range, phase);
}

void Recorder::close() {
  if (!f_) return;
  std::FILE* f = f_;
  f_ = nullptr;
  const bool bad = std::ferror(f) != 0;
  if (std::fclose(f) != 0 || bad) throw std::runtime_error(path_ + ": error writing the recording");
}

namespace {

std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "''";
    else out += c;
  }
  return out + "'";
}

}  // namespace

std::string plot_csv(const std::string& csv, const std::string& png) {
  {
    std::ifstream in(csv);
    if (!in) return csv + ": cannot open the recording";
    std::string header;
    std::getline(in, header);
    if (header != csv_header()) return csv + ":1: not a dca sim recording (unexpected header)";
    std::string row;
    if (!std::getline(in, row)) return csv + ":2: the recording has no data";
  }
  const std::string script_path = png + ".gnuplot";
  {
    std::ofstream g(script_path);
    if (!g) return script_path + ": cannot write the gnuplot script";
    const std::string d = quote(csv);
    g << "set terminal pngcairo size 1400,1000 font ',10' noenhanced\n"
      << "set output " << quote(png) << "\n"
      << "set datafile separator ','\n"
      << "set key autotitle columnhead\n"
      << "set grid\n"
      << "set multiplot layout 2,2 title " << quote("dca sim: " + csv) << "\n"
      << "set title 'door and handle angles'\nset xlabel 'time (s)'\nset ylabel 'degrees'\n"
      << "plot " << d << " using 1:($17*180/pi) with lines lw 2 title 'door', '' using 1:($18*180/pi) with lines"
      << " lw 2 title 'handle'\n"
      << "set title 'wrist force (sensor frame)'\nset ylabel 'N'\n"
      << "plot " << d << " using 1:11 with lines title 'fx', '' using 1:12 with lines title 'fy', '' using 1:13"
      << " with lines title 'fz', '' using 1:(sqrt($11**2+$12**2+$13**2)) with lines lw 2 title '|f|'\n"
      << "set title 'base position'\nset ylabel 'm, rad'\n"
      << "plot " << d << " using 1:8 with lines title 'x', '' using 1:9 with lines title 'y', '' using 1:10 with"
      << " lines title 'yaw'\n"
      << "set title 'base path (world)'\nset xlabel 'x (m)'\nset ylabel 'y (m)'\n"
      << "plot " << d << " using 8:9 with lines lw 2 title 'base'\n"
      << "unset multiplot\n";
  }
  const std::string command = "gnuplot " + quote(script_path) + " 2>&1";
  std::FILE* p = popen(command.c_str(), "r");
  if (!p) return "cannot run gnuplot (is it installed? scripts/setup installs gnuplot-nox)";
  std::string output;
  char buf[256];
  while (std::fgets(buf, sizeof buf, p)) output += buf;
  const int status = pclose(p);
  std::remove(script_path.c_str());
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127)
    return "cannot run gnuplot (is it installed? scripts/setup installs gnuplot-nox)";
  std::ifstream made(png, std::ios::binary);
  if (status != 0 || !made || made.peek() == std::ifstream::traits_type::eof())
    return png + ": gnuplot failed: " + output;
  return "";
}

}  // namespace dca::sim
