#include "host/codec/msgs.h"

#include <dca/msgs.h>
#include <dca/msgs_cdr.h>
#include <dca/msgs_describe.h>

#include <array>
#include <memory>
#include <type_traits>
#include <vector>

#include "host/codec/msgpack_number.h"

namespace dca::msgs {

namespace {

template <class T>
std::string schema_of() {
  if constexpr (std::is_floating_point_v<T>) {
    return R"({"type":"number"})";
  } else if constexpr (detail::Primitive<T>) {
    return R"({"type":"integer"})";
  } else if constexpr (detail::IsString<T>::value) {
    return R"({"type":"string","maxLength":)" + std::to_string(T::capacity) + "}";
  } else if constexpr (detail::IsArray<T>::value) {
    const std::string n = std::to_string(std::tuple_size_v<T>);
    return R"({"type":"array","items":)" + schema_of<typename T::value_type>() + ",\"minItems\":" + n +
           ",\"maxItems\":" + n + "}";
  } else if constexpr (detail::IsSeq<T>::value) {
    return R"({"type":"array","items":)" + schema_of<typename T::value_type>() +
           ",\"maxItems\":" + std::to_string(T::capacity) + "}";
  } else {
    std::string s = R"({"type":"object","title":")" + std::string(T::ros_name) + R"(","properties":{)";
    bool first = true;
    const auto m = std::make_unique<T>();
    T::fields(*m, [&](std::string_view name, const auto& f) {
      s += first ? "\"" : ",\"";
      first = false;
      s += std::string(name) + "\":" + schema_of<std::remove_cvref_t<decltype(f)>>();
    });
    return s + "}}";
  }
}

template <class T>
void pack_field(msgpack::packer<msgpack::sbuffer>& pk, const T& v) {
  if constexpr (std::is_floating_point_v<T>) {
    wire::pack_real(pk, v);  // (not pk.pack: a whole value from 2^63 up would become an integer dca cannot read)
  } else if constexpr (detail::Primitive<T>) {
    pk.pack(v);
  } else if constexpr (detail::IsString<T>::value) {
    pk.pack_str(static_cast<std::uint32_t>(v.size()));
    pk.pack_str_body(v.c_str(), static_cast<std::uint32_t>(v.size()));
  } else if constexpr (detail::IsArray<T>::value || detail::IsSeq<T>::value) {
    pk.pack_array(static_cast<std::uint32_t>(v.end() - v.begin()));
    for (const auto& e : v) pack_field(pk, e);
  } else {
    std::uint32_t n = 0;
    T::fields(v, [&n](std::string_view, const auto&) { ++n; });
    pk.pack_map(n);
    T::fields(v, [&pk](std::string_view name, const auto& f) {
      pk.pack_str(static_cast<std::uint32_t>(name.size()));
      pk.pack_str_body(name.data(), static_cast<std::uint32_t>(name.size()));
      pack_field(pk, f);
    });
  }
}

template <class M>
TypeInfo info() {
  return {M::ros_name,
          M::dds_name,
          M::type_hash,
          cdr_max_size<M>,
          [](std::span<const std::byte> cdr) {
            M m;
            const CdrResult r = cdr_decode(cdr, m);
            return r && cdr.size() - r.offset < 4;  // at most DDS's padding after it
          },
          [](std::span<const std::byte> cdr) -> std::string {
            const auto m = std::make_unique<M>();
            return cdr_decode(cdr, *m) ? to_json(*m) : "null";
          },
          [] { return schema_of<M>(); },
          [] { return ros2msg_definition<M>(); },
          [](std::span<const std::byte> cdr, msgpack::packer<msgpack::sbuffer>& pk) {
            const auto m = std::make_unique<M>();
            if (cdr_decode(cdr, *m)) pack_field(pk, *m);
            else pk.pack_nil();
          },
          []() -> std::span<const std::byte> {
            static const std::vector<std::byte> z = [] {
              std::vector<std::byte> b(cdr_max_size<M>);
              b.resize(cdr_encode(*std::make_unique<M>(), b));
              return b;
            }();
            return z;
          }};
}

constexpr std::size_t kTypes = [] {
  std::size_t n = 0;
  for_each_message_type([&n]<class M>() { ++n; });
  return n;
}();

std::array<TypeInfo, kTypes> make_table() {
  std::array<TypeInfo, kTypes> t{};
  std::size_t i = 0;
  for_each_message_type([&]<class M>() { t[i++] = info<M>(); });
  return t;
}

}  // namespace

std::span<const TypeInfo> types() {
  static const std::array<TypeInfo, kTypes> table = make_table();
  return table;
}

const TypeInfo* find_type(std::string_view ros_name) {
  for (const auto& t : types())
    if (t.ros_name == ros_name) return &t;
  return nullptr;
}

}  // namespace dca::msgs
