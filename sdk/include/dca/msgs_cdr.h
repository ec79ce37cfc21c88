#pragma once
// CDR of dca::msgs (docs/data-plane.md, "Typed messages"): XCDR1 ("plain CDR"), what ROS 2 puts in a DDS sample
// and in a ros2 bag. A message is the 4-byte encapsulation header (00 01 00 00: CDR, little endian) and its
// fields in order; each primitive aligned to its size counted from after the header; a string is a uint32
// length (with the NUL), the bytes and a NUL; a sequence a uint32 count and the elements; a fixed array its
// elements only.
//
//   std::array<std::byte, cdr_max_size<JointState>> buf;      // enough for any JointState
//   std::size_t n = cdr_encode(js, buf);                       // the bytes written: buf[0..n)
//   CdrResult r = cdr_decode(std::span(buf).first(n), js2);    // r.error, r.offset when it failed
//
// Encoding writes little endian; decoding reads both little and big endian (00 00 00 00) and refuses every other
// representation. The decoder never reads past its input; it refuses a string without its NUL or holding a NUL,
// and a string or sequence longer than its capacity in dca (TooLong: never truncated). Bytes after the message
// are allowed (DDS pads a sample to 4 bytes). Neither allocates.
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string_view>

#include "dca/msgs.h"

namespace dca::msgs {

inline constexpr std::size_t kCdrHeaderSize = 4;

/// Why cdr_decode refused its input.
enum class CdrError : std::uint8_t {
  None,           ///< decoded
  Short,          ///< the input ends inside the message
  Encapsulation,  ///< not 00 01 (CDR little endian) or 00 00 (CDR big endian)
  BadString,      ///< a string's last byte is not NUL, or it holds a NUL
  TooLong,        ///< a string or sequence longer than its capacity in dca
};

inline std::string_view to_string(CdrError e) {
  switch (e) {
    case CdrError::None: return "none";
    case CdrError::Short: return "input ends inside the message";
    case CdrError::Encapsulation: return "not a CDR encapsulation (00 00 or 00 01)";
    case CdrError::BadString: return "a string without its NUL, or with a NUL inside";
    case CdrError::TooLong: return "a string or sequence longer than its capacity";
  }
  return "?";
}

/// What cdr_decode found: the error and the input's byte offset where it was found.
struct CdrResult {
  CdrError error = CdrError::None;
  std::size_t offset = 0;
  explicit operator bool() const { return error == CdrError::None; }
};

namespace detail {

/// The most bytes a field of type T takes, alignment included.
template <class T>
constexpr std::size_t cdr_max_field() {
  if constexpr (Primitive<T>) {
    return 2 * sizeof(T) - 1;
  } else if constexpr (IsString<T>::value) {
    return 3 + 4 + T::capacity + 1;
  } else if constexpr (IsArray<T>::value) {
    return std::tuple_size_v<T> * cdr_max_field<typename T::value_type>();
  } else if constexpr (IsSeq<T>::value) {
    return 3 + 4 + T::capacity * cdr_max_field<typename T::value_type>();
  } else {
    static_assert(Message<T>, "not a message field");
    std::size_t n = 0;
    const T m{};
    T::fields(m, [&n](std::string_view, const auto& f) { n += cdr_max_field<std::remove_cvref_t<decltype(f)>>(); });
    return n;
  }
}

/// Writes fields (or counts their bytes when out is empty).
class CdrWriter {
 public:
  explicit CdrWriter(std::span<std::byte> out) : out_(out) {}
  std::size_t size() const { return pos_; }
  bool fits() const { return pos_ <= out_.size(); }
  void header() {
    const std::byte h[4] = {std::byte{0}, std::byte{1}, std::byte{0}, std::byte{0}};
    put(h, 4);
  }
  template <class T>
  void operator()(std::string_view, const T& v) { field(v); }

