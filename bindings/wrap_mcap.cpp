// core.mcap_read: what an MCAP recording holds (host/mcap's bounds-checked reader), for Lua (`dca monitor
// FILE.mcap` replays a recording).
//
//   local rec, err = core.mcap_read("run.mcap")
//   rec.channels[id] = { topic = "/world/door", schema = "/world/door", encoding = "json", schema_data = JSON_SCHEMA }
//   rec.messages[i]  = { channel = id, t = log time in ns (integer), data = "{...}" }   -- in file order
// A channel of the `ros2` profile (encoding "cdr", a ros2msg schema named as one of dca's message types,
// e.g. "sensor_msgs/msg/JointState") has its messages decoded: data = {"value": {fields by name}}, the JSON a
// message port's sample has in a recording without the profile (null for a message that does not decode); its
// channel says encoding = "cdr", decoded = true. Other CDR channels keep their bytes (decoded = nil).
//
// core.mcap_message_json(encoding, schema_encoding, schema_name, data): that decoding of one message, for readers
// of their own (the monitor's): the JSON text, or nil when the channel is not such a CDR channel.
// A file that is not a well-formed MCAP file this reader understands: nil and the reason ("offset N: ...").
//
// core.mcap_index: a recording read through its summary (chunk indexes, statistics), a chunk at a time, so a long
// recording is never held whole (`dca monitor FILE.mcap`, dca.monitor.replay):
//   local idx, err = core.mcap_index("run.mcap")   -- its footer and summary read | nil, reason
//   idx:summary()   --> { channels = { [id] = {topic, schema, encoding, decoded} }, counts = { [id] = messages },
//                   --     chunks = { { start = ns, finish = ns, channels = { [id] = true } }, ... } (file order),
//                   --     messages, start, finish }
//   idx:chunk(i)    --> the messages of chunk i, { {channel, t, data}, ... } as core.mcap_read's | nil, reason
//   idx:chunks_read() --> how many chunks idx:chunk has read so far (for tests: what opening a file costs)
//
// core.mcap_writer: an MCAP recording written from Lua (host/codec/mcap.h's Writer on a file), for the recordings
// of wall-clock runs (dca.launch.wall_record):
//   local w, err = core.mcap_writer("run.mcap")    -- the file created (truncated) | nil, reason
//   local id = w:channel(topic, schema_name, schema)  -- a channel of JSON messages described by a JSON Schema
//   w:write(id, json [, t_ns])      -- one message; log time t_ns (integer), by default now on CLOCK_REALTIME
//   local st, err = w:finish()      -- the summary written and the file closed: st = {messages, chunks,
//                                   -- channels = {{topic, n}, ...} by id} | nil, reason (a failed write)
// A writer dropped without finish() closes its file as it stands (not a valid recording). Nothing is written
// after finish(), nor after a failed write (write() is then a no-op; finish() says why).
#include <lua.hpp>

#include <sys/types.h>
#include <time.h>

#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "bindings/lua_support.h"
#include "host/codec/mcap.h"
#include "host/codec/msgs.h"

namespace dca::bindings {
namespace {

// The recording's bytes: at most 1 GiB. False with *error.
bool slurp(const char* path, std::string* out, std::string* error) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    *error = "cannot read the recording";
    return false;
  }
  f.seekg(0, std::ios::end);
  const auto size = f.tellg();
  if (size < 0 || size > (std::streamoff{1} << 30)) {
    *error = "not a file of at most 1 GiB";
    return false;
  }
  f.seekg(0);
  out->resize(static_cast<std::size_t>(size));
  f.read(out->data(), size);
  return static_cast<bool>(f);
}

// The message type of a `ros2` profile channel of dca's types, or nullptr.
const msgs::TypeInfo* cdr_type(std::string_view encoding, std::string_view schema_encoding, std::string_view name) {
  return encoding == "cdr" && schema_encoding == "ros2msg" ? msgs::find_type(name) : nullptr;
}

