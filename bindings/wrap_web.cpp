// dca.WebServer and dca.WebConnection: the monitor's HTTP/WebSocket server (host/web) for Lua, and JSON.
//
//   local srv, err = core.web_listen("127.0.0.1:0", { max_connections = 64, max_unauthenticated = 16,
//                                                      max_message = 65536, max_queue = 4 MiB, close_queue = 16 MiB })
//   srv:address()  srv:token()  srv:add_token(t)
//   srv:add_key_token([key_file]) --> token | nil, err   -- also admit the cluster key's token (web::key_token)
//   core.monitor_token([key_file]) --> token | nil, err  -- that token, for a key holder (dca monitor --token)
//   srv:page("/", html, "text/html; charset=utf-8", true)    -- public (true) or with a token only (false)
//   srv:protocol("dca.monitor.v1", { open = function(conn) end, message = function(conn, text, binary) end,
//                                    close = function(conn, reason) end })
//   local id = srv:topic("/world/door", { "door_angle", "handle_angle" } [, units])  -- live samples (host/sample_hub;
//                                                   -- units: the manifest's text, "rad", the schema's description)
//   srv:publish(id, t_seconds, { 0.1, 0.2 })   srv:remove_topic(id)   srv:topics()
//   local ev = srv:stream_topic("/dca/events", "dca/events", schema)  -- a topic of JSON messages (host/sample_hub)
//   srv:publish_message(ev, t_seconds, json_text) --> ok  (t < 0: now on the Unix epoch; srv:topics() marks such a
//                                                          -- topic stream = true)
//   srv:robot(topic_id, { {parent, child}, ... }, urdf)  -- topic_id carries link frames (foxglove.FrameTransforms),
//                                  -- and /robot_description the URDF (host/codec/frames.h) --> its id
//   srv:history(id) --> '{"type":"history","topic":ID,"rows":[[t_s,v1,...],...]}' | nil: the topic's samples from its
//                  first, bounded and decimated (host/web/sample_history.h), as JSON text for conn:send
//   srv:stats()  srv:flush_samples() (the samples a rate held back, now)  srv:close()
//   conn:send(text [, droppable])   conn:subscribe(topic_id, rate_per_s)   conn:close(reason)
//   conn:id()  conn:is_open()  conn:peer()  conn:protocol()  conn:stats()
//   core.json_encode(value) --> text | nil, err     core.json_decode(text) --> value | nil, err
// A connection is the same userdata in every callback from open to close. An open server is never garbage
// collected: close it.
#include "bindings/wrap_web.h"

#include <lua.hpp>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <map>
#include <string_view>
#include <utility>
#include <vector>

#include "bindings/lua_loop.h"
#include "bindings/lua_support.h"
#include "bindings/lua_value.h"
#include "host/codec/frames.h"
#include "host/codec/json.h"
#include "host/net/auth.h"

namespace dca::lua {
namespace {

constexpr const char* kServerMeta = "dca.WebServer";
constexpr const char* kConnMeta = "dca.WebConnection";

struct ServerUD {
  std::shared_ptr<web::Server> s;
  LoopState* ls = nullptr;
  int self = LUA_NOREF;
};

struct ConnUD {
  web::Connection::Ptr c;
};

ServerUD* check_server_ud(lua_State* L) { return static_cast<ServerUD*>(luaL_checkudata(L, 1, kServerMeta)); }
ConnUD* check_conn(lua_State* L) { return static_cast<ConnUD*>(luaL_checkudata(L, 1, kConnMeta)); }

// A subprotocol handled by Lua functions; each connection's userdata is anchored from open to close.
class LuaProtocol : public web::Protocol {
 public:
  LuaProtocol(LoopState& ls, std::shared_ptr<LuaRef> open, std::shared_ptr<LuaRef> message,
              std::shared_ptr<LuaRef> close)
      : ls_(ls), open_(std::move(open)), message_(std::move(message)), close_(std::move(close)) {}

