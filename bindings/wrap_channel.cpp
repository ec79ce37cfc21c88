// dca.Channel and dca.Listener: control-plane channels (host/channel) for Lua.
//
//   core.connect("127.0.0.1:4000", opts, function(ch, err) ... end)
//   local l, err = core.listen("127.0.0.1:0", opts, function(ch) ... end)   -- l:address(), l:close()
//   opts (all optional): key = "<cluster key>", key_file = PATH (default: $DCA_KEY_FILE, then the user's config
//   directory; created when missing), timeout = seconds for connect + handshake (default 5),
//   on_refused = function(reason) (listen: each refused connection).
//
//   ch:send{type = "event", x = 1}             -- true, or false once closed (a field id = N sends that id)
//   ch:request({type = "lookup", name = "/a"}, 2.0, function(reply, err, error_reply) ... end)
//        reply: the "ok" reply as a table; or nil, err: the reason of an "error" reply (error_reply: the whole
//        reply), a timeout, or the channel's close. Runs exactly once.
//   ch:on_message(function(msg, id) ... end)   -- requests (msg.id == id > 0: answer with ch:reply) and
//                                              -- events (msg.id == nil, id == 0)
//   ch:reply(req, {field = ...})               -- req: the request table or its id; replies "ok" with the fields,
//                                              -- or "error" when the table has type = "error" (and a reason)
//   ch:reply_error(req, "reason")
//   ch:on_close(function(reason) ... end)      -- exactly once
//   ch:close([reason])  ch:is_open()  ch:peer()
// An open channel is never garbage collected: close it. Messages are tables {type = "...", ...} (lua_value.h).
#include <lua.hpp>

#include <cstdio>
#include <cstring>

#include "bindings/lua_loop.h"
#include "bindings/lua_support.h"
#include "bindings/lua_value.h"
#include "host/net/channel.h"