// A CDR message of type t as a recorded message port's JSON sample.
std::string cdr_json(const msgs::TypeInfo& t, std::string_view data) {
  return "{\"value\":" + t.json(std::as_bytes(std::span(data.data(), data.size()))) + "}";
}

int l_mcap_message_json(lua_State* L) {
  std::size_t n = 0;
  const char* data = luaL_checklstring(L, 4, &n);
  const auto* t = cdr_type(luaL_checkstring(L, 1), luaL_checkstring(L, 2), luaL_checkstring(L, 3));
  if (!t) return lua_pushnil(L), 1;
  const std::string json = cdr_json(*t, std::string_view(data, n));
  lua_pushlstring(L, json.data(), json.size());
  return 1;
}

// Pushes channels as { [id] = {topic, schema, encoding, schema_data, decoded} } (schema_data: the schema's text) (decoded: a CDR channel of dca's types,
// whose messages come as their JSON).
void push_channels(lua_State* L, const std::map<uint16_t, mcap::Contents::Channel>& channels) {
  lua_createtable(L, 0, static_cast<int>(channels.size()));
  for (const auto& [id, ch] : channels) {
    lua_createtable(L, 0, 3);
    lua_pushlstring(L, ch.topic.data(), ch.topic.size());
    lua_setfield(L, -2, "topic");
    lua_pushlstring(L, ch.schema_name.data(), ch.schema_name.size());
    lua_setfield(L, -2, "schema");
    lua_pushlstring(L, ch.message_encoding.data(), ch.message_encoding.size());
    lua_setfield(L, -2, "encoding");
    lua_pushlstring(L, ch.schema.data(), ch.schema.size());
    lua_setfield(L, -2, "schema_data");
    if (cdr_type(ch.message_encoding, ch.schema_encoding, ch.schema_name) != nullptr) {
      lua_pushboolean(L, 1);
      lua_setfield(L, -2, "decoded");
    }
    lua_rawseti(L, -2, id);
  }
}

// Pushes messages as { {channel, t, data}, ... }, those of a CDR channel of dca's types as their JSON.
void push_messages(lua_State* L, const std::vector<mcap::Contents::Message>& messages,
                   const std::map<uint16_t, mcap::Contents::Channel>& channels) {
  std::map<std::uint16_t, const msgs::TypeInfo*> decoders;
  for (const auto& [id, ch] : channels)
    if (const auto* t = cdr_type(ch.message_encoding, ch.schema_encoding, ch.schema_name)) decoders[id] = t;
  lua_createtable(L, static_cast<int>(messages.size()), 0);
  lua_Integer i = 1;
  for (const auto& m : messages) {
    lua_createtable(L, 0, 3);
    lua_pushinteger(L, m.channel);
    lua_setfield(L, -2, "channel");
    lua_pushinteger(L, static_cast<lua_Integer>(m.log_time));
    lua_setfield(L, -2, "t");
    if (const auto d = decoders.find(m.channel); d != decoders.end()) {
      const std::string json = cdr_json(*d->second, m.data);
      lua_pushlstring(L, json.data(), json.size());
    } else {
      lua_pushlstring(L, m.data.data(), m.data.size());
    }
    lua_setfield(L, -2, "data");
    lua_rawseti(L, -2, i++);
  }
}

// Pushes the contents as the table described above.
void push_contents(lua_State* L, const mcap::Contents& c) {
  lua_createtable(L, 0, 2);
  push_channels(L, c.channels);
  lua_setfield(L, -2, "channels");
  push_messages(L, c.messages, c.channels);
  lua_setfield(L, -2, "messages");
}

constexpr const char* kContentsMeta = "dca.McapContents";

int contents_gc(lua_State* L) {
  static_cast<mcap::Contents*>(luaL_checkudata(L, 1, kContentsMeta))->~Contents();
  return 0;
}

