#include "host/codec/mcap.h"

#include <lz4frame.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <memory>
#include <utility>

namespace dca::mcap {

namespace {

constexpr std::string_view kMagic{"\x89MCAP0\r\n", 8};

enum Op : uint8_t {
  kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05, kChunk = 0x06,
  kMessageIndex = 0x07, kChunkIndex = 0x08, kStatistics = 0x0B, kSummaryOffset = 0x0E, kDataEnd = 0x0F,
};

// Little-endian serialisation of the spec's field types.
void put(std::string& b, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) b.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
void u8(std::string& b, uint64_t v) { put(b, v, 1); }
void u16(std::string& b, uint64_t v) { put(b, v, 2); }
void u32(std::string& b, uint64_t v) { put(b, v, 4); }
void u64(std::string& b, uint64_t v) { put(b, v, 8); }
void str(std::string& b, std::string_view s) {
  u32(b, s.size());
  b.append(s);
}
// Map<uint16, uint64>: its byte length, then the pairs.
void map16_64(std::string& b, const std::map<uint16_t, uint64_t>& m) {
  u32(b, m.size() * 10);
  for (const auto& [k, v] : m) {
    u16(b, k);
    u64(b, v);
  }
}

// <opcode><uint64 content length><content>
std::string record(uint8_t op, std::string_view content) {
  std::string r;
  u8(r, op);
  u64(r, content.size());
  r.append(content);
  return r;
}

std::array<uint32_t, 256> crc_table() {
  std::array<uint32_t, 256> t{};
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    t[i] = c;
  }
  return t;
}

// zstd's own default level: on the door's JSON, 1 would cost less time and give larger chunks (tests/bench).
constexpr int kZstdLevel = 3;

// `in` compressed as `c` says into *out: false when the library failed (the chunk is then written uncompressed).
bool compress(Compression c, std::string_view in, std::string* out) {
  if (c == Compression::zstd) {
    out->resize(ZSTD_compressBound(in.size()));
    const size_t n = ZSTD_compress(out->data(), out->size(), in.data(), in.size(), kZstdLevel);
    if (ZSTD_isError(n)) return false;
    out->resize(n);
    return true;
  }
  if (c == Compression::lz4) {
    LZ4F_preferences_t prefs{};
    prefs.frameInfo.contentSize = in.size();  // a reader may size its buffer by it
    out->resize(LZ4F_compressFrameBound(in.size(), &prefs));
    const size_t n = LZ4F_compressFrame(out->data(), out->size(), in.data(), in.size(), &prefs);
    if (LZ4F_isError(n)) return false;
    out->resize(n);
    return true;
  }
  return false;
}

}  // namespace

const char* compression_name(Compression c) {
  return c == Compression::zstd ? "zstd" : c == Compression::lz4 ? "lz4" : "";
}

bool parse_compression(std::string_view name, Compression* out) {
  if (name == "none" || name.empty()) *out = Compression::none;
  else if (name == "zstd") *out = Compression::zstd;
  else if (name == "lz4") *out = Compression::lz4;
  else return false;
  return true;
}

uint32_t crc32(std::string_view bytes, uint32_t crc) {
  static const std::array<uint32_t, 256> table = crc_table();
  crc = ~crc;
  for (unsigned char c : bytes) crc = table[(crc ^ c) & 0xff] ^ (crc >> 8);
  return ~crc;
}

Writer::Writer(Sink sink, std::string library, size_t chunk_bytes, Compression compression, const std::string& profile)
    : sink_(std::move(sink)), chunk_bytes_(chunk_bytes), compression_(compression) {
  std::string header;
  str(header, profile);  // "": none of the well-known ones (JSON messages); "ros2": CDR messages, ros2msg schemas
  str(header, library);
  emit(kMagic);
  emit(record(kHeader, header));
}

void Writer::emit(std::string_view bytes) {
  if (!ok_) return;
  ok_ = sink_(bytes);
  offset_ += bytes.size();
  stats_.bytes = offset_;
}

