// dca.TapPoint and core.foxglove: live taps (host/net/tap.h) whose samples feed the live samples of the monitor's
// server (host/web, host/sample_hub), and the Foxglove WebSocket protocol (host/web/foxglove.h) on that server.
//
//   local tp, err = core.tap_point{ name = "taps:main@123", host = "h1", key_file = PATH, tcp = "127.0.0.1:0",
//                                   server = srv,        -- srv: a dca.WebServer (core.web_listen)
//                                   stamp = "writer" | "arrival" }  -- a sample's time: the writer's clock (simulated
//                                   -- time), or its arrival here on the Unix epoch (wall-clock runs: the nodes'
//                                   -- monotonic clocks mean nothing to a viewer, nor across hosts)
//   tp:endpoints()   --> { host =, data_uds =, data_tcp = }   (what the daemon's `register` takes)
//   tp:add(path, port_type, size, units, queue[, message]) --> the topic ("/main/door/hit/Force") | nil, err: its
//                    samples go to that topic of srv's samples (fields "value", or "value[0]".. for a vector; a
//                    value or message port's samples are counted, not published)
//   tp:stats()       --> { [path] = { taken =, dropped =, unpublished = } }
//   tp:close()
//   core.foxglove(srv, { name = "dca main", subscribe = fn(topic), unsubscribe = fn(topic),
//                        get_parameters = fn(names, reply), set_parameters = fn(params, reply) })
//                    -- serves foxglove.websocket.v1 on srv: subscribe(topic) runs when a channel gets its first
//                    -- subscriber, unsubscribe(topic) when it loses its last; with both parameter functions the
//                    -- server has the capability `parameters`: get_parameters({name...}) (empty: every one),
//                    -- set_parameters({ {name =, value =}... }), each answering once, now or later, with
//                    -- reply({ {name =, value =}... }) or reply(nil, error); time = true: simulated time (the
//                    -- capability `time`), watch = fn() when a client subscribes to its first channel
//                    --> fox: fox:time(t_seconds) (the run's time now), fox:end_time(t_seconds) (the run's end:
//                    --  no Time after it), fox:graph(published, subscribed) (each
//                    --  { {topic, {id...}}... }: the capability connectionGraph), fox:clients() --> how many
#include <lua.hpp>

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <vector>

#include "bindings/lua_loop.h"
#include "bindings/lua_support.h"
#include "bindings/lua_value.h"
#include "bindings/wrap_web.h"
#include "host/net/auth.h"
#include "host/net/tap.h"
#include "host/paths.h"
#include "host/web/foxglove.h"

