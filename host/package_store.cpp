#include "host/package_store.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "host/paths.h"

namespace dca {

namespace fs = std::filesystem;

namespace {

constexpr const char* kSuffix = ".dca.so";
constexpr std::size_t kMaxPackage = 15u << 20;  // below the control plane's 16 MiB frame

// A package name as `use NAME;` takes it: a C++ identifier, at most 64 characters.
bool is_word(const std::string& s) {
  if (s.empty() || s.size() > 64 || std::isdigit(static_cast<unsigned char>(s[0]))) return false;
  for (char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  return true;
}

std::string sys_error(const std::string& what, const std::string& path) {
  return what + " " + path + ": " + std::strerror(errno);
}

// A folder made if missing, mode 0755 (the loader refuses a group- or world-writable one).
bool make_dir(const std::string& d, std::string* error) {
  std::error_code ec;
  fs::create_directories(d, ec);
  if (ec) {
    *error = "cannot make " + d + ": " + ec.message();
    return false;
  }
  if (::chmod(d.c_str(), 0755) != 0) {
    *error = sys_error("cannot set the mode of", d);
    return false;
  }
  return true;
}

// `data` written to `path` (0644, flushed to disk), created anew.
bool write_file(const std::string& path, std::string_view data, std::string* error) {
  ::unlink(path.c_str());
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) {
    *error = sys_error("cannot write", path);
    return false;
  }
  std::size_t at = 0;
  while (at < data.size()) {
    const ssize_t n = ::write(fd, data.data() + at, data.size() - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      *error = sys_error("cannot write", path);
      ::close(fd);
      ::unlink(path.c_str());
      return false;
    }
    at += static_cast<std::size_t>(n);
  }
  const bool ok = ::fchmod(fd, 0644) == 0 && ::fsync(fd) == 0;
  if (!ok) *error = sys_error("cannot write", path);
  ::close(fd);
  if (!ok) ::unlink(path.c_str());
  return ok;
}

// The folder's entries (a rename) made durable: flushed to disk (best effort).
void sync_dir(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

bool exists(const std::string& path) {
  struct stat st{};
  return ::lstat(path.c_str(), &st) == 0;
}

}  // namespace

std::string package_version(std::string_view bytes) {
  std::array<unsigned char, EVP_MAX_MD_SIZE> md{};
  unsigned int n = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), md.data(), &n, EVP_sha256(), nullptr) != 1 || n < 8) return "";
  static const char* kHex = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < 8; ++i) {
    out += kHex[md[i] >> 4];
    out += kHex[md[i] & 15];
  }
  return out;
}

std::string package_file_version(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return in.bad() ? "" : package_version(bytes);
}

PackageStore::PackageStore(std::string host, std::string dir, std::string off)
    : host_(std::move(host)), dir_(std::move(dir)), off_(std::move(off)) {}

std::string PackageStore::current(const std::string& name) const { return dir_ + "/current/" + name + kSuffix; }
std::string PackageStore::previous(const std::string& name) const { return dir_ + "/previous/" + name + kSuffix; }

void PackageStore::start() {
  std::error_code ec;
  if (!dir_.empty() && fs::is_directory(dir_ + "/current", ec)) on_path();
}

// <dir>/current first on DCA_CONTROLLER_PATH, once: every node this daemon starts from now on searches it first.
bool PackageStore::on_path() {
  if (on_path_) return true;
  const char* old = std::getenv("DCA_CONTROLLER_PATH");
  const std::string path = dir_ + "/current" + (old != nullptr && old[0] != '\0' ? ":" + std::string(old) : "");
  on_path_ = ::setenv("DCA_CONTROLLER_PATH", path.c_str(), 1) == 0;
  return on_path_;
}

std::optional<PackageStore::Versions> PackageStore::install(const std::string& name, std::string_view data,
                                                            std::string* error) {
  const auto fail = [&](std::string why) -> std::optional<Versions> {
    *error = "package_install of '" + name + "' on host " + host_ + ": " + why;
    return std::nullopt;
  };
  if (dir_.empty()) return fail(off_);
  if (!is_word(name)) return fail("a package name is a word (letters, digits, _), as `use NAME;` takes it");
  if (data.size() < 4 || data.substr(0, 4) != std::string_view("\x7f" "ELF", 4))
    return fail("not a shared library (no ELF header in its " + std::to_string(data.size()) + " bytes)");
  if (data.size() > kMaxPackage) return fail("larger than " + std::to_string(kMaxPackage) + " bytes");
  std::string why;
  if (!make_dir(dir_, &why) || !make_dir(dir_ + "/current", &why) || !make_dir(dir_ + "/previous", &why))
    return fail(why);
  Versions v;
  v.version = package_version(data);
  const std::string cur = current(name), prev = previous(name);
  if (exists(cur)) {
    const std::string had = package_file_version(cur);
    if (had == v.version) {
      v.previous = exists(prev) ? package_file_version(prev) : "";
      v.unchanged = true;
      if (!on_path()) return fail("cannot set DCA_CONTROLLER_PATH");
      return v;
    }
    // the replaced file stays as previous (a second name of its inode, then renamed over the old previous)
    const std::string tmp = prev + ".tmp";
    ::unlink(tmp.c_str());
    if (::link(cur.c_str(), tmp.c_str()) != 0) return fail(sys_error("cannot keep", cur));
    if (::rename(tmp.c_str(), prev.c_str()) != 0) return fail(sys_error("cannot keep", cur));
    v.previous = had;
  } else if (exists(prev) && ::unlink(prev.c_str()) != 0) {
    return fail(sys_error("cannot remove", prev));
  }
  const std::string tmp = cur + ".tmp";
  if (!write_file(tmp, data, &why)) return fail(why);
  if (::rename(tmp.c_str(), cur.c_str()) != 0) {
    ::unlink(tmp.c_str());
    return fail(sys_error("cannot install", cur));
  }
  sync_dir(dir_ + "/previous");
  sync_dir(dir_ + "/current");
  if (!on_path()) return fail("cannot set DCA_CONTROLLER_PATH");
  return v;
}