std::string Writer::schema_record(uint16_t id) const {
  const Channel& c = channels_[id - 1];
  std::string s;
  u16(s, id);
  str(s, c.schema_name);
  str(s, c.cdr ? "ros2msg" : "jsonschema");
  str(s, c.schema);
  return record(kSchema, s);
}

// ROS 2's default QoS (KEEP_LAST 10, RELIABLE, VOLATILE, AUTOMATIC liveliness, no deadline, lifespan or lease) as
// the YAML list of rosbag2's offered_qos_profiles: the enums as numbers (rmw's), "infinite" durations as rmw's.
constexpr const char* kDefaultQos =
    "- history: 1\n  depth: 10\n  reliability: 1\n  durability: 2\n"
    "  deadline:\n    sec: 9223372036\n    nsec: 854775807\n"
    "  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n  liveliness: 1\n"
    "  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n"
    "  avoid_ros_namespace_conventions: false";

std::string Writer::channel_record(uint16_t id) const {
  std::string s;
  u16(s, id);
  u16(s, id);  // its schema: one per channel, with the same id
  str(s, channels_[id - 1].topic);
  str(s, channels_[id - 1].cdr ? "cdr" : "json");
  if (!channels_[id - 1].cdr) {
    u32(s, 0);  // metadata: an empty map
  } else {  // the ros2 profile's offered_qos_profiles: ROS 2's default QoS, as rosbag2 writes it (YAML)
    std::string meta;
    str(meta, "offered_qos_profiles");
    str(meta, kDefaultQos);
    u32(s, static_cast<uint32_t>(meta.size()));
    s += meta;
  }
  return record(kChannel, s);
}

uint16_t Writer::add_channel(const std::string& topic, const std::string& schema_name, const std::string& schema) {
  return add_channel(ChannelSpec{topic, schema_name, schema, false});
}

uint16_t Writer::add_channel(const ChannelSpec& spec) {
  flush_chunk();  // a channel precedes every message on it: outside the chunks, in the data section
  channels_.push_back(spec);
  const auto id = static_cast<uint16_t>(channels_.size());
  emit(schema_record(id));
  emit(channel_record(id));
  return id;
}

void Writer::write(uint16_t channel, uint64_t log_time_ns, std::string_view json) {
  if (finished_ || channel == 0 || channel > channels_.size()) return;
  std::string m;
  u16(m, channel);
  u32(m, stats_.per_channel[channel]);  // sequence: the channel's message count
  u64(m, log_time_ns);
  u64(m, log_time_ns);
  m.append(json);
  if (chunk_.empty()) chunk_start_ = chunk_end_ = log_time_ns;
  chunk_start_ = std::min(chunk_start_, log_time_ns);
  chunk_end_ = std::max(chunk_end_, log_time_ns);
  chunk_index_[channel].emplace_back(log_time_ns, chunk_.size());
  chunk_ += record(kMessage, m);
  if (stats_.messages == 0) stats_.start_time = log_time_ns;
  stats_.start_time = std::min(stats_.start_time, log_time_ns);
  stats_.end_time = std::max(stats_.end_time, log_time_ns);
  ++stats_.messages;
  ++stats_.per_channel[channel];
  if (chunk_.size() >= chunk_bytes_) flush_chunk();
}

void Writer::flush_chunk() {
  if (chunk_.empty()) return;
  std::string packed;
  const Compression how = compress(compression_, chunk_, &packed) ? compression_ : Compression::none;
  const std::string_view records = how == Compression::none ? std::string_view(chunk_) : std::string_view(packed);
  std::string c;
  u64(c, chunk_start_);
  u64(c, chunk_end_);
  u64(c, chunk_.size());
  u32(c, crc32(chunk_));  // of the records before compression
  str(c, compression_name(how));
  u64(c, records.size());
  c += records;
  ChunkIndex ci{chunk_start_, chunk_end_, offset_, 0, 0, chunk_.size(), records.size(), {}};
  ci.compression = how;
  const std::string chunk = record(kChunk, c);
  ci.length = chunk.size();
  emit(chunk);
  const uint64_t indexes_start = offset_;
  for (const auto& [channel, entries] : chunk_index_) {
    std::string mi;
    u16(mi, channel);
    u32(mi, entries.size() * 16);
    for (const auto& [time, at] : entries) {
      u64(mi, time);
      u64(mi, at);
    }
    ci.index_offsets[channel] = offset_;
    emit(record(kMessageIndex, mi));
  }
  ci.index_length = offset_ - indexes_start;
  chunk_indexes_.push_back(std::move(ci));
  stats_.chunk_bytes += chunk_.size();
  chunk_.clear();
  chunk_index_.clear();
  ++stats_.chunks;
}