int l_mcap_read(lua_State* L) {
  const char* path = luaL_checkstring(L, 1);
  // the contents live in a userdata (freed by its __gc), so a Lua error while the tables are built leaks nothing
  auto* contents = static_cast<mcap::Contents*>(lua_newuserdatauv(L, sizeof(mcap::Contents), 0));
  new (contents) mcap::Contents();
  luaL_setmetatable(L, kContentsMeta);
  char err[512] = {};
  try {
    std::string bytes, error;
    if (!slurp(path, &bytes, &error) || !mcap::read(bytes, contents, &error))
      std::snprintf(err, sizeof err, "%s: %s", path, error.c_str());
  } catch (const std::exception& e) {
    std::snprintf(err, sizeof err, "%s: %s", path, e.what());
  }
  if (err[0] != '\0') {
    lua_pushnil(L);
    lua_pushstring(L, err);
    return 2;
  }
  push_contents(L, *contents);
  return 1;
}

// -------------------------------------------------------------------------------------------- the index ---

constexpr const char* kIndexMeta = "dca.McapIndex";

struct LuaIndex {
  std::FILE* file = nullptr;
  std::string path;
  uint64_t size = 0;
  mcap::Summary summary;
  lua_Integer chunks_read = 0;
  void close() {
    if (file) std::fclose(file);
    file = nullptr;
  }
  // Reads `length` bytes at `offset`: false past the end (nothing allocated) or on an I/O error.
  bool fetch(uint64_t offset, uint64_t length, std::string* out) const {
    if (!file || offset > size || length > size - offset || ::fseeko(file, static_cast<off_t>(offset), SEEK_SET) != 0)
      return false;
    out->resize(static_cast<std::size_t>(length));
    return std::fread(out->data(), 1, out->size(), file) == out->size();
  }
};

LuaIndex* check_index(lua_State* L) { return static_cast<LuaIndex*>(luaL_checkudata(L, 1, kIndexMeta)); }

int index_gc(lua_State* L) {
  auto* x = check_index(L);
  x->close();
  x->~LuaIndex();
  return 0;
}

