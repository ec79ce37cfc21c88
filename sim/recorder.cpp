#include "sim/recorder.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>

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
  std::string ignored;
  close(&ignored);
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

bool Recorder::close(std::string* error) {
  if (!f_) return true;
  std::FILE* f = f_;
  f_ = nullptr;
  const bool bad = std::ferror(f) != 0;
  if (std::fclose(f) == 0 && !bad) return true;
  *error = path_ + ": error writing the recording";
  return false;
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

bool fail(std::string* error, std::string why) {
  *error = std::move(why);
  return false;
}

// The recording has dca sim's header and at least one row.
bool check_recording(const std::string& csv, std::string* error) {
  std::ifstream in(csv);
  if (!in) return fail(error, csv + ": cannot open the recording");
  std::string header;
  std::getline(in, header);
  if (header != csv_header()) return fail(error, csv + ":1: not a dca sim recording (unexpected header)");
  std::string row;
  if (!std::getline(in, row)) return fail(error, csv + ":2: the recording has no data");
  return true;
}

// The gnuplot script that draws `csv` to `png`: four panels (angles, wrist force, base position, base path).
bool write_script(const std::string& csv, const std::string& png, const std::string& path, std::string* error) {
  std::ofstream g(path);
  if (!g) return fail(error, path + ": cannot write the gnuplot script");
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
  return true;
}

// Runs gnuplot on `script` (then removes it); true when it made a non-empty `png`.
bool run_gnuplot(const std::string& script, const std::string& png, std::string* error) {
  const char* missing = "cannot run gnuplot (is it installed? scripts/setup installs gnuplot-nox)";
  const std::string command = "gnuplot " + quote(script) + " 2>&1";
  std::FILE* p = popen(command.c_str(), "r");
  if (!p) return fail(error, missing);
  std::string output;
  char buf[256];
  while (std::fgets(buf, sizeof buf, p)) output += buf;
  const int status = pclose(p);
  std::remove(script.c_str());
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127) return fail(error, missing);
  std::ifstream made(png, std::ios::binary);
  if (status != 0 || !made || made.peek() == std::ifstream::traits_type::eof())
    return fail(error, png + ": gnuplot failed: " + output);
  return true;
}

}  // namespace

bool plot_csv(const std::string& csv, const std::string& png, std::string* error) {
  const std::string script = png + ".gnuplot";
  return check_recording(csv, error) && write_script(csv, png, script, error) && run_gnuplot(script, png, error);
}

}  // namespace dca::sim
