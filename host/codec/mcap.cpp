#include "host/codec/mcap.h"

#include <algorithm>
#include <array>
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

}  // namespace

uint32_t crc32(std::string_view bytes, uint32_t crc) {
  static const std::array<uint32_t, 256> table = crc_table();
  crc = ~crc;
  for (unsigned char c : bytes) crc = table[(crc ^ c) & 0xff] ^ (crc >> 8);
  return ~crc;
}

Writer::Writer(Sink sink, std::string library, size_t chunk_bytes)
    : sink_(std::move(sink)), chunk_bytes_(chunk_bytes) {
  std::string header;
  str(header, "");  // profile: none of the well-known ones (JSON messages)
  str(header, library);
  emit(kMagic);
  emit(record(kHeader, header));
}

void Writer::emit(std::string_view bytes) {
  if (!ok_) return;
  ok_ = sink_(bytes);
  offset_ += bytes.size();
}

std::string Writer::schema_record(uint16_t id) const {
  const Channel& c = channels_[id - 1];
  std::string s;
  u16(s, id);
  str(s, c.schema_name);
  str(s, "jsonschema");
  str(s, c.schema);
  return record(kSchema, s);
}

std::string Writer::channel_record(uint16_t id) const {
  std::string s;
  u16(s, id);
  u16(s, id);  // its schema: one per channel, with the same id
  str(s, channels_[id - 1].topic);
  str(s, "json");
  u32(s, 0);  // metadata: an empty map
  return record(kChannel, s);
}

uint16_t Writer::add_channel(const std::string& topic, const std::string& schema_name, const std::string& schema) {
  flush_chunk();  // a channel precedes every message on it: outside the chunks, in the data section
  channels_.push_back({topic, schema_name, schema});
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
  std::string c;
  u64(c, chunk_start_);
  u64(c, chunk_end_);
  u64(c, chunk_.size());
  u32(c, crc32(chunk_));
  str(c, "");  // no compression
  u64(c, chunk_.size());
  c += chunk_;
  ChunkIndex ci{chunk_start_, chunk_end_, offset_, 0, 0, chunk_.size(), {}};
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
    str(s, "");
    u64(s, ci.size);
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

struct Parser {
  Contents* out;
  std::string* error;
  std::map<uint16_t, std::pair<std::string, std::string>> schemas;  // id -> name, encoding

  bool schema(Cursor c) {
    uint64_t id;
    std::string name, encoding;
    if (!c.u(2, &id) || !c.str(&name) || !c.str(&encoding)) return fail(error, c.offset(), "truncated schema");
    schemas[static_cast<uint16_t>(id)] = {name, encoding};
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
      ch.schema_name = s->second.first;
      ch.schema_encoding = s->second.second;
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
    if (!compression.empty()) return fail(error, c.offset(), "compressed chunk ('" + compression + "')");
    const uint64_t at = c.offset();
    if (!c.bytes(length, &records) || length != size) return fail(error, at, "chunk records do not fit");
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

bool read(std::string_view file, Contents* out, std::string* error) {
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
  Parser p{out, error, {}};
  return p.records_of(Cursor(file.substr(kMagic.size(), file.size() - 2 * kMagic.size()), kMagic.size()), false);
}

}  // namespace dca::mcap