std::string Writer::statistics_record() const {
  std::string s;
  u64(s, stats_.messages);
  u16(s, channels_.size());  // schema count: one per channel
  u32(s, channels_.size());
  u32(s, 0);  // attachments
  u32(s, 0);  // metadata
  u32(s, stats_.chunks);
  u64(s, stats_.start_time);
  u64(s, stats_.end_time);
  map16_64(s, stats_.per_channel);
  return record(kStatistics, s);
}

bool Writer::finish() {
  if (finished_) return ok_;
  flush_chunk();
  finished_ = true;
  std::string end;
  u32(end, 0);  // the data section's CRC: not computed (allowed by the spec)
  emit(record(kDataEnd, end));
  // The summary: one group per record kind, each found through a summary offset record.
  const uint64_t summary_start = offset_;
  uint32_t summary_crc = 0;
  std::string offsets;
  auto group = [&](uint8_t op, const std::string& bytes) {
    if (bytes.empty()) return;
    std::string so;
    u8(so, op);
    u64(so, offset_);
    u64(so, bytes.size());
    offsets += record(kSummaryOffset, so);
    summary_crc = crc32(bytes, summary_crc);
    emit(bytes);
  };
  std::string schemas, channels, indexes;
  for (uint16_t id = 1; id <= channels_.size(); ++id) {
    schemas += schema_record(id);
    channels += channel_record(id);
  }
  for (const ChunkIndex& ci : chunk_indexes_) {
    std::string s;
    u64(s, ci.start_time);
    u64(s, ci.end_time);
    u64(s, ci.offset);
    u64(s, ci.length);
    map16_64(s, ci.index_offsets);
    u64(s, ci.index_length);
    str(s, compression_name(ci.compression));
    u64(s, ci.compressed);
    u64(s, ci.size);
    indexes += record(kChunkIndex, s);
  }
  group(kSchema, schemas);
  group(kChannel, channels);
  group(kChunkIndex, indexes);
  group(kStatistics, statistics_record());
  const uint64_t offsets_start = offset_;
  emit(offsets);
  std::string footer;
  u8(footer, kFooter);
  u64(footer, 20);
  u64(footer, summary_start);
  u64(footer, offsets_start);
  summary_crc = crc32(offsets, summary_crc);
  u32(footer, crc32(footer, summary_crc));
  emit(footer);
  emit(kMagic);
  return ok_;
}

}  // namespace dca::mcap

namespace dca::mcap {

namespace {

// Bounds-checked little-endian reading of a byte range; every read fails softly past the end.
class Cursor {
 public:
  Cursor(std::string_view b, uint64_t base) : b_(b), base_(base) {}
  bool u(int bytes, uint64_t* v) {
    if (b_.size() - at_ < static_cast<size_t>(bytes)) return false;
    *v = 0;
    for (int i = 0; i < bytes; ++i) *v |= static_cast<uint64_t>(static_cast<unsigned char>(b_[at_ + i])) << (8 * i);
    at_ += bytes;
    return true;
  }
  bool bytes(uint64_t n, std::string_view* out) {
    if (n > b_.size() - at_) return false;
    *out = b_.substr(at_, n);
    at_ += n;
    return true;
  }
  bool str(std::string* out) {
    uint64_t n;
    std::string_view v;
    if (!u(4, &n) || !bytes(n, &v)) return false;
    out->assign(v);
    return true;
  }
  std::string_view rest() { return b_.substr(at_); }
  bool done() const { return at_ == b_.size(); }
  uint64_t offset() const { return base_ + at_; }

