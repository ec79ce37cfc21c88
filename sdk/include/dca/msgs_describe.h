#pragma once
// Descriptions of dca::msgs (docs/data-plane.md, "Typed messages"), built on demand (they allocate: not for the
// hot path):
//   type_description_json<M>()  the JSON that ROS 2 hashes into M::type_hash (REP-2016, RIHS01): M's type
//       description and those of the types it references, sorted by name, without default values, in the
//       layout of Python's json.dumps(separators=(', ', ': ')); sha256 of it is the hash's hex
//   ros2msg_definition<M>()     M's .msg text and its dependencies' (the MCAP ros2msg schema, as ros2 bag writes)
//   to_json(m)                  a message's values as JSON, fields by name: doubles round-trip (NaN and infinities
//       are null), strings are escaped and always valid UTF-8 (a bad byte is U+FFFD)
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <string_view>

#include "dca/msgs.h"

namespace dca::msgs {

namespace detail {

/// REP-2016's FieldType id of a field of type T (type_description_interfaces/msg/FieldType).
template <class T>
constexpr std::uint8_t field_type_id() {
  if constexpr (IsArray<T>::value) return field_type_id<typename T::value_type>() + 48;
  else if constexpr (IsSeq<T>::value) return field_type_id<typename T::value_type>() + 144;  // unbounded in ROS
  else if constexpr (IsString<T>::value) return 17;
  else if constexpr (std::is_same_v<T, bool>) return 15;
  else if constexpr (std::is_same_v<T, float>) return 10;
  else if constexpr (std::is_same_v<T, double>) return 11;
  else if constexpr (std::is_integral_v<T>) return (sizeof(T) == 1 ? 2 : sizeof(T) == 2 ? 4 : sizeof(T) == 4 ? 6 : 8) +
                                                   (std::is_unsigned_v<T> ? 1 : 0);
  else return 1;  // a nested type
}

template <class T>
struct Element {
  using type = T;
};
template <class T>
  requires(IsArray<T>::value || IsSeq<T>::value)
struct Element<T> {
  using type = typename T::value_type;
};

/// M's {"type_name": ..., "fields": [...]}; adds the types it references to `refs` (by name).
template <class M>
std::string describe(std::map<std::string_view, std::string>& refs) {
  std::string out = "{\"type_name\": \"" + std::string(M::ros_name) + "\", \"fields\": [";
  bool first = true;
  const M m{};
  M::fields(m, [&](std::string_view name, const auto& f) {
    using F = std::remove_cvref_t<decltype(f)>;
    using E = typename Element<F>::type;
    std::string nested;
    std::size_t capacity = 0;
    if constexpr (IsArray<F>::value) capacity = std::tuple_size_v<F>;
    if constexpr (Message<E>) {
      nested = E::ros_name;
      if (!refs.contains(E::ros_name)) refs[E::ros_name] = describe<E>(refs);
    }
    out += first ? "" : ", ";
    first = false;
    out += "{\"name\": \"" + std::string(name) + "\", \"type\": {\"type_id\": " +
           std::to_string(field_type_id<F>()) + ", \"capacity\": " + std::to_string(capacity) +
           ", \"string_capacity\": 0, \"nested_type_name\": \"" + nested + "\"}}";
  });
  return out + "]}";
}

/// The length of the valid UTF-8 sequence at s[i], or 0 (RFC 3629: no overlongs, no surrogates, at most U+10FFFF).
inline std::size_t utf8_length(std::string_view s, std::size_t i) {
  const auto at = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = at(i);
  std::size_t n = 0;
  if (c < 0x80) n = 1;
  else if (c >= 0xc2 && c <= 0xdf) n = 2;
  else if (c >= 0xe0 && c <= 0xef) n = 3;
  else if (c >= 0xf0 && c <= 0xf4) n = 4;
  if (n == 0 || i + n > s.size()) return 0;
  for (std::size_t k = 1; k < n; ++k)
    if ((at(i + k) & 0xc0) != 0x80) return 0;
  if (n == 3 && ((c == 0xe0 && at(i + 1) < 0xa0) || (c == 0xed && at(i + 1) > 0x9f))) return 0;
  if (n == 4 && ((c == 0xf0 && at(i + 1) < 0x90) || (c == 0xf4 && at(i + 1) > 0x8f))) return 0;
  return n;
}

/// `s` as a JSON string: quotes, backslashes and control characters escaped, a byte that is not valid UTF-8
/// replaced by U+FFFD (so the JSON is always valid).
inline void json_string(std::string& out, std::string_view s) {
  out += '"';
  for (std::size_t i = 0; i < s.size();) {
    const char c = s[i];
    const std::size_t n = utf8_length(s, i);
    if (n == 0) {
      out += "\xef\xbf\xbd";
      ++i;
      continue;
    }
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char u[8];
      std::snprintf(u, sizeof u, "\\u%04x", static_cast<unsigned>(c));
      out += u;
    } else {
      out.append(s.substr(i, n));
    }
    i += n;
  }
  out += '"';
}

template <class T>
void json_value(std::string& out, const T& v) {
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(v)) {
      out += "null";  // JSON has no NaN or infinity
      return;
    }
    char b[32];
    std::snprintf(b, sizeof b, "%.17g", static_cast<double>(v));
    out += b;
  } else if constexpr (Primitive<T>) {
    out += std::to_string(v);
  } else if constexpr (IsString<T>::value) {
    json_string(out, v.view());
  } else if constexpr (IsArray<T>::value || IsSeq<T>::value) {
    out += '[';
    for (const auto& e : v) {
      if (&e != &*v.begin()) out += ',';
      json_value(out, e);
    }
    out += ']';
  } else {
    out += '{';
    bool first = true;
    T::fields(v, [&](std::string_view name, const auto& f) {
      if (!first) out += ',';
      first = false;
      json_string(out, name);
      out += ':';
      json_value(out, f);
    });
    out += '}';
  }
}