std::optional<PackageStore::Versions> PackageStore::rollback(const std::string& name, std::string* error) {
  const auto fail = [&](std::string why) -> std::optional<Versions> {
    *error = "package_rollback of '" + name + "' on host " + host_ + ": " + why;
    return std::nullopt;
  };
  if (dir_.empty()) return fail(off_);
  if (!is_word(name)) return fail("a package name is a word (letters, digits, _)");
  const std::string cur = current(name), prev = previous(name);
  const bool has_cur = exists(cur), has_prev = exists(prev);
  if (!has_cur && !has_prev) return fail("no version of it was installed here (" + dir_ + ")");
  if (has_cur && has_prev) {
    const std::string tmp = prev + ".swap";
    ::unlink(tmp.c_str());
    if (::link(cur.c_str(), tmp.c_str()) != 0) return fail(sys_error("cannot keep", cur));
    if (::rename(prev.c_str(), cur.c_str()) != 0) return fail(sys_error("cannot restore", prev));
    if (::rename(tmp.c_str(), prev.c_str()) != 0) return fail(sys_error("cannot keep", cur));
  } else if (has_cur) {
    if (::rename(cur.c_str(), prev.c_str()) != 0) return fail(sys_error("cannot remove", cur));
  } else if (::rename(prev.c_str(), cur.c_str()) != 0) {
    return fail(sys_error("cannot restore", prev));
  }
  sync_dir(dir_ + "/previous");
  sync_dir(dir_ + "/current");
  Versions v;
  v.version = exists(cur) ? package_file_version(cur) : "";
  v.previous = exists(prev) ? package_file_version(prev) : "";
  return v;
}

wire::Value PackageStore::status(const wire::Value& payload) const {
  wire::Value::Array list;
  std::error_code ec;
  const std::string only = payload["name"].is_string() ? payload["name"].as_string() : "";
  for (const char* sub : {"/current", "/previous"}) {
    for (fs::directory_iterator it(dir_ + sub, ec), end; !ec && it != end; it.increment(ec)) {
      std::string f = it->path().filename().string();
      const std::string suffix = kSuffix;
      if (f.size() <= suffix.size() || f.compare(f.size() - suffix.size(), suffix.size(), suffix) != 0) continue;
      const std::string name = f.substr(0, f.size() - suffix.size());
      if (!only.empty() && name != only) continue;
      bool seen = false;
      for (const auto& e : list) seen = seen || e["name"].as_string() == name;
      if (seen) continue;
      list.push_back(wire::Value::map()
                         .set("name", name)
                         .set("version", exists(current(name)) ? package_file_version(current(name)) : "")
                         .set("previous", exists(previous(name)) ? package_file_version(previous(name)) : ""));
    }
    ec.clear();
  }
  wire::Value r = wire::Value::map().set("host", host_).set("dir", dir_).set("packages", list);
  if (!only.empty() && is_word(only)) {
    const std::string sys = payload["system_dir"].is_string() ? payload["system_dir"].as_string() : "";
    for (const auto& d : controller_dirs(sys.empty() || sys[0] != '/' ? "" : sys)) {
      const std::string file = d + "/" + only + kSuffix;
      if (!exists(file)) continue;
      r.set("loads", wire::Value::map().set("file", file).set("version", package_file_version(file)));
      break;
    }
  }
  return r;
}

bool PackageStore::handle(const Channel::Ptr& ch, const wire::Message& m) {
  if (m.type.rfind("package_", 0) != 0) return false;
  if (m.type == "package_status") {
    if (dir_.empty()) {
      ch->reply_error(m, off_);
    } else {
      ch->reply(m, status(m.payload));
    }
    return true;
  }
  const std::string name = m.payload["name"].is_string() ? m.payload["name"].as_string() : "";
  std::string error;
  std::optional<Versions> v;
  if (m.type == "package_install") {
    const wire::Value& data = m.payload["data"];
    if (!data.is_string()) {
      ch->reply_error(m, "package_install on host " + host_ + ": data must be the package file's bytes");
      return true;
    }
    v = install(name, data.as_string(), &error);
  } else if (m.type == "package_rollback") {
    v = rollback(name, &error);
  } else {
    ch->reply_error(m, "unknown request '" + m.type + "' (daemon on host " + host_ +
                           "; package_install, package_rollback, package_status)");
    return true;
  }
  if (!v) {
    ch->reply_error(m, error);
    return true;
  }
  ch->reply(m, wire::Value::map()
                   .set("name", name)
                   .set("version", v->version)
                   .set("previous", v->previous)
                   .set("unchanged", v->unchanged)
                   .set("host", host_));
  return true;
}

}  // namespace dca