 private:
  std::string_view b_;
  uint64_t base_;
  size_t at_ = 0;
};

bool fail(std::string* error, uint64_t at, const std::string& what) {
  *error = "offset " + std::to_string(at) + ": " + what;
  return false;
}

// `src` decompressed as `compression` says into *out, which must come to exactly `size` bytes (it is never let
// grow past them): "" or what is wrong.
std::string decompress(const std::string& compression, std::string_view src, uint64_t size, std::string* out) {
  out->resize(size);
  if (compression == "zstd") {
    const size_t n = ZSTD_decompress(out->data(), size, src.data(), src.size());
    if (ZSTD_isError(n)) return std::string("corrupt zstd chunk (") + ZSTD_getErrorName(n) + ")";
    if (n != size) return "zstd chunk of " + std::to_string(n) + " bytes, not the " + std::to_string(size) + " it states";
    return "";
  }
  if (compression != "lz4") return "chunk compressed as '" + compression + "' (zstd, lz4 or none are read)";
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) return "no lz4 decompression context";
  const std::unique_ptr<LZ4F_dctx, size_t (*)(LZ4F_dctx*)> d(raw, LZ4F_freeDecompressionContext);
  size_t in = 0, done = 0, more = 1;
  while (more != 0) {
    size_t dst = size - done, n = src.size() - in;
    more = LZ4F_decompress(d.get(), out->data() + done, &dst, src.data() + in, &n, nullptr);
    if (LZ4F_isError(more)) return std::string("corrupt lz4 chunk (") + LZ4F_getErrorName(more) + ")";
    in += n, done += dst;
    if (more != 0 && n == 0 && dst == 0)
      return in == src.size() ? "lz4 chunk ends inside its frame" : "lz4 chunk larger than the " + std::to_string(size) + " bytes it states";
  }
  if (in != src.size()) return "bytes after the lz4 chunk's frame";
  if (done != size) return "lz4 chunk of " + std::to_string(done) + " bytes, not the " + std::to_string(size) + " it states";
  return "";
}

struct Parser {
  Contents* out;
  std::string* error;
  Limits limits;
  uint64_t total = 0;  // bytes decompressed so far
  struct Schema {
    std::string name, encoding, data;
  };
  std::map<uint16_t, Schema> schemas;  // id -> its name, encoding and data

