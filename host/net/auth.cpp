#include "host/net/auth.h"

#include <fcntl.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "host/codec/hex.h"
#include "host/paths.h"

namespace dca::auth {
namespace {

constexpr const char* kContext = "dca-auth-1 ";

std::string mode_string(mode_t m) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%04o", static_cast<unsigned>(m & 07777));
  return buf;
}

}  // namespace

std::string random_bytes(std::size_t n) {
  std::string out(n, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(out.data()), static_cast<int>(n)) != 1)
    throw std::runtime_error("OpenSSL RAND_bytes failed: no random source");
  return out;
}

std::string hmac_sha256(const std::string& key, const std::string& data) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()), reinterpret_cast<const unsigned char*>(data.data()),
       data.size(), md, &len);
  return std::string(reinterpret_cast<const char*>(md), len);
}

bool equal_mac(const std::string& a, const std::string& b) {
  return a.size() == b.size() && CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

std::string random_token(std::size_t n) { return hex::encode(random_bytes(n)); }

Key data_key(const Key& cluster_key) {
  if (cluster_key.empty()) return {};  // no key stays no key: the handshake then refuses
  return hmac_sha256(cluster_key, "dca-data-1");
}

std::string key_token(const Key& cluster_key) { return hex::encode(hmac_sha256(cluster_key, "dca-monitor-1").substr(0, 16)); }

Handshake::Handshake(Role role, Key key, std::function<std::string()> nonce_source)
    : role_(role), key_(std::move(key)), nonce_source_(std::move(nonce_source)) {
  if (!nonce_source_) nonce_source_ = [] { return random_bytes(kNonceSize); };
}

Handshake::Step Handshake::fail(std::string reason, std::string tell_peer) {
  Step s;
  state_ = State::kFailed;
  reason_ = std::move(reason);
  s.out.push_back(wire::Message{"error", 0, wire::Value::map().set("reason", std::move(tell_peer))});
  s.state = state_;
  return s;
}

std::string Handshake::mac(const char* role) const {
  return hmac_sha256(key_, std::string(kContext) + role + client_nonce_ + server_nonce_);
}

Handshake::Step Handshake::start() {
  Step s;
  if (key_.empty()) return fail("no cluster key", "the peer has no cluster key");
  my_nonce_ = nonce_source_();
  if (role_ == Role::kClient) {
    client_nonce_ = my_nonce_;
    s.out.push_back(wire::Message{
        "hello", 0, wire::Value::map().set("version", wire::kProtocolVersion).set("nonce", my_nonce_)});
  } else {
    server_nonce_ = my_nonce_;
  }
  return s;
}

Handshake::Step Handshake::on_message(const wire::Message& m) {
  if (state_ != State::kRunning) return Step{{}, state_};
  if (my_nonce_.empty()) return fail("handshake not started", "handshake not started");
  if (m.type == "error") {
    state_ = State::kFailed;
    const std::string why = m.payload["reason"].as_string();
    reason_ = "refused by the peer: " + (why.empty() ? std::string("no reason given") : why);
    return Step{{}, state_};
  }
  const auto check_version = [&](const wire::Message& msg) -> bool {
    peer_version_ = msg.payload["version"].as_int(-1);
    return peer_version_ == wire::kProtocolVersion;
  };
  const auto bad_version = [&]() {
    std::string why = "protocol version " + std::to_string(peer_version_) + " not supported (this side speaks " +
                      std::to_string(wire::kProtocolVersion) + ")";
    return fail(why, why);
  };

  if (role_ == Role::kServer) {
    if (stage_ == 0) {
      if (m.type != "hello")
        return fail("expected a handshake hello, got '" + m.type + "' (the peer did not authenticate)",
                    "authentication required: expected hello, got '" + m.type + "'");
      if (!check_version(m)) return bad_version();
      client_nonce_ = m.payload["nonce"].as_string();
      if (client_nonce_.size() != kNonceSize) return fail("malformed hello: bad nonce", "malformed hello: bad nonce");
      if (client_nonce_ == server_nonce_) return fail("reflected nonce in hello", "reflected nonce");
      stage_ = 1;
      Step s;
      s.out.push_back(wire::Message{"challenge", 0,
                                    wire::Value::map()
                                        .set("version", wire::kProtocolVersion)
                                        .set("nonce", server_nonce_)
                                        .set("mac", mac("server"))});
      return s;
    }
    if (m.type != "proof")
      return fail("expected a handshake proof, got '" + m.type + "'", "expected proof, got '" + m.type + "'");
    if (!equal_mac(m.payload["mac"].as_string(), mac("client")))
      return fail("the peer failed the key check (wrong cluster key, or a replayed or tampered handshake)",
                  "wrong cluster key: this side's key check failed (or the handshake was replayed or tampered)");
    state_ = State::kDone;
    Step s;
    s.out.push_back(wire::Message{"welcome", 0, wire::Value::map()});
    s.state = state_;
    return s;
  }

  // client
  if (stage_ == 0) {
    if (m.type != "challenge")
      return fail("expected a handshake challenge, got '" + m.type + "'",
                  "expected challenge, got '" + m.type + "'");
    if (!check_version(m)) return bad_version();
    server_nonce_ = m.payload["nonce"].as_string();
    if (server_nonce_.size() != kNonceSize) return fail("malformed challenge: bad nonce", "bad nonce");
    if (server_nonce_ == client_nonce_) return fail("reflected nonce in challenge", "reflected nonce");
    if (!equal_mac(m.payload["mac"].as_string(), mac("server")))
      return fail("the server failed the key check (wrong cluster key, or a replayed or tampered handshake)",
                  "wrong cluster key: the client's key check of this server failed");
    stage_ = 1;
    Step s;
    s.out.push_back(wire::Message{"proof", 0, wire::Value::map().set("mac", mac("client"))});
    return s;
  }
  if (m.type != "welcome")
    return fail("expected a handshake welcome, got '" + m.type + "'", "expected welcome, got '" + m.type + "'");
  state_ = State::kDone;
  return Step{{}, state_};
}

std::string key_file_path(const std::string& explicit_path) {
  if (!explicit_path.empty()) return explicit_path;
  if (const char* e = std::getenv("DCA_KEY_FILE"); e != nullptr && *e != '\0') return e;
  return dca::config_dir() + "/key";
}

std::optional<Key> load_key(const std::string& path, std::string* error) {
  const auto set = [&](std::string e) {
    if (error != nullptr) *error = std::move(e);
    return std::nullopt;
  };
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) return set("cannot read key file " + path + ": " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return set("key file " + path + " is not a regular file");
  }
  if ((st.st_mode & 077) != 0) {
    ::close(fd);
    return set("key file " + path + " has mode " + mode_string(st.st_mode) + "; it must be 0600 (chmod 600 " +
               path + ")");
  }
  if (st.st_uid != ::geteuid()) {
    ::close(fd);
    return set("key file " + path + " is not owned by this user");
  }
  std::string key;
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    key.append(buf, static_cast<std::size_t>(n));
    if (key.size() > (1u << 16)) break;
  }
  ::close(fd);
  while (!key.empty() && (key.back() == '\n' || key.back() == '\r' || key.back() == ' ')) key.pop_back();
  if (key.size() < 16) return set("key file " + path + " holds fewer than 16 bytes of key");
  return key;
}

std::optional<Key> load_or_create_key(const std::string& path, std::string* error) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    const auto dir = std::filesystem::path(path).parent_path();
    if (!dir.empty() && !std::filesystem::exists(dir, ec)) {
      std::filesystem::create_directories(dir, ec);
      if (ec) {
        if (error != nullptr) *error = "cannot create the directory of key file " + path + ": " + ec.message();
        return std::nullopt;
      }
      std::filesystem::permissions(dir, std::filesystem::perms::owner_all, ec);
    }
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd >= 0) {
      const std::string text = hex::encode(random_bytes(32)) + "\n";
      const bool ok = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
      ::fchmod(fd, 0600);
      ::close(fd);
      if (!ok) {
        ::unlink(path.c_str());
        if (error != nullptr) *error = "cannot write key file " + path + ": " + std::strerror(errno);
        return std::nullopt;
      }
      std::fprintf(stderr, "dca: created a new cluster key in %s\n", path.c_str());
    } else if (errno != EEXIST) {
      if (error != nullptr) *error = "cannot create key file " + path + ": " + std::strerror(errno);
      return std::nullopt;
    }
  }
  return load_key(path, error);
}

}  // namespace dca::auth
