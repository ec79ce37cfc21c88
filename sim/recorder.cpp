#include "sim/recorder.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <stdexcept>
#include <utility>
#include <vector>


#include "host/codec/mcap.h"

namespace dca::sim {

bool is_mcap(const std::string& path) {
  return path.size() > 5 && path.compare(path.size() - 5, 5, ".mcap") == 0;
}

namespace {

// A writer of 64 KiB chunks into f.
std::unique_ptr<dca::mcap::Writer> file_writer(std::FILE* f, dca::mcap::Compression c, const std::string& profile) {
  return std::make_unique<dca::mcap::Writer>(
      [f](std::string_view b) { return std::fwrite(b.data(), 1, b.size(), f) == b.size(); }, "dca sim", 64 * 1024, c,
      profile);
}

// Adds what `s` counted to *total.
void add_stats(dca::mcap::Stats* total, const dca::mcap::Stats& s) {
  total->messages += s.messages;
  total->chunks += s.chunks;
  total->bytes += s.bytes;
  total->chunk_bytes += s.chunk_bytes;
  for (const auto& [c, n] : s.per_channel) total->per_channel[c] += n;
}

}  // namespace

bool parse_split(const std::string& text, RecordOptions* o) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || !(v > 0) || v > 1e15) return false;
  const std::string unit = end;
  static const std::pair<const char*, double> sizes[] = {{"", 1}, {"B", 1}, {"KB", 1e3}, {"MB", 1e6}, {"GB", 1e9},
                                                         {"KiB", 1024}, {"MiB", 1048576}, {"GiB", 1073741824}};
  static const std::pair<const char*, double> times[] = {{"s", 1}, {"min", 60}, {"h", 3600}};
  for (const auto& [u, k] : sizes)
    if (unit == u && v * k >= 4096) return o->split_bytes = static_cast<uint64_t>(v * k), o->split_ns = 0, true;
  for (const auto& [u, k] : times)
    if (unit == u && v * k >= 0.001) return o->split_ns = static_cast<uint64_t>(std::llround(v * k * 1e9)), o->split_bytes = 0, true;
  return false;
}

struct Recorder::Mcap {
  Mcap(std::FILE* f, dca::mcap::Compression c) : writer(file_writer(f, c, "")) {}
  std::unique_ptr<dca::mcap::Writer> writer;
  dca::mcap::Stats done;  // a split recording's files before the open one
  std::string failed;     // a file of a split that could not be written
  uint16_t events = 0;  // the channel /dca/events, once there is a note
  uint16_t log = 0;     // the channel /dca/log, once there is a line
  std::vector<dca::mcap::ChannelSpec> added;  // the channels, in id order (a black box made later takes them over)
};

namespace {
std::string json_string(const std::string& s);
}  // namespace

// The black box's channels and its ring of messages (docs/recording.md, "Black box").
struct Recorder::Box {
  struct Held {
    uint16_t channel;
    uint64_t t;
    std::string json;
  };
  BlackboxOptions o;
  dca::mcap::Compression compression = dca::mcap::Compression::none;
  std::string profile;  // the header's ("" or "ros2")
  uint64_t before_ns = 0, after_ns = 0;
  std::vector<dca::mcap::ChannelSpec> channels;  // channel id - 1
  std::deque<Held> held;
  std::size_t bytes = 0;
  uint64_t latest = 0;          // the latest message's time
  bool pending = false;         // a trigger waits for its after-window
  uint64_t t_trigger = 0;
  std::string why;
  std::vector<std::pair<uint64_t, std::string>> also;  // the triggers counted in the pending one (kMaxAlso)
  uint64_t dropped = 0;         // messages dropped by the size bound
  uint64_t gone = 0;            // the latest time of a message dropped
  bool any_gone = false;
  std::vector<std::string> files;  // what each trigger wrote

  // Drops what no trigger can need any more, then the oldest past the size bound. Without a trigger pending, a
  // trigger may still come for a tick up to kLateTrigger behind the latest message (a fault's line travels from
  // the tree while time runs on), so that much more is kept.
  void evict() {
    const uint64_t keep = pending ? t_trigger : (latest > Recorder::kLateTrigger ? latest - Recorder::kLateTrigger : 0);
    const uint64_t from = keep > before_ns ? keep - before_ns : 0;
    while (!held.empty() && (held.front().t < from || bytes > o.max_bytes)) {
      if (held.front().t >= from) ++dropped;
      gone = std::max(gone, held.front().t);
      any_gone = true;
      bytes -= held.front().json.size() + sizeof(Held);
      held.pop_front();
    }
  }

