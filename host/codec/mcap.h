#pragma once
// host/codec: pure encoders and decoders. No Asio, no Beast, no socket, nothing of host/net or host/web.
// MCAP (https://mcap.dev/spec), the recording format of Foxglove, Lichtblick, PlotJuggler and rosbag2: a small
// writer of chunked, indexed files with a summary section, and a reader of what such files hold. Pure of I/O
// policy: the writer hands its bytes to a sink, the reader parses bytes in memory. Channels carry JSON messages
// described by a JSON Schema (one schema per channel). Chunks are uncompressed (no compression library is
// needed to read them); every chunk is followed by its message indexes, and the summary holds the schemas,
// channels, chunk indexes and statistics, with a summary offset record per group.
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace dca::mcap {

/// Takes the next bytes of the file; false when it could not (the writer then stops writing).
using Sink = std::function<bool(std::string_view bytes)>;

/// What a writer wrote so far.
struct Stats {
  uint64_t messages = 0;
  uint32_t chunks = 0;
  uint64_t start_time = 0, end_time = 0;  // the earliest and latest log time (ns), 0 without messages
  std::map<uint16_t, uint64_t> per_channel;  // message count by channel id
};

class Writer {
 public:
  /// Writes the magic and the header at once. A chunk is closed when its records reach `chunk_bytes`.
  explicit Writer(Sink sink, std::string library = "dca", size_t chunk_bytes = 256 * 1024);
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;
  /// A channel of JSON messages on `topic`, described by the JSON Schema `schema` (named `schema_name`).
  /// Returns its id (1, 2, ...).
  uint16_t add_channel(const std::string& topic, const std::string& schema_name, const std::string& schema);
  /// Appends one message (JSON text) on `channel` at `log_time_ns` (also its publish time).
  void write(uint16_t channel, uint64_t log_time_ns, std::string_view json);
  /// Closes the last chunk and writes the data end, the summary, the summary offsets, the footer and the magic.
  /// False when the sink failed at any point. Nothing can be written after.
  bool finish();
  bool ok() const { return ok_; }
  const Stats& stats() const { return stats_; }
  const std::string& topic(uint16_t channel) const { return channels_.at(channel - 1).topic; }
  /// Channels added so far (their ids are 1..channels()).
  size_t channels() const { return channels_.size(); }

 private:
  struct Channel {
    std::string topic, schema_name, schema;
  };
  struct ChunkIndex {
    uint64_t start_time, end_time, offset, length, index_length, size;
    std::map<uint16_t, uint64_t> index_offsets;
  };
  void emit(std::string_view bytes);
  void flush_chunk();
  std::string schema_record(uint16_t id) const;
  std::string channel_record(uint16_t id) const;
  std::string statistics_record() const;

  Sink sink_;
  size_t chunk_bytes_;
  bool ok_ = true, finished_ = false;
  uint64_t offset_ = 0;  // bytes written so far
  std::vector<Channel> channels_;
  std::string chunk_;  // the open chunk's records
  uint64_t chunk_start_ = 0, chunk_end_ = 0;
  std::map<uint16_t, std::vector<std::pair<uint64_t, uint64_t>>> chunk_index_;  // channel -> (time, offset)
  std::vector<ChunkIndex> chunk_indexes_;
  Stats stats_;
};

/// The CRC32 (IEEE, as zlib's crc32) of `bytes`, continuing from `crc`.
uint32_t crc32(std::string_view bytes, uint32_t crc = 0);

/// What a file holds: its channels (topic and schema by channel id), its messages in file order, and whether it
/// has the parts indexed readers need.
struct Contents {
  struct Channel {
    std::string topic, message_encoding, schema_name, schema_encoding;
  };
  struct Message {
    uint16_t channel;
    uint64_t log_time;
    std::string data;
  };
  std::map<uint16_t, Channel> channels;
  std::vector<Message> messages;
  uint32_t chunks = 0, chunk_indexes = 0;
  bool statistics = false, summary = false;
};

/// Parses a whole file. False with *error ("offset N: what") when it is not a well-formed MCAP file this reader
/// understands (compressed chunks are refused). Never crashes on malformed input.
bool read(std::string_view file, Contents* out, std::string* error);

}  // namespace dca::mcap