/// A field's type as .msg text: "float64", "string", "float64[36]", "builtin_interfaces/Time", "string[]".
template <class T>
std::string msg_type_text() {
  if constexpr (IsArray<T>::value) {
    return msg_type_text<typename T::value_type>() + "[" + std::to_string(std::tuple_size_v<T>) + "]";
  } else if constexpr (IsSeq<T>::value) {
    return msg_type_text<typename T::value_type>() + "[]";
  } else if constexpr (IsString<T>::value) {
    return "string";
  } else if constexpr (std::is_same_v<T, bool>) {
    return "bool";
  } else if constexpr (std::is_floating_point_v<T>) {
    return sizeof(T) == 4 ? "float32" : "float64";
  } else if constexpr (std::is_integral_v<T>) {
    return (std::is_unsigned_v<T> ? "uint" : "int") + std::to_string(8 * sizeof(T));
  } else {
    const std::string_view n = T::ros_name;  // "pkg/msg/T" -> "pkg/T"
    return std::string(n.substr(0, n.find('/'))) + std::string(n.substr(n.rfind('/')));
  }
}

/// Appends M's .msg text (one field a line, a primitive's non-zero default after it), then each type it uses
/// directly that is not in `seen`, sorted by name, each after "\n", a line of 80 '=' and "MSG: pkg/T", with its
/// own dependencies after it (depth first, as ros2 bag writes them).
template <class M>
void append_msg(std::string& out, std::set<std::string>& seen) {
  std::map<std::string, void (*)(std::string&, std::set<std::string>&)> deps;
  const M m{};
  M::fields(m, [&](std::string_view name, const auto& f) {
    using F = std::remove_cvref_t<decltype(f)>;
    using E = typename Element<F>::type;
    if constexpr (Message<E>) deps.emplace(msg_type_text<E>(), &append_msg<E>);
    out += msg_type_text<F>() + " " + std::string(name);
    if constexpr (Primitive<F>)
      if (f != F{}) {
        out += ' ';
        json_value(out, f);
      }
    out += '\n';
  });
  for (const auto& [name, append] : deps) {
    if (!seen.insert(name).second) continue;
    out += "\n" + std::string(80, '=') + "\nMSG: " + name + "\n";
    append(out, seen);
  }
}

}  // namespace detail

/// M's complete message definition in the MCAP `ros2msg` schema encoding, as ros2 bag writes it: M's .msg text,
/// then each type it depends on after "\n", a line of 80 '=' and a line "MSG: pkg/T" (depth first, each once).
/// No comments.
template <Message M>
std::string ros2msg_definition() {
  std::string out;
  std::set<std::string> seen;
  detail::append_msg<M>(out, seen);
  return out;
}

/// The JSON REP-2016 hashes into M::type_hash (see the header comment).
template <Message M>
std::string type_description_json() {
  std::map<std::string_view, std::string> refs;
  std::string out = "{\"type_description\": " + detail::describe<M>(refs) + ", \"referenced_type_descriptions\": [";
  bool first = true;
  for (const auto& [name, desc] : refs) {
    out += first ? "" : ", ";
    first = false;
    out += desc;
  }
  return out + "]}";
}

/// `m`'s values as compact JSON, fields by name: {"header":{"stamp":{"sec":1,"nanosec":0},"frame_id":"base"},...}.
template <Message M>
std::string to_json(const M& m) {
  std::string out;
  detail::json_value(out, m);
  return out;
}

}  // namespace dca::msgs
