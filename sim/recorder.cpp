#include "sim/recorder.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <utility>
#include <vector>


#include "host/codec/mcap.h"

namespace dca::sim {

bool is_mcap(const std::string& path) {
  return path.size() > 5 && path.compare(path.size() - 5, 5, ".mcap") == 0;
}

struct Recorder::Mcap {
  explicit Mcap(std::FILE* f)
      : writer([f](std::string_view b) { return std::fwrite(b.data(), 1, b.size(), f) == b.size(); }, "dca sim",
               64 * 1024) {}
  dca::mcap::Writer writer;
  uint16_t events = 0;  // the channel /dca/events, once there is a note
  uint16_t log = 0;     // the channel /dca/log, once there is a line
};

namespace {

// s as a JSON string literal.
std::string json_string(const std::string& s) {
  std::string out = "\"";
  char esc[8];
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20) {
      std::snprintf(esc, sizeof esc, "\\u%04x", c);
      out += esc;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

}  // namespace

void Recorder::note(double t, const std::string& line, const std::string& path, const std::string& state) {
  if (!f_ || !mcap_) return;
  if (mcap_->events == 0)
    mcap_->events = mcap_->writer.add_channel(
        "/dca/events", "dca/events",
        R"({"type":"object","title":"/dca/events","properties":{"line":{"type":"string"},)"
        R"("path":{"type":"string"},"state":{"type":"string"}}})");
  const auto ns = static_cast<uint64_t>(std::llround(std::max(0.0, t) * 1e9));
  mcap_->writer.write(mcap_->events, ns,
                      "{\"line\":" + json_string(line) + ",\"path\":" + json_string(path) +
                          ",\"state\":" + json_string(state) + "}");
}

void Recorder::log(double t, const std::string& path, const std::string& line) {
  if (!f_ || !mcap_) return;
  if (mcap_->log == 0)
    mcap_->log = mcap_->writer.add_channel(
        "/dca/log", "dca/log",
        R"({"type":"object","title":"/dca/log","properties":{"path":{"type":"string"},"line":{"type":"string"}}})");
  const auto ns = static_cast<uint64_t>(std::llround(std::max(0.0, t) * 1e9));
  mcap_->writer.write(mcap_->log, ns, "{\"path\":" + json_string(path) + ",\"line\":" + json_string(line) + "}");
}

uint16_t Recorder::add_channel(const std::string& topic, const std::string& schema, const std::string& schema_name) {
  if (!f_ || !mcap_) return 0;
  const std::string name = !schema_name.empty() ? schema_name : topic.size() > 1 ? topic.substr(1) : topic;
  return mcap_->writer.add_channel(topic, name, schema);
}

void Recorder::write(uint16_t channel, int64_t t_ns, const std::string& json) {
  if (!f_ || !mcap_ || channel == 0) return;
  mcap_->writer.write(channel, static_cast<uint64_t>(std::max<int64_t>(0, t_ns)), json);
}

Recorder::Recorder(const std::string& path, const std::string& csv_header) : path_(path) {
  if (csv_header.empty() && !is_mcap(path))
    throw std::runtime_error(path + ": this world records MCAP only (FILE.mcap)");
  f_ = std::fopen(path.c_str(), "w");
  if (!f_) throw std::runtime_error(path + ": cannot write the recording: " + std::strerror(errno));
  if (is_mcap(path)) {
    mcap_ = std::make_unique<Mcap>(f_);
  } else {
    std::fprintf(f_, "%s\n", csv_header.c_str());
  }
}

Recorder::~Recorder() {
  std::string ignored;
  close(&ignored);
}

void Recorder::csv_row(const std::string& row) {
  if (!f_ || mcap_) return;
  ++rows_;
  std::fprintf(f_, "%s\n", row.c_str());
}

bool Recorder::close(std::string* error) {
  if (!f_) return true;
  std::FILE* f = f_;
  f_ = nullptr;
  const bool bad = (mcap_ && !mcap_->writer.finish()) || std::ferror(f) != 0;
  if (std::fclose(f) == 0 && !bad) return true;
  *error = path_ + ": error writing the recording";
  return false;
}

std::string Recorder::summary() const {
  if (!mcap_) return path_ + ": " + std::to_string(rows_) + " rows";
  const dca::mcap::Stats& st = mcap_->writer.stats();
  const size_t channels = mcap_->writer.channels();
  std::string s = path_ + ": " + std::to_string(st.messages) + " messages on " + std::to_string(channels) +
                  " channels (";
  for (size_t c = 1; c <= channels; ++c) {
    auto n = st.per_channel.find(static_cast<uint16_t>(c));
    s += (c > 1 ? ", " : "") + mcap_->writer.topic(static_cast<uint16_t>(c)) + " " +
         std::to_string(n == st.per_channel.end() ? 0 : n->second);
  }
  s += "), " + std::to_string(st.chunks) + " chunks";
  return dropped_ ? s + ", " + std::to_string(dropped_) + " tap samples dropped" : s;
}

}  // namespace dca::sim