  bool schema(Cursor c) {
    uint64_t id;
    Schema s;
    if (!c.u(2, &id) || !c.str(&s.name) || !c.str(&s.encoding)) return fail(error, c.offset(), "truncated schema");
    if (!c.done() && !c.str(&s.data)) return fail(error, c.offset(), "truncated schema data");
    schemas[static_cast<uint16_t>(id)] = std::move(s);
    return true;
  }
  bool channel(Cursor c) {
    uint64_t id, schema_id;
    Contents::Channel ch;
    if (!c.u(2, &id) || !c.u(2, &schema_id) || !c.str(&ch.topic) || !c.str(&ch.message_encoding))
      return fail(error, c.offset(), "truncated channel");
    if (schema_id != 0) {
      auto s = schemas.find(static_cast<uint16_t>(schema_id));
      if (s == schemas.end()) return fail(error, c.offset(), "channel names an unknown schema");
      ch.schema_name = s->second.name;
      ch.schema_encoding = s->second.encoding;
      ch.schema = s->second.data;
    }
    out->channels[static_cast<uint16_t>(id)] = ch;
    return true;
  }
  bool message(Cursor c) {
    uint64_t channel, sequence, log_time, publish_time;
    if (!c.u(2, &channel) || !c.u(4, &sequence) || !c.u(8, &log_time) || !c.u(8, &publish_time))
      return fail(error, c.offset(), "truncated message");
    if (!out->channels.count(static_cast<uint16_t>(channel)))
      return fail(error, c.offset(), "message on an unknown channel");
    out->messages.push_back({static_cast<uint16_t>(channel), log_time, std::string(c.rest())});
    return true;
  }
  bool chunk(Cursor c) {
    uint64_t start, end, size, crc, length;
    std::string compression;
    std::string_view records;
    if (!c.u(8, &start) || !c.u(8, &end) || !c.u(8, &size) || !c.u(4, &crc) || !c.str(&compression) ||
        !c.u(8, &length))
      return fail(error, c.offset(), "truncated chunk");
    const uint64_t at = c.offset();
    if (!c.bytes(length, &records)) return fail(error, at, "chunk records do not fit");
    std::string plain;
    if (compression.empty()) {
      if (length != size) return fail(error, at, "chunk records do not fit");
    } else {
      if (size > limits.max_chunk || size > limits.max_total - std::min(total, limits.max_total))
        return fail(error, at, "chunk of " + std::to_string(size) + " bytes decompressed: over the limit of " +
                                   std::to_string(size > limits.max_chunk ? limits.max_chunk : limits.max_total) +
                                   (size > limits.max_chunk ? " per chunk" : " per file"));
      if (const std::string why = decompress(compression, records, size, &plain); !why.empty())
        return fail(error, at, why);
      total += size;
      records = plain;
    }
    if (crc != 0 && crc32(records) != crc) return fail(error, at, "chunk CRC mismatch");
    ++out->chunks;
    return records_of(Cursor(records, at), true);
  }
  // The records in c: the file's (in_chunk false) or a chunk's. Stops after the footer.
  bool records_of(Cursor c, bool in_chunk) {
    while (!c.done()) {
      uint64_t op, length;
      std::string_view content;
      const uint64_t at = c.offset();
      if (!c.u(1, &op) || !c.u(8, &length) || !c.bytes(length, &content)) return fail(error, at, "truncated record");
      Cursor r(content, at + 9);
      bool ok = true;
      if (op == kSchema) ok = schema(r);
      else if (op == kChannel) ok = channel(r);
      else if (op == kMessage) ok = message(r);
      else if (op == kChunk && !in_chunk) ok = chunk(r);
      else if (op == kChunkIndex) ++out->chunk_indexes;
      else if (op == kStatistics) out->statistics = true;
      else if (op == kFooter && !in_chunk) return c.done() || fail(error, c.offset(), "bytes after the footer");
      if (!ok) return false;
    }
    return in_chunk || fail(error, c.offset(), "no footer");
  }
};

}  // namespace

bool read(std::string_view file, Contents* out, std::string* error, const Limits& limits) {
  *out = Contents{};
  const size_t footer = 1 + 8 + 20;
  if (file.size() < 2 * kMagic.size() + footer || file.substr(0, kMagic.size()) != kMagic ||
      file.substr(file.size() - kMagic.size()) != kMagic)
    return fail(error, 0, "not an MCAP file (no magic at both ends)");
  Cursor f(file.substr(file.size() - kMagic.size() - footer, footer), file.size() - kMagic.size() - footer);
  uint64_t op, length, summary_start;
  if (!f.u(1, &op) || !f.u(8, &length) || !f.u(8, &summary_start) || op != kFooter || length != 20)
    return fail(error, f.offset(), "no footer before the closing magic");
  out->summary = summary_start != 0;
  Parser p{out, error, limits, 0, {}};
  return p.records_of(Cursor(file.substr(kMagic.size(), file.size() - 2 * kMagic.size()), kMagic.size()), false);
}

