#pragma once
// host/codec: pure encoders and decoders. No Asio, no Beast, no socket, nothing of host/net or host/web.
// Hex text, the tree's one hex codec: keys and tokens (host/net/auth), escapes in JSON (\u), URLs (%XX) and
// rendered wire values (\xXX).
#include <string>
#include <string_view>

namespace dca::hex {

/// `bytes` as lower-case hex, two digits a byte.
inline std::string encode(std::string_view bytes) {
  static constexpr std::string_view kDigits = "0123456789abcdef";
  std::string out;
  out.reserve(2 * bytes.size());
  for (const unsigned char c : bytes) {
    out += kDigits[c >> 4];
    out += kDigits[c & 15];
  }
  return out;
}

/// The value of the hex digit `c` (either case), or -1.
inline int digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace dca::hex
