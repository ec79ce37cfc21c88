// Line editing for `dca repl` (libedit's readline interface): core.readline, history, completion.
//
//   core.readline(prompt)          --> the line typed (without newline), or nil at end of input (Ctrl-D)
//   core.add_history(line)         -- appends to the in-memory history
//   core.read_history(path)        -- loads a history file (missing file: nothing happens)
//   core.write_history(path)       -- saves the history (creates the file)
//   core.set_completer(fn | nil)   -- fn(word, line) --> { candidates } for the word under the cursor (Tab)
// Without blocking (a console inside a process whose event loop must keep running):
//   core.readline_install(prompt, fn)  -- fn(line | nil) for each line typed (nil: end of input)
//   core.readline_poll()               --> true if stdin had input (read and fed to the line editor)
//   core.readline_prompt(prompt)       -- the prompt of the next line
//   core.readline_remove()             -- restores the terminal
//   core.readline_print(text)          -- prints text on its own line(s) above the prompt, then redraws the
//                                         prompt and the line being typed (asynchronous output; libedit
//                                         redraws a just-accepted line too: remove the handler until the
//                                         answer, as `dca repl` does)
//
// The completer is called from inside readline (a C callback): it runs under lua_pcall, so a Lua error in
// it prints nothing and offers no candidates, and never unwinds through libedit's frames.
#include <lua.hpp>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <poll.h>

#include <editline/readline.h>

#include "bindings/lua_support.h"