  void on_open(const web::Connection::Ptr& c) override {
    // the userdata is made inside the protected call (a memory error there unwinds no C++ frame)
    invoke(*open_, [this, c](lua_State* S) {
      auto* ud = static_cast<ConnUD*>(lua_newuserdatauv(S, sizeof(ConnUD), 0));
      new (ud) ConnUD{c};
      luaL_setmetatable(S, kConnMeta);
      refs_[c->id()] = anchor(S, -1);
      return 1;
    });
  }
  void on_message(const web::Connection::Ptr& c, std::string_view data, bool binary) override {
    auto it = refs_.find(c->id());
    if (it == refs_.end() || !message_) return;
    const int ref = it->second;
    invoke(*message_, [ref, data, binary](lua_State* S) {
      push_anchored(S, ref);
      lua_pushlstring(S, data.data(), data.size());
      lua_pushboolean(S, binary);
      return 3;
    });
  }
  void on_close(const web::Connection::Ptr& c, const std::string& reason) override {
    auto it = refs_.find(c->id());
    if (it == refs_.end()) return;
    int ref = it->second;
    refs_.erase(it);
    if (close_) invoke(*close_, [ref, &reason](lua_State* S) {
        push_anchored(S, ref);
        lua_pushlstring(S, reason.data(), reason.size());
        return 2;
      });
    unanchor(ls_, ref);
  }