  // The trigger's file: every channel, the trigger on /dca/blackbox, the messages of its window.
  std::string write(const std::string& file) const {
    std::FILE* f = std::fopen(file.c_str(), "w");
    if (!f) return file + ": cannot write the black box: " + std::strerror(errno);
    const auto writer = file_writer(f, compression, profile);
    dca::mcap::Writer& w = *writer;
    for (const auto& c : channels) w.add_channel(c);
    const uint16_t box = w.add_channel("/dca/blackbox", "dca/blackbox",
                                       R"({"type":"object","title":"/dca/blackbox","properties":{"trigger":)"
                                       R"({"type":"string"},"t":{"type":"number"},"before":{"type":"number"},)"
                                       R"("after":{"type":"number"}}})");
    char numbers[128];
    std::snprintf(numbers, sizeof numbers, ",\"t\":%.9f,\"before\":%.9g,\"after\":%.9g}",
                  static_cast<double>(t_trigger) / 1e9, o.before, o.after);
    w.write(box, t_trigger, "{\"trigger\":" + json_string(why) + numbers);
    for (const auto& [t, what] : also) {  // the later triggers it holds, each at its own time
      std::snprintf(numbers, sizeof numbers, ",\"t\":%.9f,\"before\":%.9g,\"after\":%.9g}",
                    static_cast<double>(t) / 1e9, o.before, o.after);
      w.write(box, t, "{\"trigger\":" + json_string(what) + numbers);
    }
    const uint64_t from = t_trigger > before_ns ? t_trigger - before_ns : 0, to = t_trigger + after_ns;
    for (const auto& m : held)
      if (m.t >= from && m.t <= to) w.write(m.channel, m.t, m.json);
    const bool bad = !w.finish() || std::ferror(f) != 0;
    if (std::fclose(f) != 0 || bad) return file + ": error writing the black box";
    char window[160];
    std::snprintf(window, sizeof window, " at %.3f s, [%.3f, %.3f] s, ", static_cast<double>(t_trigger) / 1e9,
                  static_cast<double>(from) / 1e9, static_cast<double>(to) / 1e9);
    std::string cut;
    if (any_gone && gone >= from) {  // came too late, or past the size bound: say what it lacks
      char held_from[96];
      std::snprintf(held_from, sizeof held_from, " (messages up to %.3f s were no longer held)",
                    static_cast<double>(gone) / 1e9);
      cut = held_from;
    }
    return file + ": " + why + window + std::to_string(w.stats().messages - 1 - also.size()) + " messages" + cut;
  }
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

uint16_t Recorder::channel(const dca::mcap::ChannelSpec& spec) {
  if (box_) {
    box_->channels.push_back(spec);
    return static_cast<uint16_t>(box_->channels.size());
  }
  if (!f_ || !mcap_) return 0;
  mcap_->added.push_back(spec);
  return mcap_->writer->add_channel(spec);
}

void Recorder::put(uint16_t channel, uint64_t t_ns, std::string json) {
  if (channel == 0) return;
  if (!box_) {
    if (f_ && mcap_) rotate_if_due(t_ns);
    if (f_ && mcap_) mcap_->writer->write(channel, t_ns, json);
    return;
  }
  Box& b = *box_;
  b.latest = std::max(b.latest, t_ns);
  b.bytes += json.size() + sizeof(Box::Held);
  b.held.push_back({channel, t_ns, std::move(json)});
  if (b.pending && b.latest > b.t_trigger + b.after_ns) {
    b.files.push_back(b.write(path_.substr(0, path_.size() - 5) + "-" + std::to_string(b.files.size() + 1) + ".mcap"));
    b.pending = false;
    b.also.clear();
  }
  b.evict();
}

void Recorder::note(double t, const std::string& line, const std::string& path, const std::string& state) {
  if (!mcap_) return;
  if (mcap_->events == 0)
    mcap_->events = channel({"/dca/events", "dca/events",
                             R"({"type":"object","title":"/dca/events","properties":{"line":{"type":"string"},)"
                             R"("path":{"type":"string"},"state":{"type":"string"}}})", false});
  const auto ns = static_cast<uint64_t>(std::llround(std::max(0.0, t) * 1e9));
  put(mcap_->events, ns,
      "{\"line\":" + json_string(line) + ",\"path\":" + json_string(path) + ",\"state\":" + json_string(state) + "}");
}

void Recorder::log(double t, const std::string& path, const std::string& line) {
  if (!mcap_) return;
  if (mcap_->log == 0)
    mcap_->log = channel({"/dca/log", "dca/log",
                          R"({"type":"object","title":"/dca/log","properties":{"path":{"type":"string"},)"
                          R"("line":{"type":"string"}}})", false});
  const auto ns = static_cast<uint64_t>(std::llround(std::max(0.0, t) * 1e9));
  put(mcap_->log, ns, "{\"path\":" + json_string(path) + ",\"line\":" + json_string(line) + "}");
}

uint16_t Recorder::add_channel(const std::string& topic, const std::string& schema, const std::string& schema_name) {
  const std::string name = !schema_name.empty() ? schema_name : topic.size() > 1 ? topic.substr(1) : topic;
  return channel({topic, name, schema, false});
}

uint16_t Recorder::add_cdr_channel(const std::string& topic, const std::string& ros_name,
                                   const std::string& definition) {
  return channel({topic, ros_name, definition, true});
}

void Recorder::write(uint16_t channel, int64_t t_ns, const std::string& json) {
  put(channel, static_cast<uint64_t>(std::max<int64_t>(0, t_ns)), json);
}

bool Recorder::blackbox(const BlackboxOptions& o) {
  if (!mcap_ || box_ || !f_) return false;
  std::fclose(f_);  // (only the magic and header were written: PATH itself is never the black box's file)
  f_ = nullptr;
  std::remove(path_.c_str());
  box_ = std::make_unique<Box>();
  box_->channels = mcap_->added;
  box_->o = o;
  box_->before_ns = static_cast<uint64_t>(std::llround(std::max(0.0, o.before) * 1e9));
  box_->after_ns = static_cast<uint64_t>(std::llround(std::max(0.0, o.after) * 1e9));
  return true;
}

void Recorder::trigger(double t, const std::string& why) {
  if (!box_) return;
  if (box_->pending) {  // part of the pending one: named in its file too
    if (box_->also.size() < Recorder::kMaxAlso)
      box_->also.emplace_back(static_cast<uint64_t>(std::llround(std::max(0.0, t) * 1e9)), why);
    return;
  }
  box_->pending = true;
  box_->t_trigger = static_cast<uint64_t>(std::llround(std::max(0.0, t) * 1e9));
  box_->why = why;
}

void Recorder::configure(const RecordOptions& o) {
  options_ = o;
  if (box_) box_->compression = o.compression, box_->profile = o.profile;
  if (!mcap_ || !f_) return;
  mcap_->writer->set_compression(o.compression);
  if (!o.profile.empty() && o.split_bytes == 0 && o.split_ns == 0) {  // the header again, with the profile
    if (!(f_ = std::freopen(path_.c_str(), "w", f_))) {
      mcap_->failed = path_ + ": cannot write the recording: " + std::strerror(errno);
      return;
    }
    mcap_->writer = file_writer(f_, o.compression, o.profile);
    for (const auto& c : mcap_->added) mcap_->writer->add_channel(c);
    return;
  }
  if (o.split_bytes == 0 && o.split_ns == 0) return;
  std::fclose(f_);  // (only the magic, the header and the channels were written: the split's files are the record)
  f_ = nullptr;
  std::remove(path_.c_str());
  split_at_ = o.split_ns;
  next_file();
}

void Recorder::next_file() {
  if (f_) {
    const bool bad = !mcap_->writer->finish() || std::ferror(f_) != 0;
    if ((std::fclose(f_) != 0 || bad) && mcap_->failed.empty()) mcap_->failed = files_.back() + ": error writing the recording";
    f_ = nullptr;
    add_stats(&mcap_->done, mcap_->writer->stats());
  }
  char n[32];
  std::snprintf(n, sizeof n, "-%03zu.mcap", files_.size());
  files_.push_back(path_.substr(0, path_.size() - 5) + n);
  f_ = std::fopen(files_.back().c_str(), "w");
  if (!f_) {
    if (mcap_->failed.empty()) mcap_->failed = files_.back() + ": cannot write the recording: " + std::strerror(errno);
    return;
  }
  mcap_->writer = file_writer(f_, options_.compression, options_.profile);
  for (const auto& c : mcap_->added) mcap_->writer->add_channel(c);
}

void Recorder::rotate_if_due(uint64_t t_ns) {
  if (files_.empty()) return;
  const dca::mcap::Writer& w = *mcap_->writer;
  const bool by_size = options_.split_bytes && w.stats().bytes + w.pending_bytes() >= options_.split_bytes &&
                       w.stats().messages + w.pending_bytes() > 0;
  const bool by_time = options_.split_ns && t_ns >= split_at_;
  if (by_time) split_at_ = (t_ns / options_.split_ns + 1) * options_.split_ns;
  if (by_size || by_time) next_file();
}

std::size_t Recorder::held_bytes() const { return box_ ? box_->bytes : 0; }

Recorder::Recorder(const std::string& path, const std::string& csv_header) : path_(path) {
  if (csv_header.empty() && !is_mcap(path))
    throw std::runtime_error(path + ": this world records MCAP only (FILE.mcap)");
  f_ = std::fopen(path.c_str(), "w");
  if (!f_) throw std::runtime_error(path + ": cannot write the recording: " + std::strerror(errno));
  if (is_mcap(path)) {
    mcap_ = std::make_unique<Mcap>(f_, dca::mcap::Compression::none);
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
  if (box_ && box_->pending) {
    box_->files.push_back(
        box_->write(path_.substr(0, path_.size() - 5) + "-" + std::to_string(box_->files.size() + 1) + ".mcap"));
    box_->pending = false;
  }
  const bool failed = mcap_ && !mcap_->failed.empty();
  if (failed) *error = mcap_->failed;
  if (!f_) return !failed;
  std::FILE* f = f_;
  f_ = nullptr;
  const bool bad = (mcap_ && !mcap_->writer->finish()) || std::ferror(f) != 0;
  if (std::fclose(f) == 0 && !bad) return !failed;
  *error = (files_.empty() ? path_ : files_.back()) + ": error writing the recording";
  return false;
}

std::string Recorder::summary() const {
  if (box_) {
    std::string s = path_ + ": black box, " + std::to_string(box_->files.size()) + " written";
    for (const auto& f : box_->files) s += "; " + f;
    if (box_->dropped) s += "; " + std::to_string(box_->dropped) + " messages dropped by its size bound";
    return s;
  }
  if (!mcap_) return path_ + ": " + std::to_string(rows_) + " rows";
  dca::mcap::Stats st = mcap_->done;
  add_stats(&st, mcap_->writer->stats());
  const size_t channels = mcap_->writer->channels();
  std::string s = path_ + ": " + std::to_string(st.messages) + " messages on " + std::to_string(channels) +
                  " channels (";
  for (size_t c = 1; c <= channels; ++c) {
    auto n = st.per_channel.find(static_cast<uint16_t>(c));
    s += (c > 1 ? ", " : "") + mcap_->writer->topic(static_cast<uint16_t>(c)) + " " +
         std::to_string(n == st.per_channel.end() ? 0 : n->second);
  }
  s += "), " + std::to_string(st.chunks) + " chunks";
  if (options_.compression != dca::mcap::Compression::none && st.chunk_bytes > 0) {
    char ratio[96];
    std::snprintf(ratio, sizeof ratio, ", %s %.1fx", dca::mcap::compression_name(options_.compression),
                  static_cast<double>(st.chunk_bytes) / static_cast<double>(std::max<uint64_t>(1, st.bytes)));
    s += ratio;
  }
  if (files_.size() == 1) s += ", in 1 file " + files_[0];
  if (files_.size() > 1) s += ", in " + std::to_string(files_.size()) + " files " + files_.front() + " .. " + files_.back();
  return dropped_ ? s + ", " + std::to_string(dropped_) + " tap samples dropped" : s;
}

}  // namespace dca::sim