namespace dca::lua {
namespace {

constexpr const char* kChannelMeta = "dca.Channel";
constexpr const char* kListenerMeta = "dca.Listener";

struct ChannelUD {
  Channel::Ptr ch;
  LoopState* ls = nullptr;
  int self = LUA_NOREF;                 // anchor while open
  std::shared_ptr<LuaRef> on_close;     // the user's on_close
};

struct ListenerUD {
  Listener::Ptr l;
  LoopState* ls = nullptr;
  int self = LUA_NOREF;  // anchor while listening
};

ChannelUD* check_channel(lua_State* L) { return static_cast<ChannelUD*>(luaL_checkudata(L, 1, kChannelMeta)); }
ListenerUD* check_listener(lua_State* L) { return static_cast<ListenerUD*>(luaL_checkudata(L, 1, kListenerMeta)); }

// Pushes a new userdata for `ch`, anchored until the channel closes.
void push_channel(lua_State* L, LoopState& ls, const Channel::Ptr& ch) {
  auto* ud = static_cast<ChannelUD*>(lua_newuserdatauv(L, sizeof(ChannelUD), 0));
  new (ud) ChannelUD{ch, &ls, LUA_NOREF, nullptr};
  luaL_setmetatable(L, kChannelMeta);
  ud->self = anchor(L, -1);
  ch->on_close([ud](const std::string& reason) {
    // The userdata is anchored until here, so `ud` is valid.
    auto fn = std::move(ud->on_close);
    ud->on_close.reset();
    if (fn) invoke(*fn, [&reason](lua_State* S) {
        lua_pushlstring(S, reason.data(), reason.size());
        return 1;
      });
    unanchor(*ud->ls, ud->self);
  });
}

// Reads opts (table at `index` or nil) into ChannelOptions. Returns false with *error (no Lua error).
bool read_options(lua_State* L, int index, ChannelOptions& o, std::string* error) {
  std::string key_file;
  bool have_key = false;
  if (lua_type(L, index) == LUA_TTABLE) {
    lua_getfield(L, index, "key");
    if (lua_type(L, -1) == LUA_TSTRING) {
      std::size_t n = 0;
      const char* k = lua_tolstring(L, -1, &n);
      o.key.assign(k, n);
      have_key = true;
    }
    lua_pop(L, 1);
    lua_getfield(L, index, "key_file");
    if (lua_type(L, -1) == LUA_TSTRING) key_file = lua_tostring(L, -1);
    lua_pop(L, 1);
    lua_getfield(L, index, "timeout");
    if (lua_type(L, -1) == LUA_TNUMBER) {
      const double t = lua_tonumber(L, -1);
      if (t > 0 && t < 1e6) o.handshake_timeout = std::chrono::milliseconds(static_cast<std::int64_t>(t * 1000));
    }
    lua_pop(L, 1);
  }
  if (!have_key) {
    const auto key = auth::load_or_create_key(auth::key_file_path(key_file), error);
    if (!key) return false;
    o.key = *key;
  }
  return true;
}

// core.connect's and core.listen's arguments: (address, [options table], callback); returns the address.
std::string_view check_endpoint_args(lua_State* L) {
  std::size_t n = 0;
  const char* addr_text = luaL_checklstring(L, 1, &n);
  if (!lua_isnoneornil(L, 2)) luaL_checktype(L, 2, LUA_TTABLE);
  luaL_checktype(L, 3, LUA_TFUNCTION);
  return {addr_text, n};
}

int core_connect(lua_State* L) {
  const std::string_view addr_text = check_endpoint_args(L);
  LoopState& ls = loop_state(L);
  char err[512] = {};
  {
    std::string error;
    ChannelOptions o;
    auto addr = Address::parse(addr_text, &error);
    auto cb = std::make_shared<LuaRef>(L, 3, ls);
    if (addr && read_options(L, 2, o, &error)) {
      LoopState* lsp = &ls;
      Channel::connect(ls.loop.io(), *addr, std::move(o), [lsp, cb](Channel::Ptr ch, const std::string& e) {
        invoke(*cb, [&](lua_State* S) {
          if (ch) {
            push_channel(S, *lsp, ch);
            return 1;
          }
          lua_pushnil(S);
          lua_pushlstring(S, e.data(), e.size());
          return 2;
        });
      });
    } else if (addr) {
      // A key problem: reported through the callback, from the loop, like any connect failure.
      boost::asio::post(ls.loop.io(), [cb, error] {
        invoke(*cb, [&](lua_State* S) {
          lua_pushnil(S);
          lua_pushlstring(S, error.data(), error.size());
          return 2;
        });
      });
    } else {
      std::snprintf(err, sizeof err, "%s", error.c_str());
    }
  }
  if (err[0] != '\0') return luaL_argerror(L, 1, err);
  return 0;
}

int core_listen(lua_State* L) {
  const std::string_view addr_text = check_endpoint_args(L);
  LoopState& ls = loop_state(L);
  char err[512] = {};
  bool bad_address = false;
  Listener::Ptr listener;
  {
    std::string error;
    ChannelOptions o;
    auto addr = Address::parse(addr_text, &error);
    auto cb = std::make_shared<LuaRef>(L, 3, ls);
    std::shared_ptr<LuaRef> refused;
    if (lua_type(L, 2) == LUA_TTABLE) {
      lua_getfield(L, 2, "on_refused");
      if (lua_type(L, -1) == LUA_TFUNCTION) refused = std::make_shared<LuaRef>(L, -1, ls);
      lua_pop(L, 1);
    }
    if (!addr) {
      bad_address = true;
    } else if (read_options(L, 2, o, &error)) {
      LoopState* lsp = &ls;
      listener = Listener::listen(
          ls.loop.io(), *addr, std::move(o),
          [lsp, cb](Channel::Ptr ch) {
            invoke(*cb, [&](lua_State* S) {
              push_channel(S, *lsp, ch);
              return 1;
            });
          },
          &error,
          [refused](const std::string& why) {
            if (!refused) return;
            invoke(*refused, [&](lua_State* S) {
              lua_pushlstring(S, why.data(), why.size());
              return 1;
            });
          });
    }
    if (!listener) std::snprintf(err, sizeof err, "%s", error.c_str());
  }
  if (bad_address) return luaL_argerror(L, 1, err);
  if (!listener) {
    lua_pushnil(L);
    lua_pushstring(L, err);
    return 2;
  }
  auto* ud = static_cast<ListenerUD*>(lua_newuserdatauv(L, sizeof(ListenerUD), 0));
  new (ud) ListenerUD{std::move(listener), &ls, LUA_NOREF};
  luaL_setmetatable(L, kListenerMeta);
  ud->self = anchor(L, -1);
  return 1;
}

// --- Channel methods ------------------------------------------------------------------------------------------

int ch_send(lua_State* L) {
  ChannelUD* ud = check_channel(L);
  luaL_checktype(L, 2, LUA_TTABLE);
  char err[512] = {};
  bool sent = false;
  {
    wire::Message m;
    std::string error;
    if (to_message(L, 2, m, &error)) {
      sent = ud->ch && ud->ch->send(std::move(m));
    } else {
      std::snprintf(err, sizeof err, "%s", error.c_str());
    }
  }
  if (err[0] != '\0') return luaL_argerror(L, 2, err);
  lua_pushboolean(L, sent);
  return 1;
}

int ch_request(lua_State* L) {
  ChannelUD* ud = check_channel(L);
  luaL_checktype(L, 2, LUA_TTABLE);
  const double timeout = luaL_checknumber(L, 3);
  luaL_argcheck(L, timeout > 0 && timeout < 1e6, 3, "timeout must be > 0 seconds");
  luaL_checktype(L, 4, LUA_TFUNCTION);
  char err[512] = {};
  std::uint64_t id = 0;
  {
    wire::Message m;
    std::string error;
    if (!to_message(L, 2, m, &error)) {
      std::snprintf(err, sizeof err, "%s", error.c_str());
    } else {
      auto cb = std::make_shared<LuaRef>(L, 4, *ud->ls);
      id = ud->ch->request(std::move(m), std::chrono::milliseconds(static_cast<std::int64_t>(timeout * 1000)),
                           [cb](Response r) {
                             invoke(*cb, [&](lua_State* S) {
                               if (r.ok()) {
                                 push_message(S, r.message, false);
                                 return 1;
                               }
                               lua_pushnil(S);
                               lua_pushlstring(S, r.error.data(), r.error.size());
                               if (!r.replied()) return 2;
                               push_message(S, r.message, false);
                               return 3;
                             });
                           });
    }
  }
  if (err[0] != '\0') return luaL_argerror(L, 2, err);
  lua_pushinteger(L, static_cast<lua_Integer>(id));
  return 1;
}

// The request id given as an integer or as the request table's `id` (raises when there is none).
lua_Integer request_id(lua_State* L, int index) {
  lua_Integer id = 0;
  if (lua_istable(L, index)) {
    lua_getfield(L, index, "id");
    id = lua_isinteger(L, -1) ? lua_tointeger(L, -1) : 0;
    lua_pop(L, 1);
  } else {
    id = luaL_checkinteger(L, index);
  }
  luaL_argcheck(L, id > 0, index, "a request (a table with id > 0) or its id");
  return id;
}

int ch_reply(lua_State* L) {
  ChannelUD* ud = check_channel(L);
  const lua_Integer id = request_id(L, 2);
  if (!lua_isnoneornil(L, 3)) luaL_checktype(L, 3, LUA_TTABLE);
  bool is_error = false;
  if (lua_istable(L, 3)) {
    lua_getfield(L, 3, "type");
    is_error = lua_type(L, -1) == LUA_TSTRING && std::strcmp(lua_tostring(L, -1), "error") == 0;
    lua_pop(L, 1);
  }
  char err[512] = {};
  bool sent = false;
  {
    wire::Value payload = wire::Value::map();
    std::string error;
    if (lua_istable(L, 3) && !to_value(L, 3, payload, &error)) {
      std::snprintf(err, sizeof err, "%s", error.c_str());
    } else {
      if (!payload.is_map()) payload = wire::Value::map();
      drop_envelope_fields(payload);
      if (is_error && payload["reason"].as_string().empty()) payload.set("reason", "error reply without a reason");
      sent = ud->ch->send(wire::Message{is_error ? "error" : "ok", static_cast<std::uint64_t>(id), std::move(payload)});
    }
  }
  if (err[0] != '\0') return luaL_argerror(L, 3, err);
  lua_pushboolean(L, sent);
  return 1;
}

int ch_reply_error(lua_State* L) {
  ChannelUD* ud = check_channel(L);
  const lua_Integer id = request_id(L, 2);
  std::size_t n = 0;
  const char* reason = luaL_checklstring(L, 3, &n);
  bool sent = false;
  {
    wire::Message to{"", static_cast<std::uint64_t>(id), wire::Value::map()};
    sent = ud->ch->reply_error(to, std::string_view(reason, n));
  }
  lua_pushboolean(L, sent);
  return 1;
}

int ch_on_message(lua_State* L) {
  ChannelUD* ud = check_channel(L);
  if (lua_isnil(L, 2)) {
    ud->ch->on_message(nullptr);
    return 0;
  }
  luaL_checktype(L, 2, LUA_TFUNCTION);
  auto cb = std::make_shared<LuaRef>(L, 2, *ud->ls);
  ud->ch->on_message([cb](const wire::Message& m) {
    invoke(*cb, [&](lua_State* S) {
      push_message(S, m);
      lua_pushinteger(S, static_cast<lua_Integer>(m.id));
      return 2;
    });
  });
  return 0;
}

int ch_on_close(lua_State* L) {
  ChannelUD* ud = check_channel(L);
  luaL_checktype(L, 2, LUA_TFUNCTION);
  auto cb = std::make_shared<LuaRef>(L, 2, *ud->ls);
  if (ud->ch->is_open()) {
    ud->on_close = std::move(cb);
  } else {
    // Already closed: called from the loop, as promised.
    std::string why = ud->ch->close_reason();
    boost::asio::post(ud->ls->loop.io(), [cb, why] {
      invoke(*cb, [&](lua_State* S) {
        lua_pushlstring(S, why.data(), why.size());
        return 1;
      });
    });
  }
  return 0;
}

int ch_close(lua_State* L) {
  ChannelUD* ud = check_channel(L);
  std::size_t n = 0;
  const char* reason = luaL_optlstring(L, 2, "closed by this side", &n);
  lua_State* prev = ud->ls->current;
  ud->ls->current = L;
  {
    const std::string why(reason, n);
    if (ud->ch) ud->ch->close(why);
  }
  ud->ls->current = prev;
  return 0;
}

int ch_is_open(lua_State* L) {
  ChannelUD* ud = check_channel(L);
  lua_pushboolean(L, ud->ch && ud->ch->is_open());
  return 1;
}

int ch_peer(lua_State* L) {
  ChannelUD* ud = check_channel(L);
  lua_pushstring(L, ud->ch ? ud->ch->peer().c_str() : "");
  return 1;
}

int ch_gc(lua_State* L) {
  ChannelUD* ud = check_channel(L);
  if (ud->ch && *ud->ls->alive) {
    ud->ls->suppress++;  // the state is closing (an open channel is anchored): no callbacks now
    ud->ch->on_message(nullptr);
    ud->ch->close("the Lua state closed");
    ud->ls->suppress--;
  }
  ud->~ChannelUD();
  return 0;
}

int ch_tostring(lua_State* L) {
  ChannelUD* ud = check_channel(L);
  if (!ud->ch) {
    lua_pushstring(L, "dca.Channel(closed)");
  } else {
    lua_pushfstring(L, "dca.Channel(%s, %s)", ud->ch->peer().c_str(), ud->ch->is_open() ? "open" : "closed");
  }
  return 1;
}

// --- Listener methods -----------------------------------------------------------------------------------------

int l_address(lua_State* L) {
  ListenerUD* ud = check_listener(L);
  lua_pushstring(L, ud->l ? ud->l->address().str().c_str() : "");
  return 1;
}

int l_close(lua_State* L) {
  ListenerUD* ud = check_listener(L);
  if (ud->l) ud->l->close();
  unanchor(*ud->ls, ud->self);
  return 0;
}

int l_gc(lua_State* L) {
  ListenerUD* ud = check_listener(L);
  if (ud->l && *ud->ls->alive) ud->l->close();
  ud->~ListenerUD();
  return 0;
}

int l_tostring(lua_State* L) {
  ListenerUD* ud = check_listener(L);
  lua_pushfstring(L, "dca.Listener(%s)", ud->l ? ud->l->address().str().c_str() : "closed");
  return 1;
}

}  // namespace

void register_channel(lua_State* L) {
  static const luaL_Reg ch_methods[] = {
      {"send", ch_send},           {"request", ch_request}, {"reply", ch_reply},     {"reply_error", ch_reply_error},
      {"on_message", ch_on_message}, {"on_close", ch_on_close}, {"close", ch_close}, {"is_open", ch_is_open},
      {"peer", ch_peer},           {nullptr, nullptr}};
  register_type(L, kChannelMeta, ch_methods, {ch_gc, ch_close, ch_tostring});
  static const luaL_Reg l_methods[] = {{"address", l_address}, {"close", l_close}, {nullptr, nullptr}};
  register_type(L, kListenerMeta, l_methods, {l_gc, l_close, l_tostring});
  static const luaL_Reg functions[] = {{"connect", core_connect}, {"listen", core_listen}, {nullptr, nullptr}};
  luaL_setfuncs(L, functions, 0);
}

}  // namespace dca::lua