namespace dca::bindings {
namespace {

constexpr const char* kMeta = "dca.TapPoint";

struct TapUD {
  std::unique_ptr<tap::TapPoint> point;
  std::weak_ptr<web::Server> server;
  std::map<std::string, std::uint32_t> topics;        // path -> topic id in the server's samples
  std::map<std::string, std::uint64_t> unpublished;  // path -> samples not published (value ports, no server)
  bool arrival = false;  // published at their arrival (the Unix epoch), not at the writer's stamp
};

TapUD* check(lua_State* L) {
  auto* ud = static_cast<TapUD*>(luaL_checkudata(L, 1, kMeta));
  if (!ud->point) luaL_error(L, "dca.TapPoint: closed");
  return ud;
}

std::string string_field(lua_State* L, int index, const char* name, const char* fallback) {
  lua_getfield(L, index, name);
  std::string s = lua_type(L, -1) == LUA_TSTRING ? lua_tostring(L, -1) : fallback;
  lua_pop(L, 1);
  return s;
}

// Publishes a tap's sample into the server's topic of its path.
void publish(TapUD& ud, tap::Taps::Tap& t, std::int64_t at, Bytes sample) {
  auto server = ud.server.lock();
  auto id = ud.topics.find(t.path);
  thread_local std::vector<double> values;
  if (!server || id == ud.topics.end() || !tap::sample_values(t.spec, sample, values)) {
    ++ud.unpublished[t.path];
    return;
  }
  if (ud.arrival)
    at = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  server->samples().publish(id->second, at, values);
}

int core_tap_point(lua_State* L) {
  luaL_checktype(L, 1, LUA_TTABLE);
  const std::string name = string_field(L, 1, "name", "");
  const std::string host = string_field(L, 1, "host", "");
  const std::string key_file = string_field(L, 1, "key_file", "");
  const std::string tcp = string_field(L, 1, "tcp", "127.0.0.1:0");
  const std::string stamp = string_field(L, 1, "stamp", "writer");
  luaL_argcheck(L, !name.empty() && !host.empty(), 1, "{ name = ..., host = ... } needed");
  std::shared_ptr<web::Server> server;
  lua_getfield(L, 1, "server");
  if (!lua_isnil(L, -1)) server = lua::check_web_server(L, -1);
  lua_pop(L, 1);
  auto* ud = static_cast<TapUD*>(lua_newuserdatauv(L, sizeof(TapUD), 0));
  new (ud) TapUD{};
  luaL_setmetatable(L, kMeta);
  char err[512] = {};
  {
    std::string error;
    try {
      auto key = auth::load_key(auth::key_file_path(key_file), &error);
      if (key) {
        EndpointOptions o;
        o.key = *key;
        static int made = 0;
        const std::string uds = runtime_dir() + "/taps-" + std::to_string(::getpid()) + "-" + std::to_string(made++) + ".sock";
        ud->point = std::make_unique<tap::TapPoint>(lua::loop_state(L).loop.io(), host, name, std::move(o), uds, tcp);
        ud->server = server;
        ud->arrival = stamp == "arrival";
        ud->point->on_sample = [ud](tap::Taps::Tap& t, std::int64_t at, Bytes sample) { publish(*ud, t, at, sample); };
      }
    } catch (const std::exception& e) {
      error = e.what();
    }
    if (!ud->point) std::snprintf(err, sizeof err, "tap point %s: %s", name.c_str(), error.c_str());
  }
  if (ud->point) return 1;
  lua_pushnil(L);
  lua_pushstring(L, err);
  return 2;
}

int tp_endpoints(lua_State* L) {
  TapUD* ud = check(L);
  const Location loc = ud->point->location();
  lua_createtable(L, 0, 3);
  lua_pushstring(L, ud->point->endpoint().host().c_str());
  lua_setfield(L, -2, "host");
  lua_pushstring(L, loc.data_uds.c_str());
  lua_setfield(L, -2, "data_uds");
  lua_pushstring(L, loc.data_tcp.c_str());
  lua_setfield(L, -2, "data_tcp");
  return 1;
}

// The topic's fields for a port of spec `s`: "value", "value[0]".. (vector), none (a vector of any size).
std::vector<std::string> fields_of(const PortSpec& s) {
  if (s.type == PortType::Scalar) return {"value"};
  std::vector<std::string> f;
  if (s.type == PortType::Vector)
    for (std::uint32_t i = 0; i < s.size; ++i) f.push_back("value[" + std::to_string(i) + "]");
  return f;
}

int tp_add(lua_State* L) {
  TapUD* ud = check(L);
  const std::string path = luaL_checkstring(L, 2);
  const char* type = luaL_checkstring(L, 3);
  const auto size = static_cast<std::uint32_t>(luaL_optinteger(L, 4, 1));
  const char* units = luaL_optstring(L, 5, "");
  const auto queue = static_cast<std::size_t>(luaL_optinteger(L, 6, 64));
  PortSpec spec{path, PortType::Scalar, size, units, {}};
  spec.message = luaL_optstring(L, 7, "");
  char err[512] = {};
  std::string topic;
  {
    std::string error;
    const auto t = port_type_from(type);
    if (!t) {
      error = std::string("unknown port type '") + type + "'";
    } else if (spec.type = *t; ud->point->add(path, spec, std::min<std::size_t>(queue, 4096), &error)) {
      topic = tap::topic_of(path);
      auto server = ud->server.lock();
      // the topic the run made at start (dca.launch.live) is used as it is: made again, it would be advertised
      // again to every viewer
      if (server && *t != PortType::Value && *t != PortType::Message && !ud->topics.count(path)) {
        const auto* known = server->samples().find(topic);
        ud->topics[path] = known ? known->id : server->samples().add_topic(topic, fields_of({path, *t, size, units, {}}), units);
      }
    }
    if (topic.empty()) std::snprintf(err, sizeof err, "tap %s: %s", path.c_str(), error.c_str());
  }
  if (!topic.empty()) {
    lua_pushlstring(L, topic.data(), topic.size());
    return 1;
  }
  lua_pushnil(L);
  lua_pushstring(L, err);
  return 2;
}

int tp_stats(lua_State* L) {
  TapUD* ud = check(L);
  lua_newtable(L);
  for (const auto& t : ud->point->taps().all()) {
    lua_createtable(L, 0, 3);
    lua_pushinteger(L, static_cast<lua_Integer>(t->taken));
    lua_setfield(L, -2, "taken");
    lua_pushinteger(L, static_cast<lua_Integer>(t->dropped() + t->malformed));
    lua_setfield(L, -2, "dropped");
    lua_pushinteger(L, static_cast<lua_Integer>(ud->unpublished[t->path]));
    lua_setfield(L, -2, "unpublished");
    lua_setfield(L, -2, t->path.c_str());
  }
  return 1;
}

int tp_close(lua_State* L) {
  auto* ud = static_cast<TapUD*>(luaL_checkudata(L, 1, kMeta));
  ud->point.reset();
  return 0;
}

int tp_gc(lua_State* L) {
  auto* ud = static_cast<TapUD*>(luaL_checkudata(L, 1, kMeta));
  ud->~TapUD();
  return 0;
}

// A parameter request's answer for Lua: a function reply(params) | reply(nil, error), answering once (later calls
// do nothing).
constexpr const char* kReplyMeta = "dca.FoxgloveReply";
struct ReplyUD {
  foxglove::Protocol::ParamsReply fn;
};

int reply_gc(lua_State* L) {
  static_cast<ReplyUD*>(luaL_checkudata(L, 1, kReplyMeta))->~ReplyUD();
  return 0;
}

int reply_call(lua_State* L) {
  auto* ud = static_cast<ReplyUD*>(lua_touserdata(L, lua_upvalueindex(1)));
  if (!ud || !ud->fn) return 0;
  const auto fn = std::move(ud->fn);
  ud->fn = nullptr;
  wire::Value params;
  std::string error;
  if (lua_isnoneornil(L, 1)) {
    const char* e = lua_type(L, 2) == LUA_TSTRING ? lua_tostring(L, 2) : nullptr;
    error = e ? e : "no answer";
  } else if (!lua::to_value(L, 1, params, &error)) {
    error = "the parameters: " + error;
  }
  fn(params, error);
  return 0;
}

void push_reply(lua_State* L, foxglove::Protocol::ParamsReply fn) {
  auto* ud = static_cast<ReplyUD*>(lua_newuserdatauv(L, sizeof(ReplyUD), 0));
  new (ud) ReplyUD{std::move(fn)};
  luaL_setmetatable(L, kReplyMeta);
  lua_pushcclosure(L, reply_call, 1);
}

// The run's parameter functions (opts get_parameters, set_parameters at `index`) on `proto`: both or none.
void serve_parameters(lua_State* L, int index, lua::LoopState& ls, foxglove::Protocol& proto) {
  lua_getfield(L, index, "get_parameters");
  lua_getfield(L, index, "set_parameters");
  if (!lua_isfunction(L, -2) || !lua_isfunction(L, -1)) return lua_pop(L, 2);
  auto get = std::make_shared<lua::LuaRef>(L, -2, ls);
  auto set = std::make_shared<lua::LuaRef>(L, -1, ls);
  lua_pop(L, 2);
  proto.get_parameters = [get](const std::vector<std::string>& names, foxglove::Protocol::ParamsReply reply) {
    lua::invoke(*get, [&names, &reply](lua_State* S) {
      lua_createtable(S, static_cast<int>(names.size()), 0);
      for (std::size_t i = 0; i < names.size(); ++i) {
        lua_pushlstring(S, names[i].data(), names[i].size());
        lua_rawseti(S, -2, static_cast<lua_Integer>(i + 1));
      }
      push_reply(S, std::move(reply));
      return 2;
    });
  };
  proto.set_parameters = [set](const wire::Value& params, foxglove::Protocol::ParamsReply reply) {
    lua::invoke(*set, [&params, &reply](lua_State* S) {
      lua::push_value(S, params);
      push_reply(S, std::move(reply));
      return 2;
    });
  };
}

constexpr const char* kFoxMeta = "dca.Foxglove";
struct FoxUD {
  std::weak_ptr<foxglove::Protocol> proto;
};

std::shared_ptr<foxglove::Protocol> check_fox(lua_State* L) {
  auto* ud = static_cast<FoxUD*>(luaL_checkudata(L, 1, kFoxMeta));
  return ud->proto.lock();
}

int fox_gc(lua_State* L) {
  static_cast<FoxUD*>(luaL_checkudata(L, 1, kFoxMeta))->~FoxUD();
  return 0;
}

int fox_time(lua_State* L) {
  const double t = luaL_checknumber(L, 2);
  if (auto p = check_fox(L); p && t >= 0 && t < 9e9) p->time(static_cast<std::int64_t>(t * 1e9));
  return 0;
}

int fox_end_time(lua_State* L) {
  const double t = luaL_checknumber(L, 2);
  if (auto p = check_fox(L); p && t >= 0 && t < 9e9) p->end_time(static_cast<std::int64_t>(t * 1e9));
  return 0;
}

// { {topic, {id, ...}}, ... } at `index`: entries that are not a string and a list of strings are left out.
std::vector<std::pair<std::string, std::vector<std::string>>> graph_list(lua_State* L, int index) {
  std::vector<std::pair<std::string, std::vector<std::string>>> out;
  if (!lua_istable(L, index)) return out;
  const lua_Integer n = luaL_len(L, index);
  for (lua_Integer i = 1; i <= n; ++i) {
    lua_geti(L, index, i);
    if (lua_istable(L, -1)) {
      lua_geti(L, -1, 1);
      lua_geti(L, -2, 2);
      if (lua_type(L, -2) == LUA_TSTRING && lua_istable(L, -1)) {
        std::vector<std::string> ids;
        const lua_Integer m = luaL_len(L, -1);
        for (lua_Integer k = 1; k <= m; ++k) {
          lua_geti(L, -1, k);
          if (lua_type(L, -1) == LUA_TSTRING) ids.emplace_back(lua_tostring(L, -1));
          lua_pop(L, 1);
        }
        out.emplace_back(lua_tostring(L, -2), std::move(ids));
      }
      lua_pop(L, 2);
    }
    lua_pop(L, 1);
  }
  return out;
}

int fox_graph(lua_State* L) {
  auto p = check_fox(L);
  auto published = graph_list(L, 2);
  auto subscribed = graph_list(L, 3);
  if (p) p->set_graph(std::move(published), std::move(subscribed));
  return 0;
}

int fox_clients(lua_State* L) {
  auto p = check_fox(L);
  lua_pushinteger(L, p ? static_cast<lua_Integer>(p->clients()) : 0);
  return 1;
}

int core_foxglove(lua_State* L) {
  auto server = lua::check_web_server(L, 1);
  luaL_checktype(L, 2, LUA_TTABLE);
  const std::string name = string_field(L, 2, "name", "dca");
  lua::LoopState& ls = lua::loop_state(L);
  std::shared_ptr<lua::LuaRef> on_sub, on_unsub;
  lua_getfield(L, 2, "subscribe");
  if (lua_isfunction(L, -1)) on_sub = std::make_shared<lua::LuaRef>(L, -1, ls);
  lua_getfield(L, 2, "unsubscribe");
  if (lua_isfunction(L, -1)) on_unsub = std::make_shared<lua::LuaRef>(L, -1, ls);
  lua_pop(L, 2);
  auto proto = std::make_shared<foxglove::Protocol>(server, name);
  auto call = [](const std::shared_ptr<lua::LuaRef>& fn) {
    return [fn](const std::string& topic) {
      if (fn) lua::invoke(*fn, [topic](lua_State* S) {
          lua_pushlstring(S, topic.data(), topic.size());
          return 1;
        });
    };
  };
  proto->on_first_subscribe = call(on_sub);
  proto->on_last_unsubscribe = call(on_unsub);
  serve_parameters(L, 2, ls, *proto);
  lua_getfield(L, 2, "time");
  proto->sim_time = lua_toboolean(L, -1) != 0;
  lua_getfield(L, 2, "watch");
  if (lua_isfunction(L, -1)) {
    auto on_watch = std::make_shared<lua::LuaRef>(L, -1, ls);
    proto->on_watch = [on_watch] { lua::invoke(*on_watch, [](lua_State*) { return 0; }); };
  }
  lua_pop(L, 2);
  server->add_protocol(foxglove::kSubprotocol, proto);
  auto* ud = static_cast<FoxUD*>(lua_newuserdatauv(L, sizeof(FoxUD), 0));
  new (ud) FoxUD{proto};
  luaL_setmetatable(L, kFoxMeta);
  return 1;
}

}  // namespace

void open_taps(lua_State* L) {
  static const luaL_Reg methods[] = {{"endpoints", tp_endpoints}, {"add", tp_add},   {"stats", tp_stats},
                                     {"close", tp_close},         {nullptr, nullptr}};
  lua::register_type(L, kMeta, methods, {tp_gc, tp_close, nullptr});
  static const luaL_Reg no_methods[] = {{nullptr, nullptr}};
  lua::register_type(L, kReplyMeta, no_methods, {reply_gc, nullptr, nullptr});
  static const luaL_Reg fox_methods[] = {{"time", fox_time}, {"end_time", fox_end_time}, {"graph", fox_graph}, {"clients", fox_clients},
                                         {nullptr, nullptr}};
  lua::register_type(L, kFoxMeta, fox_methods, {fox_gc, nullptr, nullptr});
  static const luaL_Reg functions[] = {{"tap_point", core_tap_point}, {"foxglove", core_foxglove}, {nullptr, nullptr}};
  luaL_setfuncs(L, functions, 0);
}

}  // namespace dca::bindings
