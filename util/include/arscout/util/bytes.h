// Little-endian bytes: the one writer and reader under every hand-written
// binary format (the engine state, the depth maps; docs/ARCHITECTURE.md).
// Numbers are written least significant byte first whatever the host, so
// stored bytes read back on any machine; a format's own pieces (strings,
// vectors, matrices, images) are thin helpers in its file, made of put(),
// append(), get() and take(). Standard C++ only.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>

namespace arscout::util {

// The arithmetic types put() and get() take: 1, 2, 4 or 8 bytes (not long
// double, whose size and layout differ between hosts).
template <typename T>
concept ByteNumber = std::is_arithmetic_v<T> &&
    (sizeof(T) == 1 || sizeof(T) == 2 || sizeof(T) == 4 || sizeof(T) == 8);

namespace bytes_detail {

template <size_t N>
struct UnsignedOf;
template <>
struct UnsignedOf<1> {
  using type = uint8_t;
};
template <>
struct UnsignedOf<2> {
  using type = uint16_t;
};
template <>
struct UnsignedOf<4> {
  using type = uint32_t;
};
template <>
struct UnsignedOf<8> {
  using type = uint64_t;
};
// The unsigned integer with T's bits: numbers are (de)coded through it.
template <typename T>
using Unsigned = typename UnsignedOf<sizeof(T)>::type;

inline constexpr bool kLittleEndianHost =
    std::endian::native == std::endian::little;

}  // namespace bytes_detail

// Appends to a growing byte string. Never throws except std::bad_alloc
// (and std::out_of_range from put_at).
class ByteWriter {
 public:
  // `value`'s bytes, little-endian (IEEE 754 bits for floating point).
  template <ByteNumber T>
  void put(T value) {
    const auto bits = std::bit_cast<bytes_detail::Unsigned<T>>(value);
    if constexpr (bytes_detail::kLittleEndianHost) {
      out_.append(reinterpret_cast<const char*>(&bits), sizeof(bits));
    } else {
      for (size_t i = 0; i < sizeof(T); ++i)
        out_.push_back(static_cast<char>((bits >> (8 * i)) & 0xff));
    }
  }
  // Overwrites sizeof(T) bytes written before, at `offset`, with `value`
  // as put() writes it: a field whose value is known only at the end (a
  // total size). Throws std::out_of_range when they were not all written.
  template <ByteNumber T>
  void put_at(size_t offset, T value) {
    if (offset > out_.size() || out_.size() - offset < sizeof(T))
      throw_out_of_range(offset, sizeof(T));
    const auto bits = std::bit_cast<bytes_detail::Unsigned<T>>(value);
    for (size_t i = 0; i < sizeof(T); ++i)
      out_[offset + i] = static_cast<char>((bits >> (8 * i)) & 0xff);
  }
  // Raw bytes as they are: magic numbers, text, and bulk arrays a format
  // has already laid out little-endian.
  void append(std::string_view raw) { out_.append(raw); }
  void append(const void* data, size_t size) {
    out_.append(static_cast<const char*>(data), size);
  }

  void reserve(size_t size) { out_.reserve(size); }
  size_t size() const { return out_.size(); }
  const std::string& bytes() const { return out_; }
  // The bytes written; the writer is empty afterwards.
  std::string take();

 private:
  [[noreturn]] void throw_out_of_range(size_t offset, size_t size) const;

  std::string out_;
};

// Reads a byte string front to back. It views `in` without a copy: the
// bytes must outlive the reader. Every failure, its own (too few bytes
// left: "truncated") or a caller's (fail()), throws std::runtime_error
// whose message is the caller-given prefix followed by what is wrong, so
// all the errors of one format read alike.
class ByteReader {
 public:
  ByteReader(std::string_view in, std::string failure_prefix);

  // The next sizeof(T) bytes as put() wrote them.
  template <ByteNumber T>
  T get() {
    const std::string_view raw = take(sizeof(T));
    bytes_detail::Unsigned<T> bits = 0;
    if constexpr (bytes_detail::kLittleEndianHost) {
      std::memcpy(&bits, raw.data(), sizeof(T));
    } else {
      for (size_t i = 0; i < sizeof(T); ++i)
        bits |= static_cast<bytes_detail::Unsigned<T>>(
                    static_cast<unsigned char>(raw[i]))
                << (8 * i);
    }
    return std::bit_cast<T>(bits);
  }
  // The next `n` bytes, viewed in the input.
  std::string_view take(size_t n);

  size_t left() const { return in_.size() - pos_; }
  bool done() const { return pos_ == in_.size(); }
  size_t size() const { return in_.size(); }  // of the whole input

  // Throws std::runtime_error(prefix + what).
  [[noreturn]] void fail(std::string_view what) const;

 private:
  std::string_view in_;
  size_t pos_ = 0;
  std::string prefix_;
};

}  // namespace arscout::util
