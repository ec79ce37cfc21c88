#pragma once
// The registry of the `dca` executable's subcommands, dispatched like git's.
#include <span>
#include <string>
#include <vector>

namespace dca::cli {

/// A subcommand's entry point: args are the words after the subcommand's name. Returns the exit code.
using Main = int (*)(std::span<char* const> args);

/// One subcommand of `dca`.
struct Subcommand {
  const char* name;     ///< the word after `dca`
  const char* summary;  ///< one line for `dca help`
  const char* usage;    ///< printed by `dca <name> --help`
  Main main;
};

/// Adds a subcommand (called by DCA_SUBCOMMAND at static-initialisation time).
void add(const Subcommand& s);
/// Every registered C++ subcommand, sorted by name.
std::vector<Subcommand> all();
/// The subcommand named `name`, or nullptr.
const Subcommand* find(const std::string& name);

struct Registrar {
  explicit Registrar(const Subcommand& s) { add(s); }
};

}  // namespace dca::cli

#define DCA_CLI_CONCAT2(a, b) a##b
#define DCA_CLI_CONCAT(a, b) DCA_CLI_CONCAT2(a, b)
/// DCA_SUBCOMMAND("name", "summary", "usage", fn) registers a subcommand from any file linked into `dca`.
/// (__COUNTER__, not __LINE__: a unity build joins files, two of which may register on the same line)
#define DCA_SUBCOMMAND(name, summary, usage, fn) \
  static const ::dca::cli::Registrar DCA_CLI_CONCAT(dca_subcommand_, __COUNTER__){{name, summary, usage, fn}}
