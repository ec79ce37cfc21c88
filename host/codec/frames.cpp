#include "host/codec/frames.h"

#include "host/codec/json.h"

namespace dca::frames {

namespace {

// {"type":"object","properties":{k1:{"type":"number"},...},"required":[k1,...]}: a vector or quaternion.
std::string numbers_object(const char* title, const std::vector<const char*>& keys) {
  std::string s = "{\"title\":";
  json::append_string(s, title);
  s += ",\"type\":\"object\",\"properties\":{";
  std::string required;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    if (i) s += ',', required += ',';
    json::append_string(s, keys[i]);
    s += ":{\"type\":\"number\"}";
    json::append_string(required, keys[i]);
  }
  s += "},\"required\":[";
  s += required;
  s += "]}";
  return s;
}

void append_xyz(std::string& out, const char* keys, const double* v, std::size_t n) {
  out += '{';
  for (std::size_t i = 0; i < n; ++i) {
    if (i) out += ',';
    out += '"';
    out += keys[i];
    out += "\":";
    json::append_number(out, v[i]);
  }
  out += '}';
}

}  // namespace

const std::string& json_schema() {
  static const std::string schema = [] {
    std::string time = R"({"title":"time","type":"object","properties":{"sec":{"type":"integer","minimum":0},)"
                       R"("nsec":{"type":"integer","minimum":0,"maximum":999999999}}})";
    std::string frame = R"({"title":"foxglove.FrameTransform","type":"object","properties":{"timestamp":)" + time +
                        R"(,"parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},"translation":)" +
                        numbers_object("foxglove.Vector3", {"x", "y", "z"}) + ",\"rotation\":" +
                        numbers_object("foxglove.Quaternion", {"x", "y", "z", "w"}) +
                        R"(},"required":["timestamp","parent_frame_id","child_frame_id","translation","rotation"]})";
    return std::string(R"({"title":"foxglove.FrameTransforms","description":"link frames of a dca world",)") +
           R"("type":"object","properties":{"transforms":{"type":"array","items":)" + frame +
           R"(}},"required":["transforms"]})";
  }();
  return schema;
}

std::string message(const std::vector<Frame>& frames, std::int64_t t_ns, const double* values, std::size_t n) {
  const std::int64_t t = t_ns < 0 ? 0 : t_ns;
  const std::string stamp =
      "{\"sec\":" + std::to_string(t / 1000000000) + ",\"nsec\":" + std::to_string(t % 1000000000) + "}";
  std::string s = "{\"transforms\":[";
  for (std::size_t i = 0; i < frames.size() && (i + 1) * kValuesPerFrame <= n; ++i) {
    const double* v = values + i * kValuesPerFrame;
    s += i ? ",{\"timestamp\":" : "{\"timestamp\":";
    s += stamp + ",\"parent_frame_id\":";
    json::append_string(s, frames[i].parent);
    s += ",\"child_frame_id\":";
    json::append_string(s, frames[i].child);
    s += ",\"translation\":";
    append_xyz(s, "xyz", v, 3);
    s += ",\"rotation\":";
    append_xyz(s, "xyzw", v + 3, 4);
    s += '}';
  }
  return s + "]}";
}

const std::string& description_schema() {
  static const std::string schema =
      R"({"title":"std_msgs/String","description":"the robot's URDF","type":"object",)"
      R"("properties":{"data":{"type":"string"}},"required":["data"]})";
  return schema;
}

std::string description_message(const std::string& urdf) {
  std::string s = "{\"data\":";
  json::append_string(s, urdf);
  return s + "}";
}

}  // namespace dca::frames