namespace dca::bindings {
namespace {

lua_State* g_state = nullptr;  // the state whose completer runs (readline is one per process)
int g_completer = LUA_NOREF;
std::vector<std::string> g_matches;

// readline's generator: returns each candidate once (malloc'd, as readline frees them), then nullptr.
char* generator(const char* /*text*/, int state) {
  static std::size_t next = 0;
  if (state == 0) next = 0;
  if (next >= g_matches.size()) return nullptr;
  return strdup(g_matches[next++].c_str());
}

char** complete(const char* text, int /*start*/, int /*end*/) {
  rl_attempted_completion_over = 1;  // no filename completion
  g_matches.clear();
  lua_State* L = g_state;
  if (L == nullptr || g_completer == LUA_NOREF) return nullptr;
  const int top = lua_gettop(L);
  lua_rawgeti(L, LUA_REGISTRYINDEX, g_completer);
  lua_pushstring(L, text);
  lua_pushstring(L, rl_line_buffer != nullptr ? rl_line_buffer : "");
  if (lua_pcall(L, 2, 1, 0) == LUA_OK && lua_istable(L, -1)) {
    const lua_Integer n = luaL_len(L, -1);
    for (lua_Integer i = 1; i <= n; ++i) {
      lua_rawgeti(L, -1, i);
      if (lua_type(L, -1) == LUA_TSTRING) g_matches.emplace_back(lua_tostring(L, -1));
      lua_pop(L, 1);
    }
  }
  lua_settop(L, top);
  if (g_matches.empty()) return nullptr;
  return rl_completion_matches(text, generator);
}

int l_readline(lua_State* L) {
  const char* prompt = luaL_optstring(L, 1, "> ");
  g_state = L;
  char* line = readline(prompt);
  if (line == nullptr) {
    lua_pushnil(L);
    return 1;
  }
  lua_pushstring(L, line);
  std::free(line);
  return 1;
}

int l_add_history(lua_State* L) {
  const char* line = luaL_checkstring(L, 1);
  if (line[0] != '\0') add_history(line);
  return 0;
}

int l_read_history(lua_State* L) {
  read_history(luaL_checkstring(L, 1));
  return 0;
}

int l_write_history(lua_State* L) {
  const int rc = write_history(luaL_checkstring(L, 1));
  lua_pushboolean(L, rc == 0);
  return 1;
}

int l_set_completer(lua_State* L) {
  if (g_completer != LUA_NOREF) {
    luaL_unref(L, LUA_REGISTRYINDEX, g_completer);
    g_completer = LUA_NOREF;
  }
  if (!lua_isnoneornil(L, 1)) {
    luaL_checktype(L, 1, LUA_TFUNCTION);
    lua_pushvalue(L, 1);
    g_completer = luaL_ref(L, LUA_REGISTRYINDEX);
    g_state = L;
  }
  rl_attempted_completion_function = complete;
  rl_completion_append_character = '\0';  // a path inside quotes goes on with the quote, not a space
  // complete process paths as whole words: '.' is part of a word
  rl_basic_word_break_characters = const_cast<char*>(" \t\n\"'(),=[]{}+-*/<>;:#");
  return 0;
}

int g_on_line = LUA_NOREF;

void on_line(char* line) {
  lua_State* L = g_state;
  if (L == nullptr || g_on_line == LUA_NOREF) {
    std::free(line);
    return;
  }
  const int base = lua_gettop(L);
  lua_pushcfunction(L, dca::lua::message_handler);
  lua_rawgeti(L, LUA_REGISTRYINDEX, g_on_line);
  if (line != nullptr) {
    lua_pushstring(L, line);
    std::free(line);
  } else {
    lua_pushnil(L);
  }
  if (lua_pcall(L, 1, 0, base + 1) != LUA_OK) std::fprintf(stderr, "console: %s\n", lua_tostring(L, -1));
  lua_settop(L, base);
}

int l_readline_install(lua_State* L) {
  const char* prompt = luaL_checkstring(L, 1);
  luaL_checktype(L, 2, LUA_TFUNCTION);
  if (g_on_line != LUA_NOREF) luaL_unref(L, LUA_REGISTRYINDEX, g_on_line);
  lua_pushvalue(L, 2);
  g_on_line = luaL_ref(L, LUA_REGISTRYINDEX);
  g_state = L;
  rl_callback_handler_install(prompt, on_line);
  return 0;
}

int l_readline_poll(lua_State* L) {
  pollfd p{0, POLLIN, 0};
  bool any = false;
  while (g_on_line != LUA_NOREF && ::poll(&p, 1, 0) > 0 && (p.revents & (POLLIN | POLLHUP)) != 0) {
    any = true;
    rl_callback_read_char();
    if ((p.revents & POLLHUP) != 0) break;
  }
  lua_pushboolean(L, any);
  return 1;
}

int l_readline_prompt(lua_State* L) {
  rl_set_prompt(luaL_checkstring(L, 1));
  return 0;
}

int l_readline_print(lua_State* L) {
  size_t n = 0;
  const char* text = luaL_checklstring(L, 1, &n);
  // the cursor is on the prompt line: clear it, print, and let the line editor draw prompt and input again
  std::fputs("\r\033[K", stdout);
  std::fwrite(text, 1, n, stdout);
  if (n > 0 && text[n - 1] != '\n') std::fputc('\n', stdout);  // "" only redraws (a new prompt)
  std::fflush(stdout);
  if (g_on_line != LUA_NOREF) rl_forced_update_display();
  return 0;
}

int l_readline_remove(lua_State* L) {
  rl_callback_handler_remove();
  if (g_on_line != LUA_NOREF) luaL_unref(L, LUA_REGISTRYINDEX, g_on_line);
  g_on_line = LUA_NOREF;
  return 0;
}

}  // namespace

/// Adds readline, add_history, read_history, write_history and set_completer to the table on the stack top.
void open_readline(lua_State* L) {
  using_history();
  static const luaL_Reg fns[] = {{"readline", l_readline},
                                 {"add_history", l_add_history},
                                 {"read_history", l_read_history},
                                 {"write_history", l_write_history},
                                 {"set_completer", l_set_completer},
                                 {"readline_install", l_readline_install},
                                 {"readline_poll", l_readline_poll},
                                 {"readline_prompt", l_readline_prompt},
                                 {"readline_remove", l_readline_remove},
                                 {"readline_print", l_readline_print},
                                 {nullptr, nullptr}};
  luaL_setfuncs(L, fns, 0);
}

}  // namespace dca::bindings
