#pragma once
// Descriptions of dca::msgs (docs/data-plane.md, "Typed messages"), built on demand (they allocate: not for the
// hot path):
//   type_description_json<M>()  the JSON that ROS 2 hashes into M::type_hash (REP-2016, RIHS01): M's type
//       description and those of the types it references, sorted by name, without default values, in the
//       layout of Python's json.dumps(separators=(', ', ': ')); sha256 of it is the hash's hex
//   to_json(m)                  a message's values as JSON, fields by name (strings escaped, doubles round-trip)
#include <cstdint>
#include <cstdio>
#include <map>
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

inline void json_string(std::string& out, std::string_view s) {
  out += '"';
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char u[8];
      std::snprintf(u, sizeof u, "\\u%04x", static_cast<unsigned>(c));
      out += u;
    } else {
      out += c;
    }
  }
  out += '"';
}

template <class T>
void json_value(std::string& out, const T& v) {
  if constexpr (std::is_floating_point_v<T>) {
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

}  // namespace detail

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
