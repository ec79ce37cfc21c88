#include "host/codec/json.h"

#include <charconv>
#include <cmath>
#include <cstdio>

#include "host/codec/hex.h"

namespace dca::json {

namespace {

// The length of the valid UTF-8 sequence at s[i], or 0: no overlong form, no surrogate, nothing past U+10FFFF
// (RFC 3629; the second byte's range depends on the first).
std::size_t utf8_length(std::string_view s, std::size_t i) {
  const auto c = static_cast<unsigned char>(s[i]);
  if (c < 0x80) return 1;
  const std::size_t n = c >= 0xC2 && c <= 0xDF ? 2 : c >= 0xE0 && c <= 0xEF ? 3 : c >= 0xF0 && c <= 0xF4 ? 4 : 0;
  if (n == 0 || i + n > s.size()) return 0;
  const auto c1 = static_cast<unsigned char>(s[i + 1]);
  const unsigned char lo = c == 0xE0 ? 0xA0 : c == 0xF0 ? 0x90 : 0x80;
  const unsigned char hi = c == 0xED ? 0x9F : c == 0xF4 ? 0x8F : 0xBF;
  if (c1 < lo || c1 > hi) return 0;
  for (std::size_t k = 2; k < n; k++)
    if ((static_cast<unsigned char>(s[i + k]) >> 6) != 2) return 0;
  return n;
}

// U+FFFD, the replacement character, for a byte that starts no valid UTF-8 sequence or a lone surrogate.
constexpr std::string_view kReplacement = "\xEF\xBF\xBD";

}  // namespace

void append_string(std::string& out, std::string_view s) {
  out += '"';
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    const std::size_t n = utf8_length(s, i);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c >= 0x20 && n > 0) {
      out.append(s.substr(i, n));
      i += n;
      continue;
    } else if (c >= 0x80) {
      out += kReplacement;
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    }
    i++;
  }
  out += '"';
}

void append_number(std::string& out, double d) {
  if (!std::isfinite(d)) {
    out += "null";
    return;
  }
  char buf[32];
  auto r = std::to_chars(buf, buf + sizeof buf, d);
  out.append(buf, r.ptr);
}

void append_numbers(std::string& out, std::span<const double> values) {
  out += '[';
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i) out += ',';
    append_number(out, values[i]);
  }
  out += ']';
}

void encode(const wire::Value& v, std::string& out) {
  if (v.is_bool()) {
    out += v.as_bool() ? "true" : "false";
  } else if (v.is_int()) {
    out += std::to_string(v.as_int());
  } else if (v.is_float()) {
    append_number(out, v.as_float());
  } else if (v.is_string()) {
    append_string(out, v.as_string());
  } else if (v.is_array()) {
    out += '[';
    bool first = true;
    for (const auto& e : v.as_array()) {
      if (!first) out += ',';
      first = false;
      encode(e, out);
    }
    out += ']';
  } else if (v.is_map()) {
    out += '{';
    bool first = true;
    for (const auto& [k, e] : v.as_map()) {
      if (!first) out += ',';
      first = false;
      if (k.is_string()) append_string(out, k.as_string());
      else if (k.is_int()) append_string(out, std::to_string(k.as_int()));
      else append_string(out, k.str());
      out += ':';
      encode(e, out);
    }
    out += '}';
  } else {
    out += "null";
  }
}

std::string encode(const wire::Value& v) {
  std::string out;
  encode(v, out);
  return out;
}

namespace {

// A recursive-descent reader over `s` with a position and the first error.
struct Reader {
  std::string_view s;
  std::size_t i = 0;
  std::string error;