int l_mcap_index(lua_State* L) {
  const char* path = luaL_checkstring(L, 1);
  auto* x = static_cast<LuaIndex*>(lua_newuserdatauv(L, sizeof(LuaIndex), 0));
  new (x) LuaIndex();
  luaL_setmetatable(L, kIndexMeta);
  x->path = path;
  x->file = std::fopen(path, "rb");
  std::string error = "cannot read the recording";
  bool ok = false;
  if (x->file && std::fseek(x->file, 0, SEEK_END) == 0) {
    const off_t size = ::ftello(x->file);
    x->size = size >= 0 ? static_cast<uint64_t>(size) : 0;
    try {
      ok = size >= 0 && mcap::read_summary([x](uint64_t o, uint64_t n, std::string* out) { return x->fetch(o, n, out); },
                                           x->size, &x->summary, &error);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  if (!ok) {
    x->close();
    lua_pushnil(L);
    lua_pushfstring(L, "%s: %s", path, error.c_str());
    return 2;
  }
  return 1;
}

int index_summary(lua_State* L) {
  const auto& s = check_index(L)->summary;
  lua_createtable(L, 0, 6);
  push_channels(L, s.channels);
  lua_setfield(L, -2, "channels");
  lua_createtable(L, 0, static_cast<int>(s.per_channel.size()));
  for (const auto& [id, n] : s.per_channel) {
    lua_pushinteger(L, static_cast<lua_Integer>(n));
    lua_rawseti(L, -2, id);
  }
  lua_setfield(L, -2, "counts");
  lua_createtable(L, static_cast<int>(s.chunks.size()), 0);
  lua_Integer i = 1;
  for (const auto& c : s.chunks) {
    lua_createtable(L, 0, 3);
    lua_pushinteger(L, static_cast<lua_Integer>(c.start_time));
    lua_setfield(L, -2, "start");
    lua_pushinteger(L, static_cast<lua_Integer>(c.end_time));
    lua_setfield(L, -2, "finish");
    lua_createtable(L, 0, static_cast<int>(c.channels.size()));
    for (const auto id : c.channels) {
      lua_pushboolean(L, 1);
      lua_rawseti(L, -2, id);
    }
    lua_setfield(L, -2, "channels");
    lua_rawseti(L, -2, i++);
  }
  lua_setfield(L, -2, "chunks");
  lua_pushinteger(L, static_cast<lua_Integer>(s.messages));
  lua_setfield(L, -2, "messages");
  lua_pushinteger(L, static_cast<lua_Integer>(s.start_time));
  lua_setfield(L, -2, "start");
  lua_pushinteger(L, static_cast<lua_Integer>(s.end_time));
  lua_setfield(L, -2, "finish");
  return 1;
}

int index_chunk(lua_State* L) {
  auto* x = check_index(L);
  const lua_Integer i = luaL_checkinteger(L, 2);
  if (i < 1 || static_cast<std::size_t>(i) > x->summary.chunks.size())
    return luaL_error(L, "%s: no chunk %d", x->path.c_str(), static_cast<int>(i));
  // the messages live in a userdata (freed by its __gc), so a Lua error while the tables are built leaks nothing
  auto* contents = static_cast<mcap::Contents*>(lua_newuserdatauv(L, sizeof(mcap::Contents), 0));
  new (contents) mcap::Contents();
  luaL_setmetatable(L, kContentsMeta);
  std::string error;
  bool ok = false;
  try {
    ok = mcap::read_chunk([x](uint64_t o, uint64_t n, std::string* out) { return x->fetch(o, n, out); }, x->summary,
                          x->summary.chunks[static_cast<std::size_t>(i - 1)], &contents->messages, &error);
  } catch (const std::exception& e) {
    error = e.what();
  }
  ++x->chunks_read;
  if (!ok) {
    lua_pushnil(L);
    lua_pushfstring(L, "%s: %s", x->path.c_str(), error.c_str());
    return 2;
  }
  push_messages(L, contents->messages, x->summary.channels);
  return 1;
}

int index_chunks_read(lua_State* L) {
  lua_pushinteger(L, check_index(L)->chunks_read);
  return 1;
}

// ------------------------------------------------------------------------------------------- the writer ---

constexpr const char* kWriterMeta = "dca.McapWriter";

struct LuaWriter {
  std::FILE* file = nullptr;
  std::optional<mcap::Writer> writer;
  std::string path;
  bool finished = false;
  void close() {
    if (file) std::fclose(file);
    file = nullptr;
  }
};

LuaWriter* check_writer(lua_State* L) { return static_cast<LuaWriter*>(luaL_checkudata(L, 1, kWriterMeta)); }

// The writer still open: else a Lua error.
mcap::Writer& open_writer(lua_State* L) {
  auto* w = check_writer(L);
  if (w->finished || !w->writer) luaL_error(L, "mcap writer %s: already finished", w->path.c_str());
  return *w->writer;
}

int writer_gc(lua_State* L) {
  auto* w = check_writer(L);
  w->writer.reset();
  w->close();
  w->~LuaWriter();
  return 0;
}

int l_mcap_writer(lua_State* L) {
  const char* path = luaL_checkstring(L, 1);
  auto* w = static_cast<LuaWriter*>(lua_newuserdatauv(L, sizeof(LuaWriter), 0));
  new (w) LuaWriter();
  luaL_setmetatable(L, kWriterMeta);
  w->path = path;
  w->file = std::fopen(path, "wb");
  if (!w->file) {
    lua_pushnil(L);
    lua_pushfstring(L, "%s: cannot create the recording", path);
    return 2;
  }
  std::FILE* f = w->file;
  w->writer.emplace([f](std::string_view bytes) {
    return std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  });
  return 1;
}

int writer_channel(lua_State* L) {
  auto& w = open_writer(L);
  const char* topic = luaL_checkstring(L, 2);
  const char* name = luaL_checkstring(L, 3);
  const char* schema = luaL_checkstring(L, 4);
  if (w.channels() >= 60000) return luaL_error(L, "mcap writer: too many channels");
  lua_pushinteger(L, w.add_channel(topic, name, schema));
  return 1;
}

int writer_write(lua_State* L) {
  auto& w = open_writer(L);
  const lua_Integer id = luaL_checkinteger(L, 2);
  size_t n = 0;
  const char* json = luaL_checklstring(L, 3, &n);
  if (id < 1 || static_cast<size_t>(id) > w.channels())
    return luaL_error(L, "mcap writer: no channel %d", static_cast<int>(id));
  std::uint64_t t = 0;
  if (lua_isnoneornil(L, 4)) {
    timespec ts{};
    ::clock_gettime(CLOCK_REALTIME, &ts);
    t = static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ULL + static_cast<std::uint64_t>(ts.tv_nsec);
  } else {
    const lua_Integer x = luaL_checkinteger(L, 4);
    t = x < 0 ? 0 : static_cast<std::uint64_t>(x);
  }
  if (w.ok()) w.write(static_cast<std::uint16_t>(id), t, std::string_view(json, n));
  return 0;
}

int writer_finish(lua_State* L) {
  auto* lw = check_writer(L);
  auto& w = open_writer(L);
  const bool ok = w.finish();
  lw->finished = true;
  const bool closed = std::fclose(lw->file) == 0;
  lw->file = nullptr;
  if (!(ok && closed)) {
    lua_pushnil(L);
    lua_pushfstring(L, "%s: error writing the recording", lw->path.c_str());
    return 2;
  }
  const auto& st = w.stats();
  lua_createtable(L, 0, 3);
  lua_pushinteger(L, static_cast<lua_Integer>(st.messages));
  lua_setfield(L, -2, "messages");
  lua_pushinteger(L, static_cast<lua_Integer>(st.chunks));
  lua_setfield(L, -2, "chunks");
  lua_createtable(L, static_cast<int>(w.channels()), 0);
  for (size_t c = 1; c <= w.channels(); ++c) {
    const auto id = static_cast<std::uint16_t>(c);
    const auto it = st.per_channel.find(id);
    lua_createtable(L, 2, 0);
    lua_pushstring(L, w.topic(id).c_str());
    lua_rawseti(L, -2, 1);
    lua_pushinteger(L, static_cast<lua_Integer>(it == st.per_channel.end() ? 0 : it->second));
    lua_rawseti(L, -2, 2);
    lua_rawseti(L, -2, static_cast<lua_Integer>(c));
  }
  lua_setfield(L, -2, "channels");
  return 1;
}

}  // namespace

void open_mcap(lua_State* L) {
  static const luaL_Reg none[] = {{nullptr, nullptr}};
  lua::register_type(L, kContentsMeta, none, {contents_gc, nullptr, nullptr});
  static const luaL_Reg writer[] = {
      {"channel", writer_channel}, {"write", writer_write}, {"finish", writer_finish}, {nullptr, nullptr}};
  lua::register_type(L, kWriterMeta, writer, {writer_gc, nullptr, nullptr});
  static const luaL_Reg index[] = {
      {"summary", index_summary}, {"chunk", index_chunk}, {"chunks_read", index_chunks_read}, {nullptr, nullptr}};
  lua::register_type(L, kIndexMeta, index, {index_gc, nullptr, nullptr});
  static const luaL_Reg functions[] = {{"mcap_read", l_mcap_read}, {"mcap_writer", l_mcap_writer},
                                       {"mcap_index", l_mcap_index}, {"mcap_message_json", l_mcap_message_json},
                                       {nullptr, nullptr}};
  luaL_setfuncs(L, functions, 0);
}

}  // namespace dca::bindings
