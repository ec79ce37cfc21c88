#include "worlds/door/recording.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <vector>

#include <sys/wait.h>

#include "host/codec/mcap.h"

namespace dca::sim {

namespace {

// The MCAP channels: topic and field names, in the order of the CSV's columns after time (phase last).
struct Group {
  const char* topic;
  std::vector<const char*> fields;
};
const std::vector<Group>& groups() {
  static const std::vector<Group> g = {
      {"/world/arm", {"q1", "q2", "q3", "q4", "q5", "q6"}},
      {"/world/base", {"x", "y", "yaw"}},
      {"/world/wrench", {"fx", "fy", "fz", "tx", "ty", "tz"}},
      {"/world/door", {"door_angle", "handle_angle"}},
      {"/world/gripper", {"width", "state"}},
      {"/world/laser", {"range"}},
      {"/world/phase", {"phase"}},
  };
  return g;
}

// The JSON Schema of a group's messages: an object of numbers.
std::string schema_of(const Group& g) {
  std::string s = R"({"type":"object","title":")" + std::string(g.topic) + R"(","properties":{)";
  for (size_t i = 0; i < g.fields.size(); ++i)
    s += (i ? "," : "") + std::string("\"") + g.fields[i] + R"(":{"type":"number"})";
  return s + "}}";
}

// The values of a row in the CSV's column order after time: q1..q6, base, wrench, door, gripper, laser, phase.
std::vector<double> values_of(const Sensors& s, int phase) {
  std::vector<double> v(s.arm_q.begin(), s.arm_q.end());
  v.insert(v.end(), {s.base_pose.x, s.base_pose.y, s.base_pose.yaw});
  v.insert(v.end(), s.wrench.begin(), s.wrench.end());
  v.insert(v.end(), {s.door_angle, s.handle_angle, s.gripper_width, static_cast<double>(s.gripper),
                     s.laser_range, static_cast<double>(phase)});
  return v;
}

}  // namespace

const char* csv_header() {
  return "time,q1,q2,q3,q4,q5,q6,base_x,base_y,base_yaw,fx,fy,fz,tx,ty,tz,door_angle,handle_angle,"
         "gripper_width,gripper_state,laser,phase";
}

DoorRecording::DoorRecording(const std::string& path)
    : DoorRecording(std::make_unique<Recorder>(path, csv_header())) {}

DoorRecording::DoorRecording(Recorder& recorder) : r_(&recorder) {
  for (const Group& g : groups()) {
    const std::uint16_t id = r_->add_channel(g.topic, schema_of(g), g.topic + 1);
    if (first_ == 0) first_ = id;
  }
}

DoorRecording::DoorRecording(std::unique_ptr<Recorder> own) : DoorRecording(*own) { own_ = std::move(own); }

void DoorRecording::record(const Sensors& s, int phase) {
  char num[32];
  if (r_->mcap()) {
    const std::vector<double> v = values_of(s, phase);
    const auto t = static_cast<std::int64_t>(std::llround(s.time * 1e9));
    size_t k = 0;
    for (size_t c = 0; c < groups().size(); ++c) {
      std::string json = "{";
      for (size_t i = 0; i < groups()[c].fields.size(); ++i, ++k) {
        std::snprintf(num, sizeof num, "%.9g", std::isfinite(v[k]) ? v[k] : 0.0);
        json += (i ? ",\"" : "\"") + std::string(groups()[c].fields[i]) + "\":" + num;
      }
      r_->write(static_cast<std::uint16_t>(first_ + c), t, json + "}");
    }
    return;
  }
  std::string row;
  auto add = [&](int decimals, double x) {
    std::snprintf(num, sizeof num, ",%.*f", decimals, x);
    row += num;
  };
  std::snprintf(num, sizeof num, "%.4f", s.time);
  row += num;
  for (double q : s.arm_q) add(6, q);
  add(6, s.base_pose.x), add(6, s.base_pose.y), add(6, s.base_pose.yaw);
  for (double w : s.wrench) add(4, w);
  add(6, s.door_angle), add(6, s.handle_angle), add(5, s.gripper_width);
  row += "," + std::to_string(static_cast<int>(s.gripper));
  add(5, s.laser_range);
  row += "," + std::to_string(phase);
  r_->csv_row(row);
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
// The bound on what `dca plot` reads, as `dca monitor` has it (bindings/wrap_mcap.cpp): a larger file is refused
// by its size before a byte of it is read.
constexpr std::uintmax_t kMaxRecording = std::uintmax_t{1} << 30;

bool within_bound(const std::string& path, std::string* error) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) return fail(error, path + ": cannot open the recording");
  if (size > kMaxRecording)
    return fail(error, path + ": " + std::to_string(size) + " bytes: dca plot reads recordings of at most 1 GiB");
  return true;
}

