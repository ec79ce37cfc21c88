#include "controllers/packages.h"

#include <cxxabi.h>
#include <dlfcn.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <stdexcept>
#include <system_error>

#include <dca/package.h>
#include <dca/registry.h>

namespace dca {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view kSuffix = ".dca.so";

std::vector<std::unique_ptr<LoadedPackage>>& loaded() {
  static std::vector<std::unique_ptr<LoadedPackage>> v;
  return v;
}

std::string quote(const std::string& name, const std::string& file) {
  return "package '" + name + "' (" + file + ")";
}

// Whether `file`, resolved, lies inside `dir`, resolved.
bool inside(const fs::path& file, const fs::path& dir) {
  std::error_code ec;
  const fs::path f = fs::canonical(file, ec);
  if (ec) return false;
  const fs::path d = fs::canonical(dir, ec);
  if (ec) return false;
  const auto rel = f.lexically_relative(d);
  return !rel.empty() && *rel.begin() != ".." && rel.is_relative();
}

// Why `path` (a package file or its folder) may not be trusted with this process's code: writable by its group
// or by anyone, or owned by someone other than this user or root. "" when it may.
std::string untrusted(const fs::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return path.string() + " cannot be examined";
  if ((st.st_mode & (S_IWGRP | S_IWOTH)) != 0) return path.string() + " is group- or world-writable";
  if (st.st_uid != 0 && st.st_uid != ::geteuid())
    return path.string() + " is owned by uid " + std::to_string(st.st_uid) + ", not by this user or root";
  return "";
}

// The version and ABI a package file says it was built with (its stamp, dca/package.h), without running it.
std::optional<std::pair<std::string, std::string>> read_stamp(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  std::string bytes;
  bytes.resize(64u << 20);  // a package is far smaller; a bigger file's stamp is not looked for
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  bytes.resize(static_cast<std::size_t>(in.gcount()));
  const std::string marker = "\x7f" "dca-package-stamp\n";
  const auto at = bytes.find(marker);
  if (at == std::string::npos) return std::nullopt;
  const auto v0 = at + marker.size(), v1 = bytes.find('\n', v0);
  if (v1 == std::string::npos) return std::nullopt;
  const auto a1 = bytes.find('\n', v1 + 1);
  if (a1 == std::string::npos) return std::nullopt;
  return std::make_pair(bytes.substr(v0, v1 - v0), bytes.substr(v1 + 1, a1 - v1 - 1));
}

// A stamp's parts by key ("sdk", "stdlib", "eigen", "msgpack", "cc"; an older dca's may have others), in order.
std::vector<std::pair<std::string, std::string>> stamp_parts(const std::string& abi) {
  std::vector<std::pair<std::string, std::string>> parts;
  std::size_t at = 0;
  while (at < abi.size()) {
    auto end = abi.find(' ', at);
    if (end == std::string::npos) end = abi.size();
    const std::string part = abi.substr(at, end - at);
    if (!part.empty()) parts.emplace_back(part.substr(0, part.find('-')), part);
    at = end + 1;
  }
  return parts;
}

std::string stamp_part(const std::vector<std::pair<std::string, std::string>>& parts, const std::string& key) {
  for (const auto& [k, v] : parts)
    if (k == key) return v;
  return "(none)";
}

std::string part_name(const std::string& key) {
  if (key == "sdk") return "SDK headers";
  if (key == "stdlib") return "standard library";
  if (key == "eigen") return "Eigen";
  return key;
}

FileIdentity identity_of(const struct stat& st) {
  return {static_cast<std::uint64_t>(st.st_dev), static_cast<std::uint64_t>(st.st_ino),
          static_cast<std::uint64_t>(st.st_size),
          static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1'000'000'000 + st.st_mtim.tv_nsec};
}

// The folders a private copy may go in: $XDG_RUNTIME_DIR, $TMPDIR, /tmp (those set), in that order.
std::vector<std::string> copy_bases() {
  std::vector<std::string> out;
  for (const char* var : {"XDG_RUNTIME_DIR", "TMPDIR"})
    if (const char* v = std::getenv(var); v != nullptr && v[0] == '/') out.emplace_back(v);
  out.emplace_back("/tmp");
  return out;
}

// Writes all of `n` bytes. False with errno set.
bool write_all(int fd, const char* data, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, data, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    data += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

// Copies the open file `in` into `to` (created, this user's only). False with *why.
bool copy_bytes(int in, const std::string& to, std::string* why) {
  const int out = ::open(to.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0700);
  if (out < 0) return *why = "cannot create " + to + ": " + std::strerror(errno), false;
  char buf[1 << 16];
  bool ok = true;
  for (;;) {
    const ssize_t r = ::read(in, buf, sizeof buf);
    if (r < 0 && errno == EINTR) continue;
    if (r == 0) break;
    if (r < 0 || !write_all(out, buf, static_cast<std::size_t>(r))) {
      *why = std::string("cannot copy it: ") + std::strerror(errno);
      ok = false;
      break;
    }
  }
  if (::close(out) != 0 && ok) *why = std::string("cannot copy it: ") + std::strerror(errno), ok = false;
  return ok;
}

// The private copy a package is loaded from (see controllers/packages.h): made by make(), removed with its folder
// when it goes (right after dlopen: the mapping keeps the pages of the deleted file).
class PrivateCopy {
 public:
  PrivateCopy() = default;
  PrivateCopy(const PrivateCopy&) = delete;
  PrivateCopy& operator=(const PrivateCopy&) = delete;
  ~PrivateCopy() {
    if (!path_.empty()) ::unlink(path_.c_str());
    if (!dir_.empty()) ::rmdir(dir_.c_str());
  }
  const std::string& path() const { return path_; }

  // Copies `file` (named NAME.dca.so in the copy's folder, as in backtraces); *id: the file as copied. False with
  // *why: the file cannot be read, no folder can hold the copy, or the file changed while it was copied.
  bool make(const std::string& file, FileIdentity* id, std::string* why) {
    const int in = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (in < 0) return *why = std::string("cannot read it: ") + std::strerror(errno), false;
    struct stat before {}, after {};
    bool ok = ::fstat(in, &before) == 0;
    if (!ok) *why = std::string("cannot examine it: ") + std::strerror(errno);
    ok = ok && made_dir(why);
    if (ok) path_ = dir_ + "/" + fs::path(file).filename().string();
    ok = ok && copy_bytes(in, path_, why);
    if (ok && (::fstat(in, &after) != 0 || identity_of(after) != identity_of(before))) {
      *why = "it changed while it was read (being written?): load it again once it is written";
      ok = false;
    }
    ::close(in);
    if (ok) *id = identity_of(before);
    return ok;
  }

 private:
  bool made_dir(std::string* why) {
    std::string tried;
    for (const auto& base : copy_bases()) {
      std::string tmpl = base + "/dca-package-XXXXXX";
      if (::mkdtemp(tmpl.data()) != nullptr) return dir_ = tmpl, true;  // mode 0700
      tried += (tried.empty() ? "" : ", ") + base + " (" + std::strerror(errno) + ")";
    }
    *why = "no folder can hold its private copy: tried " + tried;
    return false;
  }

  std::string dir_, path_;
};

}  // namespace

std::string abi_differences(const std::string& package_abi) {
  const auto ours = stamp_parts(DCA_ABI_STAMP), theirs = stamp_parts(package_abi);
  std::vector<std::string> keys;
  for (const auto* parts : {&ours, &theirs})
    for (const auto& [k, v] : *parts)
      if (k != "cc" && std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
  std::string out;
  for (const auto& k : keys) {
    const std::string a = stamp_part(theirs, k), b = stamp_part(ours, k);
    if (a != b) out += (out.empty() ? "" : "; ") + part_name(k) + " " + a + " (package) vs " + b + " (this dca)";
  }
  return out;
}

namespace {

// A package built against another dca: what differs, and the compilers of both (named, never compared).
std::string built_elsewhere(const std::string& name, const std::string& file, const std::string& version,
                            const std::string& abi) {
  std::string why = version != DCA_VERSION_STRING
                        ? "was built against dca " + version + "; this is dca " + DCA_VERSION_STRING
                        : "was built against another dca " + version;
  if (const auto d = abi_differences(abi); !d.empty()) why += ": " + d;
  const auto compiler = [](const std::string& stamp) {
    const auto cc = stamp_part(stamp_parts(stamp), "cc");
    return cc == "(none)" ? std::string("an unnamed compiler") : cc.substr(3);
  };
  return quote(name, file) + " " + why + " (built with " + compiler(abi) + ", this dca with " +
         compiler(DCA_ABI_STAMP) + "): rebuild the package against this dca";
}

// Whether a package's version and stamp are this dca's (its compiler may differ).
bool compatible(const std::string& version, const std::string& abi) {
  return version == DCA_VERSION_STRING && abi_differences(abi).empty();
}

std::string demangled(const std::string& symbol) {
  int status = 0;
  char* d = abi::__cxa_demangle(symbol.c_str(), nullptr, nullptr, &status);
  std::string out = status == 0 && d ? d : symbol;
  std::free(d);  // NOLINT: __cxa_demangle's buffer
  return out;
}

// Why dlopen refused `file` (loaded from its private copy `copy`, read for the stamp and never named): a mismatch
// its stamp shows, a missing symbol, or the loader's own words.
std::string open_error(const std::string& name, const std::string& file, const std::string& copy,
                       std::string why) {
  for (auto at = why.find(copy); !copy.empty() && at != std::string::npos; at = why.find(copy, at + file.size()))
    why.replace(at, copy.size(), file);
  if (auto stamp = read_stamp(copy); stamp && !compatible(stamp->first, stamp->second))
    return built_elsewhere(name, file, stamp->first, stamp->second);
  const std::string undefined = "undefined symbol: ";
  if (const auto at = why.find(undefined); at != std::string::npos) {
    std::string symbol = why.substr(at + undefined.size());
    if (const auto end = symbol.find_first_of(" \t\n,"); end != std::string::npos) symbol.resize(end);
    return quote(name, file) + ": missing symbol '" + demangled(symbol) + "'" +
           (demangled(symbol) != symbol ? " (" + symbol + ")" : "") +
           ": the library needs it and neither dca nor the libraries the package links provide it";
  }
  std::string hint;
  if (why.find("failed to map segment") != std::string::npos)
    hint = " (its private copy was in " + fs::path(copy).parent_path().parent_path().string() +
           ": a file system mounted noexec cannot hold code; set XDG_RUNTIME_DIR or TMPDIR to a folder that can)";
  return "cannot load " + quote(name, file) + ": " + why + hint;
}

// Runs the entry point's add_types into a staged registry, then into the global one (all or nothing).
bool add_types(const PackageEntry& e, const std::string& name, const std::string& file, LoadedPackage& out,
               std::string* error) {
  Registry staged;
  try {
    e.add_types(staged);
  } catch (const std::exception& ex) {
    *error = quote(name, file) + ": " + ex.what();
    return false;
  }
  for (const auto* m : staged.all()) out.types.push_back(m->type);
  std::string why;
  if (!Registry::global().adopt(std::move(staged), name, &why)) {
    *error = why + " (" + file + ")";
    return false;
  }
  return true;
}

// The entry point's answer, checked: nullptr with *error when absent or built against another dca.
const PackageEntry* entry_of(void* handle, const std::string& name, const std::string& file, std::string* error) {
  void* sym = ::dlsym(handle, DCA_PACKAGE_ENTRY_SYMBOL);
  if (sym == nullptr) {
    *error = quote(name, file) + " is not a dca controller package: it has no " DCA_PACKAGE_ENTRY_SYMBOL
             " (build it with dca_add_controller_package)";
    return nullptr;
  }
  using EntryFn = const PackageEntry* (*)();
  const PackageEntry* e = reinterpret_cast<EntryFn>(sym)();
  if (e == nullptr || e->version == nullptr || e->abi == nullptr || e->name == nullptr || e->add_types == nullptr) {
    *error = quote(name, file) + ": its entry point answered nothing usable";
    return nullptr;
  }
  if (!compatible(e->version, e->abi)) {
    *error = built_elsewhere(name, file, e->version, e->abi);
    return nullptr;
  }
  if (name != e->name) {
    *error = quote(name, file) + " holds package '" + e->name + "': a package's file is named after it";
    return nullptr;
  }
  return e;
}

}  // namespace

bool valid_package_name(std::string_view name) {
  if (name.empty() || name.size() > 64) return false;
  if (!(std::isalpha(static_cast<unsigned char>(name[0])) || name[0] == '_')) return false;
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

std::optional<std::string> find_package(const std::string& name, const std::vector<std::string>& dirs,
                                        std::string* error) {
  if (!valid_package_name(name)) {
    *error = "'" + name + "' is not a package name (a word: letters, digits and '_')";
    return std::nullopt;
  }
  std::string searched;
  for (const auto& d : dirs) {
    const fs::path file = fs::path(d) / (name + std::string(kSuffix));
    searched += (searched.empty() ? "" : ", ") + file.string();
    std::error_code ec;
    if (!fs::exists(file, ec)) continue;
    if (!inside(file, d)) {
      *error = "package '" + name + "': " + file.string() + " leads outside " + d + " (not loaded)";
      return std::nullopt;
    }
    const fs::path real = fs::canonical(file, ec);
    for (const fs::path& p : {real, real.parent_path()})
      if (std::string why = untrusted(p); !why.empty()) {
        *error = "package '" + name + "': " + why + " (not loaded)";
        return std::nullopt;
      }
    return real.string();
  }
  *error = "package '" + name + "' not found (searched: " + (searched.empty() ? "no directory" : searched) +
           "; set DCA_CONTROLLER_PATH to the directory that holds " + name + std::string(kSuffix) + ")";
  return std::nullopt;
}

const LoadedPackage* load_package(const std::string& name, const std::vector<std::string>& dirs, std::string* error) {
  for (const auto& p : loaded())
    if (p->name == name) return p.get();
  const auto file = find_package(name, dirs, error);
  if (!file) return nullptr;
  return load_package_file(name, *file, error);
}

// While a package's own code runs during its load (its static initialisers in dlopen, its add_types), a fatal
// signal first writes a line naming the package to stderr, then takes its course (the handler before, or the
// default: the process dies by that signal). Without it, `dca check` or a node died with no word of which package
// did it. The line is made before; the handler only write(2)s it and puts the earlier handlers back.
class LoadingGuard {
 public:
  LoadingGuard(const std::string& name, const std::string& file) {
    const std::string line = "dca: package '" + name + "' (" + file +
                             ") crashed while loading (in its static initialisers or add_types); it is not " +
                             "loaded: fix or remove it\n";
    std::snprintf(message_, sizeof message_, "%s", line.c_str());
    struct sigaction sa {};
    sa.sa_handler = &LoadingGuard::on_signal;
    sigemptyset(&sa.sa_mask);
    for (std::size_t i = 0; i < kSignals.size(); ++i) ::sigaction(kSignals[i], &sa, &before_[i]);
  }
  ~LoadingGuard() { restore(); }
  LoadingGuard(const LoadingGuard&) = delete;
  LoadingGuard& operator=(const LoadingGuard&) = delete;

 private:
  static constexpr std::array<int, 5> kSignals{SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT};
  static void restore() {
    for (std::size_t i = 0; i < kSignals.size(); ++i) ::sigaction(kSignals[i], &before_[i], nullptr);
  }
  // The faulting instruction runs again on return and meets the earlier handler; abort() raises again itself.
  static void on_signal(int) {
    (void)!::write(STDERR_FILENO, message_, std::strlen(message_));
    restore();
  }
  static inline char message_[1024];
  static inline std::array<struct sigaction, kSignals.size()> before_{};
};

const LoadedPackage* load_package_file(const std::string& name, const std::string& file, std::string* error) {
  for (const auto& p : loaded())
    if (p->name == name) return p.get();
  auto pkg = std::make_unique<LoadedPackage>();
  void* handle = nullptr;
  {
    PrivateCopy copy;  // removed, with its folder, once opened
    std::string why;
    if (!copy.make(file, &pkg->identity, &why)) {
      *error = "cannot load " + quote(name, file) + ": " + why;
      return nullptr;
    }
    ::dlerror();
    const LoadingGuard guard(name, file);
    handle = ::dlopen(copy.path().c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      const char* dl = ::dlerror();
      *error = open_error(name, file, copy.path(), dl ? dl : "dlopen failed");
      return nullptr;
    }
  }
  pkg->name = name;
  pkg->file = file;
  const PackageEntry* e = entry_of(handle, name, file, error);
  const bool added = e != nullptr && [&] {
    const LoadingGuard guard(name, file);
    return add_types(*e, name, file, *pkg, error);
  }();
  if (!added) {
    ::dlclose(handle);  // nothing of it is left in the registry
    return nullptr;
  }
  pkg->version = e->version;
  loaded().push_back(std::move(pkg));
  return loaded().back().get();
}

std::vector<std::string> available_packages(const std::vector<std::string>& dirs) {
  std::set<std::string> names;
  for (const auto& d : dirs) {
    std::error_code ec;
    for (fs::directory_iterator it(d, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string f = it->path().filename().string();
      if (f.size() <= kSuffix.size() || f.compare(f.size() - kSuffix.size(), kSuffix.size(), kSuffix) != 0) continue;
      const std::string n = f.substr(0, f.size() - kSuffix.size());
      if (valid_package_name(n)) names.insert(n);
    }
  }
  return {names.begin(), names.end()};
}

std::string package_changed(const std::string& name, const std::vector<std::string>& dirs) {
  const LoadedPackage* pkg = nullptr;
  for (const auto& p : loaded())
    if (p->name == name) pkg = p.get();
  if (pkg == nullptr) return "";
  std::string error;
  const auto file = find_package(name, dirs, &error);
  if (!file) return error;
  if (*file != pkg->file) return *file + " would be loaded now, not " + pkg->file + " which this process loaded";
  struct stat st {};
  if (::stat(file->c_str(), &st) != 0) return *file + " cannot be examined: " + std::strerror(errno);
  if (identity_of(st) != pkg->identity) return *file + " changed on disk since this process loaded it";
  return "";
}

std::vector<const LoadedPackage*> loaded_packages() {
  std::vector<const LoadedPackage*> v;
  for (const auto& p : loaded()) v.push_back(p.get());
  return v;
}

}  // namespace dca
