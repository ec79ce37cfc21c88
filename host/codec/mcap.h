#pragma once
// host/codec: pure encoders and decoders. No Asio, no Beast, no socket, nothing of host/net or host/web.
// MCAP (https://mcap.dev/spec), the recording format of Foxglove, Lichtblick, PlotJuggler and rosbag2: a small
// writer of chunked, indexed files with a summary section, and a reader of what such files hold. Pure of I/O
// policy: the writer hands its bytes to a sink, the reader parses bytes in memory (or fetches ranges through a
// callback: read_summary / read_chunk). Channels carry JSON messages described by a JSON Schema (one schema per
// channel), or ROS 2 messages as CDR described by their ros2msg definition (the encodings of the `ros2` profile).
// Chunks are compressed with zstd or lz4 (an LZ4 frame), or not; every chunk is followed by its message indexes,
// and the summary holds the schemas, channels, chunk indexes and statistics, with a summary offset record per
// group. Decompression is bounded: a chunk that says it holds more than Limits::max_chunk bytes, a
// file whose chunks hold more than Limits::max_total, or a chunk that does not decompress to its stated size is
// an error, never a crash.
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace dca::mcap {

/// Takes the next bytes of the file; false when it could not (the writer then stops writing).
using Sink = std::function<bool(std::string_view bytes)>;

/// A chunk's compression ("zstd", "lz4" or "" in the file).
enum class Compression { none, zstd, lz4 };
/// Its name as the file says it: "", "zstd", "lz4".
const char* compression_name(Compression c);
/// "none" (or ""), "zstd", "lz4": false for any other name.
bool parse_compression(std::string_view name, Compression* out);

/// What a writer wrote so far.
struct Stats {
  uint64_t messages = 0;
  uint32_t chunks = 0;
  uint64_t start_time = 0, end_time = 0;  // the earliest and latest log time (ns), 0 without messages
  std::map<uint16_t, uint64_t> per_channel;  // message count by channel id
  uint64_t bytes = 0;                         // the file's bytes handed to the sink
  uint64_t chunk_bytes = 0;                   // the chunks' records before compression
};

/// A channel as a writer writes it: JSON messages with a JSON Schema, or (`cdr`) a ROS 2 message's CDR (with its
/// 4-byte encapsulation header) with the message's definition as schema (encoding "ros2msg", named "pkg/msg/T").
struct ChannelSpec {
  std::string topic, schema_name, schema;
  bool cdr = false;
};

class Writer {
 public:
  /// Writes the magic and the header (with `profile`: "" for none, "ros2") at once. A chunk is closed when its
  /// records reach `chunk_bytes`.
  explicit Writer(Sink sink, std::string library = "dca", size_t chunk_bytes = 256 * 1024,
                  Compression compression = Compression::none, const std::string& profile = "");
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;
  /// A channel of JSON messages on `topic`, described by the JSON Schema `schema` (named `schema_name`).
  /// Returns its id (1, 2, ...).
  uint16_t add_channel(const std::string& topic, const std::string& schema_name, const std::string& schema);
  /// A channel of either kind (ChannelSpec). Returns its id.
  uint16_t add_channel(const ChannelSpec& spec);
  /// Appends one message (JSON text, or CDR on a `cdr` channel) on `channel` at `log_time_ns` (also its publish time).
  void write(uint16_t channel, uint64_t log_time_ns, std::string_view json);
  /// Closes the last chunk and writes the data end, the summary, the summary offsets, the footer and the magic.
  /// False when the sink failed at any point. Nothing can be written after.
  bool finish();
  bool ok() const { return ok_; }
  const Stats& stats() const { return stats_; }
  const std::string& topic(uint16_t channel) const { return channels_.at(channel - 1).topic; }
  /// The compression of the chunks closed from now on.
  void set_compression(Compression c) { compression_ = c; }
  /// The open chunk's records (not yet handed to the sink).
  size_t pending_bytes() const { return chunk_.size(); }
  /// Channels added so far (their ids are 1..channels()).
  size_t channels() const { return channels_.size(); }

 private:
  using Channel = ChannelSpec;
  struct ChunkIndex {
    uint64_t start_time, end_time, offset, length, index_length, size, compressed;
    std::map<uint16_t, uint64_t> index_offsets;
    Compression compression = Compression::none;
  };
  void emit(std::string_view bytes);
  void flush_chunk();
  std::string schema_record(uint16_t id) const;
  std::string channel_record(uint16_t id) const;
  std::string statistics_record() const;

  Sink sink_;
  size_t chunk_bytes_;
  Compression compression_;
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
    std::string schema;  ///< the schema's data (a JSON Schema's text, a ros2msg definition); "" when absent
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

/// What a reader decompresses at most.
struct Limits {
  uint64_t max_chunk = uint64_t{256} << 20;  ///< one chunk's records
  uint64_t max_total = uint64_t{4} << 30;    ///< all the chunks of a file read whole
};

/// Parses a whole file. False with *error ("offset N: what") when it is not a well-formed MCAP file this reader
/// understands (chunks uncompressed, zstd or lz4). Never crashes on malformed input.
bool read(std::string_view file, Contents* out, std::string* error, const Limits& limits = {});

/// Reads `length` bytes at `offset` of a file into *out: false when it cannot (past the end, an I/O error).
using Fetch = std::function<bool(uint64_t offset, uint64_t length, std::string* out)>;

/// A file's summary section, read without its data section (read_summary).
struct Summary {
  struct ChunkIndex {
    uint64_t start_time = 0, end_time = 0;  ///< its messages' log times (ns)
    uint64_t offset = 0, length = 0;        ///< the chunk record in the file
    std::string compression;
    uint64_t compressed = 0, uncompressed = 0;
    std::vector<uint16_t> channels;         ///< the channels with messages in it (its message indexes)
  };
  std::map<uint16_t, Contents::Channel> channels;
  std::vector<ChunkIndex> chunks;              ///< in file order
  uint64_t messages = 0, start_time = 0, end_time = 0;  ///< the statistics (0 without)
  std::map<uint16_t, uint64_t> per_channel;    ///< message count by channel id (statistics)
  bool statistics = false;
};

/// Reads the footer and the summary section of a file of `size` bytes through `fetch`: a few small reads at its
/// end. False with *error when the file has no summary (footer's summary start 0) or it is malformed.
bool read_summary(const Fetch& fetch, uint64_t size, Summary* out, std::string* error);

/// Reads the chunk `c` of the summary through `fetch` and appends its messages (on the summary's channels) to *out,
/// in chunk order. False with *error when it is malformed, its CRC wrong, or larger than `limits.max_chunk`.
bool read_chunk(const Fetch& fetch, const Summary& s, const Summary::ChunkIndex& c,
                std::vector<Contents::Message>* out, std::string* error, const Limits& limits = {});

}  // namespace dca::mcap
