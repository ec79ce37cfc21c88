// The `dca` executable: subcommands dispatched like git's. C++ subcommands register with DCA_SUBCOMMAND;
// any other word names a Lua subcommand, the module dca.cli.<word> (lua/dca/cli/<word>.lua).
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "bindings/lua_runtime.h"
#include "bindings/stop_signals.h"
#include "app/subcommand.h"
#include "host/config_store.h"
#include "host/paths.h"
#include "host/spawn.h"
#include "host/version.h"
#include "dca_commit.h"

namespace {

bool is_help(const char* a) { return std::strcmp(a, "--help") == 0 || std::strcmp(a, "-h") == 0; }

bool lua_subcommand_exists(const std::string& name) {
  if (name.empty() || name.find_first_of("./\\") != std::string::npos) return false;
  std::error_code ec;
  return std::filesystem::is_regular_file(std::filesystem::path(dca::lua_dir()) / "dca" / "cli" / (name + ".lua"), ec);
}

void print_list(FILE* out) {
  std::fprintf(out, "usage: dca <command> [args]\n       dca <command> --help\n       dca --version\n\ncommands:\n");
  std::fprintf(out, "  %-10s %s\n", "help", "this list, or `dca help <command>` for one command");
  for (const auto& s : dca::cli::all()) std::fprintf(out, "  %-10s %s\n", s.name, s.summary);
  dca::lua::Runtime rt;
  for (const auto& [name, summary] : dca::lua::lua_subcommands(rt))
    if (dca::cli::find(name) == nullptr) std::fprintf(out, "  %-10s %s\n", name.c_str(), summary.c_str());
}

// Every command's name: the C++ ones and the Lua ones.
std::vector<std::string> command_names() {
  std::vector<std::string> names{"help"};
  for (const auto& s : dca::cli::all()) names.emplace_back(s.name);
  dca::lua::Runtime rt;
  for (const auto& [name, summary] : dca::lua::lua_subcommands(rt)) names.push_back(name);
  return names;
}

// An unknown command: one line naming it, the closest commands (or those it begins), and where the list is. --> 2
int not_a_command(const std::string& name) {
  const auto names = command_names();
  auto close = dca::config::suggest(name, names);  // the closest, as for the configuration's keys
  for (const auto& c : names)
    if (name.size() >= 2 && c.rfind(name, 0) == 0 && std::find(close.begin(), close.end(), c) == close.end())
      close.push_back(c);
  std::string said;
  for (const auto& c : close) said += (said.empty() ? "" : " or ") + ("'" + c + "'");
  std::fprintf(stderr, "dca: '%s' is not a dca command%s%s%s\n", name.c_str(), said.empty() ? "" : " (did you mean ",
               said.c_str(), said.empty() ? "" : "?)");
  std::fprintf(stderr, "`dca help` lists the commands.\n");
  return 2;
}

bool is_lua_command(const std::string& name) {
  if (!lua_subcommand_exists(name)) return false;
  dca::lua::Runtime rt;
  return !rt.module_field("dca.cli." + name, "summary").empty();
}

int print_usage(const std::string& name) {
  if (const auto* s = dca::cli::find(name)) {
    std::printf("%s\n", s->usage);
    return 0;
  }
  if (is_lua_command(name)) {
    dca::lua::Runtime rt;
    std::string usage = rt.module_field("dca.cli." + name, "usage");
    if (usage.empty()) usage = "usage: dca " + name + " [args]";
    std::printf("%s\n", usage.c_str());
    return 0;
  }
  return not_a_command(name);
}

int dispatch(int argc, char** argv) {
  if (argc < 2) {
    print_list(stderr);
    return 2;
  }
  const std::string sub = argv[1];
  // the commands that start a tree stop it in order on these signals, from the first instant (see the header)
  if (sub == "run" || sub == "scenario" || sub == "supervise") dca::bindings::hold_stop_signals();
  if (sub == "--version" || sub == "version") {
    // "dca 0.1.0 (commit 1a2b3c4d5e6f)", "(commit ..., modified)" when tracked files differed from it at the build
    const std::string_view commit = DCA_COMMIT;
    std::printf("dca %.*s", static_cast<int>(dca::version().size()), dca::version().data());
    if (!commit.empty())
      std::printf(" (commit %.*s%s)", static_cast<int>(commit.size()), commit.data(), DCA_COMMIT_MODIFIED ? ", modified" : "");
    std::printf("\n");
    return 0;
  }
  if (sub == "help" || is_help(argv[1])) {
    if (argc >= 3) return print_usage(argv[2]);
    print_list(stdout);
    return 0;
  }
  const std::span<char* const> args(argv + 2, static_cast<size_t>(argc - 2));
  if (!args.empty() && is_help(args[0])) return print_usage(sub);
  if (const auto* s = dca::cli::find(sub)) return s->main(args);
  if (is_lua_command(sub)) {
    dca::lua::Runtime rt;
    return rt.run_module_main("dca.cli." + sub, args);
  }
  return not_a_command(sub);
}

}  // namespace

int main(int argc, char** argv) {
  dca::die_with_parent();
  try {
    return dispatch(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dca: %s\n", e.what());
    return 1;
  }
}