 private:
  void put(const void* p, std::size_t n) {
    if (pos_ + n <= out_.size()) std::memcpy(out_.data() + pos_, p, n);
    pos_ += n;
  }
  void align(std::size_t a) {
    static constexpr std::byte zeros[8] = {};
    put(zeros, (a - (pos_ - kCdrHeaderSize) % a) % a);
  }
  template <class T>
  void field(const T& v) {
    if constexpr (Primitive<T>) {
      align(sizeof(T));
      std::byte b[sizeof(T)];
      std::memcpy(b, &v, sizeof(T));
      if constexpr (std::endian::native == std::endian::big)
        for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
      put(b, sizeof(T));
    } else if constexpr (IsString<T>::value) {
      field(static_cast<std::uint32_t>(v.size() + 1));
      put(v.c_str(), v.size() + 1);
    } else if constexpr (IsArray<T>::value) {
      for (const auto& e : v) field(e);
    } else if constexpr (IsSeq<T>::value) {
      field(static_cast<std::uint32_t>(v.size()));
      for (const auto& e : v) field(e);
    } else {
      T::fields(v, *this);
    }
  }
  std::span<std::byte> out_;
  std::size_t pos_ = 0;
};

/// Reads fields; stops at the first error.
class CdrReader {
 public:
  CdrReader(std::span<const std::byte> in, bool big_endian) : in_(in), pos_(kCdrHeaderSize), swap_(big_endian) {
    if constexpr (std::endian::native == std::endian::big) swap_ = !swap_;
  }
  CdrResult result() const { return {error_, error_ == CdrError::None ? pos_ : at_}; }
  template <class T>
  void operator()(std::string_view, T& v) { field(v); }

 private:
  void fail(CdrError e) {
    if (error_ == CdrError::None) error_ = e, at_ = pos_;
  }
  bool take(void* p, std::size_t n) {
    if (n > in_.size() - pos_) return fail(CdrError::Short), false;
    std::memcpy(p, in_.data() + pos_, n);
    pos_ += n;
    return true;
  }
  template <class T>
  void field(T& v) {
    if (error_ != CdrError::None) return;
    if constexpr (Primitive<T>) {
      const std::size_t pad = (sizeof(T) - (pos_ - kCdrHeaderSize) % sizeof(T)) % sizeof(T);
      if (pad > in_.size() - pos_) return fail(CdrError::Short);
      pos_ += pad;
      std::byte b[sizeof(T)];
      if (!take(b, sizeof(T))) return;
      if (swap_)
        for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
      std::memcpy(&v, b, sizeof(T));
    } else if constexpr (IsString<T>::value) {
      string(v);
    } else if constexpr (IsArray<T>::value) {
      for (auto& e : v) field(e);
    } else if constexpr (IsSeq<T>::value) {
      std::uint32_t n = 0;
      field(n);
      if (error_ != CdrError::None) return;
      if (!v.resize(n)) return pos_ -= 4, fail(CdrError::TooLong);
      for (auto& e : v) field(e);
    } else {
      T::fields(v, *this);
    }
  }
  template <class S>
  void string(S& v) {
    std::uint32_t n = 0;
    field(n);
    if (error_ != CdrError::None) return;
    if (n == 0) return void(v.assign({}));  // an empty string some writers send without its NUL
    if (n - 1 > S::capacity) return pos_ -= 4, fail(CdrError::TooLong);
    if (n > in_.size() - pos_) return fail(CdrError::Short);
    const std::string_view s(reinterpret_cast<const char*>(in_.data() + pos_), n - 1);
    if (in_[pos_ + n - 1] != std::byte{0} || !v.assign(s)) return fail(CdrError::BadString);
    pos_ += n;
  }
  std::span<const std::byte> in_;
  std::size_t pos_;
  bool swap_;
  CdrError error_ = CdrError::None;
  std::size_t at_ = 0;
};

}  // namespace detail

/// The most bytes cdr_encode writes for any M (header included): a buffer this large always suffices.
template <Message M>
inline constexpr std::size_t cdr_max_size = kCdrHeaderSize + detail::cdr_max_field<M>();

/// The bytes cdr_encode writes for `m`, header included.
template <Message M>
std::size_t cdr_size(const M& m) {
  detail::CdrWriter w({});
  w.header();
  M::fields(m, w);
  return w.size();
}

/// Writes `m` as XCDR1 little endian into `out`: the bytes written, or 0 (and `out` unspecified) when `out` is
/// too small.
template <Message M>
std::size_t cdr_encode(const M& m, std::span<std::byte> out) {
  detail::CdrWriter w(out);
  w.header();
  M::fields(m, w);
  return w.fits() ? w.size() : 0;
}

/// Reads `in` into `m`. On an error `m` holds what was decoded before it; the result names the error and the
/// byte offset in `in` where it was found.
template <Message M>
CdrResult cdr_decode(std::span<const std::byte> in, M& m) {
  if (in.size() < kCdrHeaderSize) return {CdrError::Short, in.size()};
  if (in[0] != std::byte{0} || (in[1] != std::byte{0} && in[1] != std::byte{1})) return {CdrError::Encapsulation, 0};
  detail::CdrReader r(in, in[1] == std::byte{0});
  M::fields(m, r);
  return r.result();
}

}  // namespace dca::msgs