  bool fail(const char* what) {
    if (error.empty()) error = "offset " + std::to_string(i) + ": " + what;
    return false;
  }
  void blanks() {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\n' || s[i] == '\r')) i++;
  }
  bool literal(std::string_view word) {
    if (s.substr(i, word.size()) != word) return fail("unknown literal");
    i += word.size();
    return true;
  }
  bool value(wire::Value* out, int depth);
  bool string(std::string* out);
  bool number(wire::Value* out);
  bool array(wire::Value* out, int depth);
  bool object(wire::Value* out, int depth);
  bool hex4(unsigned* out);
};

bool Reader::hex4(unsigned* out) {
  if (i + 4 > s.size()) return fail("short \\u escape");
  unsigned v = 0;
  for (int k = 0; k < 4; k++) {
    const int d = hex::digit(s[i++]);
    if (d < 0) return fail("bad \\u escape");
    v = (v << 4) | static_cast<unsigned>(d);
  }
  *out = v;
  return true;
}

void put_utf8(unsigned cp, std::string* out) {
  if (cp < 0x80) {
    *out += static_cast<char>(cp);
  } else if (cp < 0x800) {
    *out += static_cast<char>(0xC0 | (cp >> 6));
    *out += static_cast<char>(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    *out += static_cast<char>(0xE0 | (cp >> 12));
    *out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    *out += static_cast<char>(0x80 | (cp & 0x3F));
  } else {
    *out += static_cast<char>(0xF0 | (cp >> 18));
    *out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
    *out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    *out += static_cast<char>(0x80 | (cp & 0x3F));
  }
}

bool Reader::string(std::string* out) {
  i++;  // the opening quote
  while (i < s.size()) {
    const char c = s[i++];
    if (c == '"') return true;
    if (static_cast<unsigned char>(c) < 0x20) return fail("control character in a string");
    if (c != '\\') {
      const std::size_t n = utf8_length(s, i - 1);
      if (n == 0) *out += kReplacement;
      else out->append(s.substr(i - 1, n));
      i += n == 0 ? 0 : n - 1;
      continue;
    }
    if (i >= s.size()) break;
    const char e = s[i++];
    switch (e) {
      case '"': case '\\': case '/': *out += e; break;
      case 'b': *out += '\b'; break;
      case 'f': *out += '\f'; break;
      case 'n': *out += '\n'; break;
      case 'r': *out += '\r'; break;
      case 't': *out += '\t'; break;
      case 'u': {
        unsigned cp = 0;
        if (!hex4(&cp)) return false;
        // A high surrogate and a low one are one code point; any other surrogate is U+FFFD, and the escape after
        // a lone high one is read on its own.
        if (cp >= 0xD800 && cp < 0xDC00 && s.substr(i, 2) == "\\u") {
          const std::size_t next = i;
          i += 2;
          unsigned lo = 0;
          if (!hex4(&lo)) return false;
          if (lo >= 0xDC00 && lo < 0xE000) cp = 0x10000 + ((cp - 0xD800) << 10) + (lo - 0xDC00);
          else i = next;
        }
        if (cp >= 0xD800 && cp < 0xE000) *out += kReplacement;
        else put_utf8(cp, out);
        break;
      }
      default: return fail("bad escape");
    }
  }
  return fail("unterminated string");
}

bool Reader::number(wire::Value* out) {
  const std::size_t start = i;
  if (i < s.size() && s[i] == '-') i++;
  bool is_float = false;
  while (i < s.size() && ((s[i] >= '0' && s[i] <= '9') || s[i] == '.' || s[i] == 'e' || s[i] == 'E' ||
                          s[i] == '+' || s[i] == '-')) {
    if (s[i] == '.' || s[i] == 'e' || s[i] == 'E') is_float = true;
    i++;
  }
  const std::string_view text = s.substr(start, i - start);
  if (!is_float && text != "-0") {  // ("-0" is the double -0.0, which encodes so: a round trip keeps its sign)
    std::int64_t n = 0;
    auto r = std::from_chars(text.data(), text.data() + text.size(), n);
    if (r.ec == std::errc() && r.ptr == text.data() + text.size()) {
      *out = wire::Value(n);
      return true;
    }
  }
  double d = 0;
  auto r = std::from_chars(text.data(), text.data() + text.size(), d);
  if (r.ec != std::errc() || r.ptr != text.data() + text.size() || text.empty()) {
    i = start;
    return fail("bad number");
  }
  *out = wire::Value(d);
  return true;
}

bool Reader::array(wire::Value* out, int depth) {
  i++;
  wire::Value::Array a;
  blanks();
  if (i < s.size() && s[i] == ']') {
    i++;
    *out = wire::Value(std::move(a));
    return true;
  }
  while (true) {
    wire::Value e;
    if (!value(&e, depth + 1)) return false;
    a.push_back(std::move(e));
    blanks();
    if (i < s.size() && s[i] == ',') { i++; continue; }
    if (i < s.size() && s[i] == ']') { i++; break; }
    return fail("expected , or ]");
  }
  *out = wire::Value(std::move(a));
  return true;
}

bool Reader::object(wire::Value* out, int depth) {
  i++;
  wire::Value::Map m;
  blanks();
  if (i < s.size() && s[i] == '}') {
    i++;
    *out = wire::Value(std::move(m));
    return true;
  }
  while (true) {
    blanks();
    if (i >= s.size() || s[i] != '"') return fail("expected a key");
    std::string key;
    if (!string(&key)) return false;
    blanks();
    if (i >= s.size() || s[i] != ':') return fail("expected :");
    i++;
    wire::Value e;
    if (!value(&e, depth + 1)) return false;
    m.emplace_back(wire::Value(std::move(key)), std::move(e));
    blanks();
    if (i < s.size() && s[i] == ',') { i++; continue; }
    if (i < s.size() && s[i] == '}') { i++; break; }
    return fail("expected , or }");
  }
  *out = wire::Value(std::move(m));
  return true;
}

bool Reader::value(wire::Value* out, int depth) {
  if (depth > kMaxDepth) return fail("nested too deep");
  blanks();
  if (i >= s.size()) return fail("expected a value");
  switch (s[i]) {
    case '{': return object(out, depth);
    case '[': return array(out, depth);
    case '"': {
      std::string str;
      if (!string(&str)) return false;
      *out = wire::Value(std::move(str));
      return true;
    }
    case 't': *out = wire::Value(true); return literal("true");
    case 'f': *out = wire::Value(false); return literal("false");
    case 'n': *out = wire::Value(); return literal("null");
    default: return number(out);
  }
}

}  // namespace

bool decode(std::string_view text, wire::Value* out, std::string* error) {
  Reader r;
  r.s = text;
  wire::Value v;
  bool ok = r.value(&v, 0);
  if (ok) {
    r.blanks();
    if (r.i != text.size()) ok = r.fail("text after the value");
  }
  if (!ok) {
    if (error) *error = r.error;
    return false;
  }
  *out = std::move(v);
  return true;
}

}  // namespace dca::json