namespace {

// A map<uint16, uint64> of the summary: its keys (the values are not needed here).
bool map_keys(Cursor& c, std::vector<uint16_t>* keys, std::map<uint16_t, uint64_t>* pairs = nullptr) {
  uint64_t bytes;
  std::string_view m;
  if (!c.u(4, &bytes) || bytes % 10 != 0 || !c.bytes(bytes, &m)) return false;
  Cursor e(m, 0);
  for (uint64_t i = 0; i < bytes / 10; ++i) {
    uint64_t k = 0, v = 0;
    e.u(2, &k), e.u(8, &v);  // (within m: its size is a multiple of 10)
    if (keys) keys->push_back(static_cast<uint16_t>(k));
    if (pairs) (*pairs)[static_cast<uint16_t>(k)] = v;
  }
  return true;
}

bool chunk_index(Cursor c, Summary::ChunkIndex* ci) {
  uint64_t index_length;
  return c.u(8, &ci->start_time) && c.u(8, &ci->end_time) && c.u(8, &ci->offset) && c.u(8, &ci->length) &&
         map_keys(c, &ci->channels) && c.u(8, &index_length) && c.str(&ci->compression) &&
         c.u(8, &ci->compressed) && c.u(8, &ci->uncompressed);
}

bool statistics(Cursor c, Summary* s) {
  uint64_t skip;
  return c.u(8, &s->messages) && c.u(2, &skip) && c.u(4, &skip) && c.u(4, &skip) && c.u(4, &skip) &&
         c.u(4, &skip) && c.u(8, &s->start_time) && c.u(8, &s->end_time) && map_keys(c, nullptr, &s->per_channel);
}

// The summary's largest size read (its chunk indexes: about 70 bytes per chunk).
constexpr uint64_t kMaxSummary = uint64_t{256} << 20;

}  // namespace

bool read_summary(const Fetch& fetch, uint64_t size, Summary* out, std::string* error) {
  *out = Summary{};
  const uint64_t tail = 1 + 8 + 20 + kMagic.size();
  std::string head, end, bytes;
  if (size < kMagic.size() + tail || !fetch(0, kMagic.size(), &head) || !fetch(size - tail, tail, &end) ||
      head != kMagic || std::string_view(end).substr(29) != kMagic)
    return fail(error, 0, "not an MCAP file (no magic at both ends)");
  Cursor f(end, size - tail);
  uint64_t op, length, summary_start;
  if (!f.u(1, &op) || !f.u(8, &length) || !f.u(8, &summary_start) || op != kFooter || length != 20)
    return fail(error, size - tail, "no footer before the closing magic");
  if (summary_start == 0) return fail(error, size - tail, "no summary section");
  if (summary_start < kMagic.size() || summary_start > size - tail || size - tail - summary_start > kMaxSummary ||
      !fetch(summary_start, size - tail - summary_start, &bytes))
    return fail(error, size - tail, "the footer's summary start is out of the file");
  Contents channels;
  Parser p{&channels, error, {}, 0, {}};
  for (Cursor c(bytes, summary_start); !c.done();) {
    std::string_view content;
    const uint64_t at = c.offset();
    if (!c.u(1, &op) || !c.u(8, &length) || !c.bytes(length, &content)) return fail(error, at, "truncated record");
    const Cursor r(content, at + 9);
    bool ok = true;
    if (op == kSchema) {
      ok = p.schema(r);
    } else if (op == kChannel) {
      ok = p.channel(r);
    } else if (op == kChunkIndex) {
      out->chunks.emplace_back();
      ok = chunk_index(r, &out->chunks.back()) || fail(error, at, "truncated chunk index");
    } else if (op == kStatistics) {
      ok = (out->statistics = statistics(r, out)) || fail(error, at, "truncated statistics");
    }
    if (!ok) return false;
  }
  out->channels = std::move(channels.channels);
  return true;
}

bool read_chunk(const Fetch& fetch, const Summary& s, const Summary::ChunkIndex& ci,
                std::vector<Contents::Message>* out, std::string* error, const Limits& limits) {
  std::string bytes;
  uint64_t op, length;
  if (ci.length < 9 || ci.length > limits.max_chunk + 4096 || !fetch(ci.offset, ci.length, &bytes))
    return fail(error, ci.offset, "the chunk index points out of the file");
  Cursor c(bytes, ci.offset);
  if (!c.u(1, &op) || !c.u(8, &length) || op != kChunk || length != ci.length - 9)
    return fail(error, ci.offset, "the chunk index points at no chunk");
  Contents contents;
  contents.channels = s.channels;
  Parser p{&contents, error, limits, 0, {}};
  if (!p.chunk(Cursor(c.rest(), ci.offset + 9))) return false;
  for (auto& m : contents.messages) out->push_back(std::move(m));
  return true;
}

}  // namespace dca::mcap
