// File watching for `dca run --watch` (Linux inotify).
//
//   local w = core.watch_file(path)  --> a dca.Watch, or nil and the reason
//   w:changed()                      --> true when the file was saved (written and closed, or replaced by a
//                                        rename, as editors do) since the last call; never blocks
//   w:close()
// The watch is on the file's directory, filtered by the file's name, so a save by rename is seen too.
#include <lua.hpp>

#include <sys/inotify.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include "bindings/lua_support.h"

namespace dca::bindings {
namespace {

constexpr const char* kWatch = "dca.Watch";

struct Watch {
  int fd = -1;
  std::string name;  // the file's name inside the watched directory
};

Watch* check_watch(lua_State* L) { return static_cast<Watch*>(luaL_checkudata(L, 1, kWatch)); }

int l_watch_file(lua_State* L) {
  const std::string path = luaL_checkstring(L, 1);
  const auto slash = path.rfind('/');
  const std::string dir = slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
  const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const int fd = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
  if (fd < 0) {
    lua_pushnil(L);
    lua_pushfstring(L, "inotify: %s", std::strerror(errno));
    return 2;
  }
  if (inotify_add_watch(fd, dir.c_str(), IN_CLOSE_WRITE | IN_MOVED_TO | IN_CREATE) < 0) {
    const int e = errno;
    ::close(fd);
    lua_pushnil(L);
    lua_pushfstring(L, "cannot watch %s: %s", dir.c_str(), std::strerror(e));
    return 2;
  }
  auto* w = static_cast<Watch*>(lua_newuserdatauv(L, sizeof(Watch), 0));
  new (w) Watch{fd, name};
  luaL_setmetatable(L, kWatch);
  return 1;
}

int l_changed(lua_State* L) {
  Watch* w = check_watch(L);
  bool changed = false;
  if (w->fd >= 0) {
    alignas(inotify_event) char buf[4096];
    for (;;) {
      const ssize_t n = ::read(w->fd, buf, sizeof buf);
      if (n <= 0) break;
      for (ssize_t off = 0; off < n;) {
        const auto* ev = reinterpret_cast<const inotify_event*>(buf + off);
        if (ev->len > 0 && w->name == ev->name) changed = true;
        off += static_cast<ssize_t>(sizeof(inotify_event) + ev->len);
      }
    }
  }
  lua_pushboolean(L, changed);
  return 1;
}

int l_close(lua_State* L) {
  Watch* w = check_watch(L);
  if (w->fd >= 0) ::close(w->fd);
  w->fd = -1;
  return 0;
}

int l_gc(lua_State* L) {
  l_close(L);
  check_watch(L)->~Watch();
  return 0;
}

int l_tostring(lua_State* L) {
  Watch* w = check_watch(L);
  lua_pushfstring(L, "dca.Watch(%s%s)", w->name.c_str(), w->fd < 0 ? ", closed" : "");
  return 1;
}

}  // namespace

/// Adds watch_file to the table on the stack top (and the dca.Watch metatable).
void open_inotify(lua_State* L) {
  static const luaL_Reg methods[] = {{"changed", l_changed}, {"close", l_close}, {nullptr, nullptr}};
  dca::lua::register_type(L, kWatch, methods, {l_gc, l_close, l_tostring});
  static const luaL_Reg functions[] = {{"watch_file", l_watch_file}, {nullptr, nullptr}};
  luaL_setfuncs(L, functions, 0);
}

}  // namespace dca::bindings
