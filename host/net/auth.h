#pragma once
// host/net: sockets on the io_context (Asio). Never Beast, never host/web.
// The handshake that opens every control connection, the cluster key file, and everything derived from the
// cluster key (the data plane's key, the monitor's key token), written in hex by host/codec/hex.h.
// Pure code apart from the key file functions: the handshake is a state machine fed with wire messages,
// testable without a socket.
//
// The exchange (K the cluster key, Nc and Ns 32 fresh random bytes from each side, H = HMAC-SHA256):
//   client -> server  hello     {version, nonce = Nc}
//   server -> client  challenge {version, nonce = Ns, mac = H(K, "dca-auth-1 server" Nc Ns)}
//   client -> server  proof     {mac = H(K, "dca-auth-1 client" Nc Ns)}      (after checking the server's mac)
//   server -> client  welcome   {}                                            (after checking the client's mac)
// Either side refusing sends `error {reason}` and closes. Fresh nonces from both sides make a recorded
// handshake useless against a new connection (replay); the role in each MAC stops reflection.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "host/codec/wire.h"

namespace dca::auth {

/// Bytes of each side's nonce.
inline constexpr std::size_t kNonceSize = 32;

/// The cluster key (raw bytes); empty means "no key".
using Key = std::string;

/// 32 bytes from the operating system's random source (OpenSSL RAND_bytes).
std::string random_bytes(std::size_t n);
/// HMAC-SHA256 of `data` with `key` (32 bytes).
std::string hmac_sha256(const std::string& key, const std::string& data);
/// Constant-time comparison.
bool equal_mac(const std::string& a, const std::string& b);

/// `n` random bytes (random_bytes) as 2n hex digits.
std::string random_token(std::size_t n = 16);

/// The key the data plane's handshake uses (host/net/endpoint.h): HMAC-SHA256(cluster key, "dca-data-1"), "" for
/// no key. A MAC made on a control port (keyed with the cluster key itself) is therefore worthless on a data port.
Key data_key(const Key& cluster_key);
/// The web monitor's token derived from the cluster key (host/web/web.h), which any key holder can compute:
/// hex of the first 16 bytes of HMAC-SHA256(cluster key, "dca-monitor-1").
std::string key_token(const Key& cluster_key);

/// One side of the handshake.
class Handshake {
 public:
  enum class Role { kClient, kServer };
  enum class State {
    kRunning,  ///< waiting for the peer's next message
    kDone,     ///< authenticated: the connection is open
    kFailed,   ///< refused: `reason()` says why; send `out` (an error message for the peer), then close
  };
  /// What one step produced: messages to send (in order) and the new state.
  struct Step {
    std::vector<wire::Message> out;
    State state = State::kRunning;
  };

  /// `nonce_source` gives the nonce (tests pass fixed ones); by default random_bytes(kNonceSize).
  Handshake(Role role, Key key, std::function<std::string()> nonce_source = {});

  /// The first step: the client's hello; nothing for the server. With no key: fails at once.
  Step start();
  /// Feeds the peer's next message.
  Step on_message(const wire::Message& m);

  State state() const { return state_; }
  /// Why the handshake failed ("" otherwise), worded for the side that holds this object.
  const std::string& reason() const { return reason_; }
  /// The peer's protocol version (after its hello/challenge).
  std::int64_t peer_version() const { return peer_version_; }

 private:
  Step fail(std::string reason, std::string tell_peer);
  std::string mac(const char* role) const;

  Role role_;
  Key key_;
  std::function<std::string()> nonce_source_;
  State state_ = State::kRunning;
  int stage_ = 0;
  std::string my_nonce_, client_nonce_, server_nonce_;
  std::string reason_;
  std::int64_t peer_version_ = 0;
};

/// The key file to use: `explicit_path` if not empty, else $DCA_KEY_FILE, else $XDG_CONFIG_HOME/dca/key,
/// else $HOME/.config/dca/key.
std::string key_file_path(const std::string& explicit_path = "");

/// Reads the key from `path`. The file must be a regular file of mode 0600 (no access for group or others)
/// holding at least 16 bytes (hex text as written by load_or_create_key, or raw bytes). On failure returns
/// nullopt with *error naming the file ("key file /x/key has mode 0644; it must be 0600 (chmod 600 /x/key)").
std::optional<Key> load_key(const std::string& path, std::string* error);
/// Like load_key, but creates the file (and its directory, mode 0700) with a fresh random key and mode 0600
/// when it does not exist.
std::optional<Key> load_or_create_key(const std::string& path, std::string* error);

}  // namespace dca::auth
