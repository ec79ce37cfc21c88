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

bool fail(std::string* error, std::string why) {
  *error = std::move(why);
  return false;
}

// The bound on what mcap_to_csv reads, as `dca monitor` has it (bindings/wrap_mcap.cpp): a larger file is refused
// by its size before a byte of it is read.
constexpr std::uintmax_t kMaxRecording = std::uintmax_t{1} << 30;

bool within_bound(const std::string& path, std::string* error) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) return fail(error, path + ": cannot open the recording");
  if (size > kMaxRecording)
    return fail(error, path + ": " + std::to_string(size) + " bytes: dca reads recordings of at most 1 GiB");
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

}  // namespace dca::sim