 private:
  LoopState& ls_;
  std::shared_ptr<LuaRef> open_, message_, close_;
  std::map<std::uint64_t, int> refs_;
};

// A size option of opts (table at 2) in [1, 1 GiB], else `fallback`.
std::size_t size_option(lua_State* L, const char* name, std::size_t fallback) {
  if (lua_type(L, 2) != LUA_TTABLE) return fallback;
  lua_getfield(L, 2, name);
  std::size_t v = fallback;
  if (lua_isinteger(L, -1) && lua_tointeger(L, -1) > 0 && lua_tointeger(L, -1) <= (1 << 30))
    v = static_cast<std::size_t>(lua_tointeger(L, -1));
  lua_pop(L, 1);
  return v;
}

int core_web_listen(lua_State* L) {
  std::size_t n = 0;
  const char* addr_text = luaL_checklstring(L, 1, &n);
  if (!lua_isnoneornil(L, 2)) luaL_checktype(L, 2, LUA_TTABLE);
  LoopState& ls = loop_state(L);
  web::Limits limits;
  limits.max_connections = size_option(L, "max_connections", limits.max_connections);
  limits.max_unauthenticated = size_option(L, "max_unauthenticated", limits.max_unauthenticated);
  limits.max_message_bytes = size_option(L, "max_message", limits.max_message_bytes);
  limits.max_queue_bytes = size_option(L, "max_queue", limits.max_queue_bytes);
  limits.close_queue_bytes = size_option(L, "close_queue", limits.close_queue_bytes);
  char err[512] = {};
  std::shared_ptr<web::Server> server;
  {
    std::string error;
    auto addr = Address::parse(std::string_view(addr_text, n), &error);
    if (addr) server = web::Server::listen(ls.loop.io(), *addr, limits, &error);
    if (!server) std::snprintf(err, sizeof err, "%s", error.c_str());
  }
  if (!server) {
    lua_pushnil(L);
    lua_pushstring(L, err);
    return 2;
  }
  auto* ud = static_cast<ServerUD*>(lua_newuserdatauv(L, sizeof(ServerUD), 0));
  new (ud) ServerUD{std::move(server), &ls, LUA_NOREF};
  luaL_setmetatable(L, kServerMeta);
  ud->self = anchor(L, -1);
  return 1;
}

web::Server& open_server(lua_State* L) {
  ServerUD* ud = check_server_ud(L);
  if (!ud->s) luaL_error(L, "dca.WebServer: closed");
  return *ud->s;
}

int srv_address(lua_State* L) {
  lua_pushstring(L, open_server(L).address().str().c_str());
  return 1;
}

int srv_token(lua_State* L) {
  lua_pushstring(L, open_server(L).token().c_str());
  return 1;
}

int srv_add_token(lua_State* L) {
  web::Server& s = open_server(L);
  std::size_t n = 0;
  const char* t = luaL_checklstring(L, 2, &n);
  luaL_argcheck(L, n >= 16, 2, "a token has at least 16 characters");
  s.add_token(std::string(t, n));
  return 0;
}

// The key token (web::key_token) of the cluster key in `key_file` (auth::key_file_path's default when empty).
// False with *error when the key does not read.
bool key_token_of(const std::string& key_file, std::string* token, std::string* error) {
  const auto key = auth::load_key(auth::key_file_path(key_file), error);
  if (!key) return false;
  *token = web::key_token(*key);
  return true;
}

// Pushes `token`, or nil and `error` (the Lua side's value | nil, err). --> number of results
int token_result(lua_State* L, bool ok, const std::string& token, const std::string& error) {
  if (ok) {
    lua_pushlstring(L, token.data(), token.size());
    return 1;
  }
  lua_pushnil(L);
  lua_pushlstring(L, error.data(), error.size());
  return 2;
}

int srv_add_key_token(lua_State* L) {
  web::Server& s = open_server(L);
  const std::string file = luaL_optstring(L, 2, "");
  std::string token, error;
  const bool ok = key_token_of(file, &token, &error);
  if (ok) s.add_token(token);
  return token_result(L, ok, token, error);
}

int core_monitor_token(lua_State* L) {
  const std::string file = luaL_optstring(L, 1, "");
  std::string token, error;
  const bool ok = key_token_of(file, &token, &error);
  return token_result(L, ok, token, error);
}

int srv_page(lua_State* L) {
  web::Server& s = open_server(L);
  std::size_t pn = 0, bn = 0;
  const char* path = luaL_checklstring(L, 2, &pn);
  const char* body = luaL_checklstring(L, 3, &bn);
  const char* type = luaL_optstring(L, 4, "text/html; charset=utf-8");
  const bool pub = lua_isnoneornil(L, 5) || lua_toboolean(L, 5);
  s.set_page(std::string(path, pn), web::Page{type, std::string(body, bn)}, pub);
  return 0;
}

// The function in field `name` of the table at `index`, as a reference (nullptr when absent).
std::shared_ptr<LuaRef> field_fn(lua_State* L, int index, const char* name, LoopState& ls) {
  lua_getfield(L, index, name);
  std::shared_ptr<LuaRef> r;
  if (lua_type(L, -1) == LUA_TFUNCTION) r = std::make_shared<LuaRef>(L, -1, ls);
  lua_pop(L, 1);
  return r;
}

int srv_protocol(lua_State* L) {
  web::Server& s = open_server(L);
  ServerUD* ud = check_server_ud(L);
  const char* name = luaL_checkstring(L, 2);
  luaL_checktype(L, 3, LUA_TTABLE);
  auto open = field_fn(L, 3, "open", *ud->ls);
  luaL_argcheck(L, open != nullptr, 3, "{ open = function(conn) ..., message = ..., close = ... }");
  auto message = field_fn(L, 3, "message", *ud->ls);
  auto close = field_fn(L, 3, "close", *ud->ls);
  s.add_protocol(name, std::make_shared<LuaProtocol>(*ud->ls, open, message, close));
  return 0;
}

int srv_topic(lua_State* L) {
  web::Server& s = open_server(L);
  const char* name = luaL_checkstring(L, 2);
  std::vector<std::string> fields;
  if (lua_istable(L, 3)) {
    const lua_Integer n = luaL_len(L, 3);
    for (lua_Integer i = 1; i <= n && i <= 4096; i++) {
      lua_geti(L, 3, i);
      if (lua_type(L, -1) == LUA_TSTRING) fields.emplace_back(lua_tostring(L, -1));
      lua_pop(L, 1);
    }
  }
  const char* units = luaL_optstring(L, 4, "");
  lua_pushinteger(L, s.samples().add_topic(name, std::move(fields), units));
  return 1;
}

int srv_publish(lua_State* L) {
  web::Server& s = open_server(L);
  const lua_Integer id = luaL_checkinteger(L, 2);
  const double t = luaL_checknumber(L, 3);
  luaL_checktype(L, 4, LUA_TTABLE);
  double values[256];
  const lua_Integer n = std::min<lua_Integer>(luaL_len(L, 4), 256);
  for (lua_Integer i = 1; i <= n; i++) {
    lua_geti(L, 4, i);
    values[i - 1] = lua_tonumber(L, -1);
    lua_pop(L, 1);
  }
  const bool ok = id > 0 && s.samples().publish(static_cast<std::uint32_t>(id), static_cast<std::int64_t>(t * 1e9),
                                                std::span<const double>(values, static_cast<std::size_t>(n)));
  lua_pushboolean(L, ok);
  return 1;
}

int srv_stream_topic(lua_State* L) {
  web::Server& s = open_server(L);
  const std::string name = luaL_checkstring(L, 2);
  const std::string schema_name = luaL_checkstring(L, 3);
  const std::string schema = luaL_checkstring(L, 4);
  lua_pushinteger(L, s.samples().add_stream_topic(name, schema_name, schema));
  return 1;
}

int srv_publish_message(lua_State* L) {
  web::Server& s = open_server(L);
  const lua_Integer id = luaL_checkinteger(L, 2);
  const double t = luaL_checknumber(L, 3);
  std::size_t n = 0;
  const char* json = luaL_checklstring(L, 4, &n);
  // t < 0: now, on the Unix epoch (a wall-clock run's stamps, as its taps' arrivals)
  const std::int64_t t_ns =
      t < 0 ? std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count()
            : static_cast<std::int64_t>(t * 1e9);
  const bool ok = id > 0 && t < 9e9 &&
                  s.samples().publish_message(static_cast<std::uint32_t>(id), t_ns, std::string_view(json, n));
  lua_pushboolean(L, ok);
  return 1;
}

int srv_robot(lua_State* L) {
  web::Server& s = open_server(L);
  const lua_Integer id = luaL_checkinteger(L, 2);
  luaL_checktype(L, 3, LUA_TTABLE);
  std::size_t len = 0;
  const char* urdf = luaL_checklstring(L, 4, &len);
  std::vector<frames::Frame> fs;
  const lua_Integer n = luaL_len(L, 3);
  for (lua_Integer i = 1; i <= n && i <= 4096; i++) {
    lua_geti(L, 3, i);
    if (lua_istable(L, -1)) {
      lua_geti(L, -1, 1);
      lua_geti(L, -2, 2);
      const char* parent = lua_tostring(L, -2);
      const char* child = lua_tostring(L, -1);
      if (parent && child) fs.push_back({parent, child});
      lua_pop(L, 2);
    }
    lua_pop(L, 1);
  }
  if (id > 0) s.samples().set_frames(static_cast<std::uint32_t>(id), std::move(fs));
  lua_pushinteger(L, s.samples().add_message_topic(frames::kDescriptionTopic, frames::kDescriptionSchemaName,
                                                   frames::description_schema(),
                                                   frames::description_message(std::string(urdf, len))));
  return 1;
}

// srv:history(id) --> the page's message {"type":"history","topic":ID,"rows":[[t,v...],...]} as JSON text, or nil
// (no sample yet)
int srv_history(lua_State* L) {
  web::Server& s = open_server(L);
  const lua_Integer id = luaL_checkinteger(L, 2);
  const SampleHistory* h = id > 0 && id < 0x100000000 ? s.samples().history(static_cast<std::uint32_t>(id)) : nullptr;
  if (!h) {
    lua_pushnil(L);
    return 1;
  }
  const std::string text = "{\"type\":\"history\",\"topic\":" + std::to_string(id) + ",\"rows\":" + h->json_rows() + "}";
  lua_pushlstring(L, text.data(), text.size());
  return 1;
}

int srv_remove_topic(lua_State* L) {
  web::Server& s = open_server(L);
  s.samples().remove_topic(static_cast<std::uint32_t>(luaL_checkinteger(L, 2)));
  return 0;
}

int srv_topics(lua_State* L) {
  web::Server& s = open_server(L);
  lua_newtable(L);
  int i = 1;
  for (const auto& [id, t] : s.samples().topics()) {
    lua_createtable(L, 0, 4);
    lua_pushinteger(L, id);
    lua_setfield(L, -2, "id");
    lua_pushstring(L, t.name.c_str());
    lua_setfield(L, -2, "name");
    lua_pushinteger(L, static_cast<lua_Integer>(t.samples));
    lua_setfield(L, -2, "samples");
    lua_createtable(L, static_cast<int>(t.fields.size()), 0);
    for (std::size_t k = 0; k < t.fields.size(); k++) {
      lua_pushstring(L, t.fields[k].c_str());
      lua_rawseti(L, -2, static_cast<lua_Integer>(k + 1));
    }
    lua_setfield(L, -2, "fields");
    if (t.stream) lua_pushboolean(L, 1), lua_setfield(L, -2, "stream");
    lua_rawseti(L, -2, i++);
  }
  return 1;
}

/// Pushes a new table of counters {name = value, ...}.
void push_counters(lua_State* L, std::initializer_list<std::pair<const char*, std::uint64_t>> counters) {
  lua_createtable(L, 0, static_cast<int>(counters.size()));
  for (const auto& [name, v] : counters) {
    lua_pushinteger(L, static_cast<lua_Integer>(v));
    lua_setfield(L, -2, name);
  }
}

int srv_stats(lua_State* L) {
  const web::ServerStats st = open_server(L).stats();
  push_counters(L, {{"http_requests", st.http_requests}, {"websockets", st.websockets}, {"refused", st.refused},
                    {"bad_requests", st.bad_requests}, {"over_limit", st.over_limit}, {"open", st.open},
                    {"evicted", st.evicted}, {"authenticated", st.authenticated}});
  return 1;
}

int srv_flush_samples(lua_State* L) {
  ServerUD* ud = check_server_ud(L);
  if (ud->s) ud->s->flush_samples();
  return 0;
}

int srv_close(lua_State* L) {
  ServerUD* ud = check_server_ud(L);
  if (ud->s) ud->s->close();
  ud->s.reset();
  unanchor(*ud->ls, ud->self);
  return 0;
}

int srv_gc(lua_State* L) {
  ServerUD* ud = check_server_ud(L);
  if (ud->s && *ud->ls->alive) ud->s->close();
  ud->~ServerUD();
  return 0;
}

int srv_tostring(lua_State* L) {
  ServerUD* ud = check_server_ud(L);
  lua_pushfstring(L, "dca.WebServer(%s)", ud->s ? ud->s->address().str().c_str() : "closed");
  return 1;
}

// --- connections ----------------------------------------------------------------------------------------------

int conn_send(lua_State* L) {
  ConnUD* ud = check_conn(L);
  std::size_t n = 0;
  const char* text = luaL_checklstring(L, 2, &n);
  const bool droppable = lua_toboolean(L, 3);
  bool sent = false;
  {
    std::string data(text, n);
    sent = ud->c && ud->c->send(std::move(data), false, droppable);
  }
  lua_pushboolean(L, sent);
  return 1;
}

int conn_subscribe(lua_State* L) {
  ConnUD* ud = check_conn(L);
  const lua_Integer topic = luaL_checkinteger(L, 2);
  const double rate = luaL_optnumber(L, 3, 30);
  if (ud->c && topic > 0) ud->c->subscribe(static_cast<std::uint32_t>(topic), rate);
  return 0;
}

int conn_close(lua_State* L) {
  ConnUD* ud = check_conn(L);
  const char* reason = luaL_optstring(L, 2, "closed by the server");
  {
    const std::string why(reason);
    if (ud->c) ud->c->close(why);
  }
  return 0;
}

int conn_id(lua_State* L) {
  ConnUD* ud = check_conn(L);
  lua_pushinteger(L, ud->c ? static_cast<lua_Integer>(ud->c->id()) : 0);
  return 1;
}

int conn_is_open(lua_State* L) {
  ConnUD* ud = check_conn(L);
  lua_pushboolean(L, ud->c && ud->c->is_open());
  return 1;
}

int conn_peer(lua_State* L) {
  ConnUD* ud = check_conn(L);
  lua_pushstring(L, ud->c ? ud->c->peer().c_str() : "");
  return 1;
}

int conn_protocol(lua_State* L) {
  ConnUD* ud = check_conn(L);
  lua_pushstring(L, ud->c ? ud->c->protocol().c_str() : "");
  return 1;
}

int conn_stats(lua_State* L) {
  ConnUD* ud = check_conn(L);
  const web::ConnectionStats st = ud->c ? ud->c->stats() : web::ConnectionStats{};
  push_counters(L, {{"sent", st.sent}, {"sent_bytes", st.sent_bytes}, {"dropped", st.dropped},
                    {"received", st.received}, {"queued_bytes", st.queued_bytes}});
  return 1;
}

int conn_gc(lua_State* L) {
  check_conn(L)->~ConnUD();
  return 0;
}

int conn_tostring(lua_State* L) {
  ConnUD* ud = check_conn(L);
  lua_pushfstring(L, "dca.WebConnection(%d)", ud->c ? static_cast<int>(ud->c->id()) : 0);
  return 1;
}

// --- JSON -----------------------------------------------------------------------------------------------------

/// Runs `attempt(error)`, which pushes one result and returns true, or returns false with `error` set; the C++
/// objects it made are gone before Lua sees the error. --> 1 (the result) | 2 (nil, error)
template <class Attempt>
int one_or_error(lua_State* L, Attempt&& attempt) {
  char err[256] = {};
  bool ok = false;
  {
    std::string error;
    ok = attempt(error);
    if (!ok) std::snprintf(err, sizeof err, "%s", error.c_str());
  }
  if (ok) return 1;
  lua_pushnil(L);
  lua_pushstring(L, err);
  return 2;
}

int core_json_encode(lua_State* L) {
  luaL_checkany(L, 1);
  return one_or_error(L, [L](std::string& error) {
    wire::Value v;
    if (!to_value(L, 1, v, &error)) return false;
    const std::string text = json::encode(v);
    lua_pushlstring(L, text.data(), text.size());
    return true;
  });
}

int core_json_decode(lua_State* L) {
  std::size_t n = 0;
  const char* text = luaL_checklstring(L, 1, &n);
  return one_or_error(L, [L, text, n](std::string& error) {
    wire::Value v;
    if (!json::decode(std::string_view(text, n), &v, &error)) return false;
    push_value(L, v);
    return true;
  });
}

}  // namespace

std::shared_ptr<web::Server> check_web_server(lua_State* L, int index) {
  auto* ud = static_cast<ServerUD*>(luaL_checkudata(L, index, kServerMeta));
  if (!ud->s) luaL_error(L, "dca.WebServer: closed");
  return ud->s;
}

void register_web(lua_State* L) {
  static const luaL_Reg srv_methods[] = {
      {"address", srv_address}, {"token", srv_token},   {"add_token", srv_add_token},
      {"add_key_token", srv_add_key_token},
      {"page", srv_page},       {"protocol", srv_protocol}, {"topic", srv_topic},
      {"publish", srv_publish}, {"remove_topic", srv_remove_topic}, {"topics", srv_topics}, {"robot", srv_robot},
      {"history", srv_history},
      {"stream_topic", srv_stream_topic}, {"publish_message", srv_publish_message},
      {"stats", srv_stats},     {"flush_samples", srv_flush_samples}, {"close", srv_close},   {nullptr, nullptr}};
  register_type(L, kServerMeta, srv_methods, {srv_gc, srv_close, srv_tostring});
  static const luaL_Reg conn_methods[] = {
      {"send", conn_send}, {"subscribe", conn_subscribe}, {"close", conn_close}, {"id", conn_id},
      {"is_open", conn_is_open}, {"peer", conn_peer}, {"protocol", conn_protocol}, {"stats", conn_stats},
      {nullptr, nullptr}};
  register_type(L, kConnMeta, conn_methods, {conn_gc, nullptr, conn_tostring});
  static const luaL_Reg functions[] = {{"web_listen", core_web_listen}, {"monitor_token", core_monitor_token},
                                       {"json_encode", core_json_encode}, {"json_decode", core_json_decode},
                                       {nullptr, nullptr}};
  luaL_setfuncs(L, functions, 0);
}

}  // namespace dca::lua