bool check_recording(const std::string& csv, std::string* error) {
  std::ifstream in(csv);
  if (!in) return fail(error, csv + ": cannot open the recording");
  std::string header;  // at most one byte past the header: a long first line is no header
  const std::size_t want = std::strlen(csv_header());
  for (char c = 0; header.size() <= want && in.get(c) && c != '\n';) header += c;
  if (header != csv_header()) return fail(error, csv + ":1: not a dca sim recording (unexpected header)");
  std::string row;
  if (!std::getline(in, row)) return fail(error, csv + ":2: the recording has no data");
  return true;
}

// The gnuplot script that draws `csv` (a recording of `title`) to `png`: four panels (angles, wrist force, base
// position, base path).
bool write_script(const std::string& csv, const std::string& title, const std::string& png, const std::string& path,
                  std::string* error) {
  std::ofstream g(path);
  if (!g) return fail(error, path + ": cannot write the gnuplot script");
  const std::string d = quote(csv);
  g << "set terminal pngcairo size 1400,1000 font ',10' noenhanced\n"
    << "set output " << quote(png) << "\n"
    << "set datafile separator ','\n"
    << "set key autotitle columnhead\n"
    << "set grid\n"
    << "set multiplot layout 2,2 title " << quote("dca sim: " + title) << "\n"
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

// The number after "field": in a JSON object's text (our own flat objects of numbers), NaN when absent.
double field_of(const std::string& json, const char* field) {
  const std::string key = std::string("\"") + field + "\":";
  const size_t at = json.find(key);
  if (at == std::string::npos) return std::nan("");
  return std::strtod(json.c_str() + at + key.size(), nullptr);
}

// The CSV rows (by log time, values after time in csv_header()'s order) of the messages in `c`.
std::map<uint64_t, std::vector<double>> rows_of(const dca::mcap::Contents& c, size_t columns) {
  std::map<uint16_t, size_t> first_column;  // channel id -> the column its first field fills
  for (const auto& [id, ch] : c.channels) {
    size_t k = 0;
    for (const Group& g : groups()) {
      if (ch.topic == g.topic) first_column[id] = k;
      k += g.fields.size();
    }
  }
  std::map<uint64_t, std::vector<double>> rows;
  for (const auto& m : c.messages) {
    auto col = first_column.find(m.channel);
    if (col == first_column.end()) continue;
    auto& row = rows.try_emplace(m.log_time, columns, 0.0).first->second;
    size_t k = col->second;
    for (const Group& g : groups()) {
      if (g.topic != c.channels.at(m.channel).topic) continue;
      for (const char* f : g.fields) {
        const double v = field_of(m.data, f);
        row[k++] = std::isfinite(v) ? v : 0.0;
      }
    }
  }
  return rows;
}

}  // namespace

bool mcap_to_csv(const std::string& mcap, const std::string& csv, std::string* error) {
  if (!within_bound(mcap, error)) return false;
  std::ifstream in(mcap, std::ios::binary);
  if (!in) return fail(error, mcap + ": cannot open the recording");
  std::string bytes(static_cast<std::size_t>(std::filesystem::file_size(mcap)), '\0');
  if (!in.read(bytes.data(), static_cast<std::streamsize>(bytes.size())))
    return fail(error, mcap + ": cannot read the recording");
  dca::mcap::Contents c;
  std::string why;
  if (!dca::mcap::read(bytes, &c, &why)) return fail(error, mcap + ": " + why);
  size_t columns = 0;
  for (const Group& g : groups()) columns += g.fields.size();
  const auto rows = rows_of(c, columns);
  if (rows.empty()) return fail(error, mcap + ": no /world/... messages (not a recording of dca sim)");
  std::FILE* out = std::fopen(csv.c_str(), "w");
  if (!out) return fail(error, csv + ": cannot write: " + std::strerror(errno));
  std::fprintf(out, "%s\n", csv_header());
  for (const auto& [t, row] : rows) {
    std::fprintf(out, "%.4f", static_cast<double>(t) * 1e-9);
    for (double v : row) std::fprintf(out, ",%.9g", v);
    std::fprintf(out, "\n");
  }
  const bool ok = std::fclose(out) == 0;
  return ok || fail(error, csv + ": error writing");
}

bool plot_csv(const std::string& file, const std::string& png, std::string* error) {
  if (!within_bound(file, error)) return false;
  const std::string script = png + ".gnuplot";
  if (is_mcap(file)) {
    const std::string csv = png + ".csv";
    const bool ok = mcap_to_csv(file, csv, error) && write_script(csv, file, png, script, error) &&
                    run_gnuplot(script, png, error);
    std::remove(csv.c_str());
    return ok;
  }
  return check_recording(file, error) && write_script(file, file, png, script, error) && run_gnuplot(script, png, error);
}

}  // namespace dca::sim
