// Helpers shared by the fuzz targets (tests/fuzz): a reader that splits a fuzzer's byte string into
// length-prefixed records, so that one input drives a sequence of operations.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

namespace rejuv::fuzz {

class Input {
 public:
  Input(const std::uint8_t* data, std::size_t size) : bytes_(reinterpret_cast<const std::byte*>(data), size) {}
  [[nodiscard]] bool empty() const { return bytes_.empty(); }
  [[nodiscard]] std::uint8_t u8() {
    if (bytes_.empty()) return 0;
    const auto v = static_cast<std::uint8_t>(bytes_.front());
    bytes_ = bytes_.subspan(1);
    return v;
  }
  [[nodiscard]] std::uint16_t u16() {
    const std::uint16_t lo = u8();
    return static_cast<std::uint16_t>(lo | (static_cast<std::uint16_t>(u8()) << 8U));
  }
  // Up to `n` bytes (fewer at the end of the input).
  [[nodiscard]] std::span<const std::byte> take(std::size_t n) {
    const std::size_t k = std::min(n, bytes_.size());
    const auto out = bytes_.first(k);
    bytes_ = bytes_.subspan(k);
    return out;
  }
  // A record: u16 length (little-endian), then that many bytes.
  [[nodiscard]] std::span<const std::byte> record() { return take(u16()); }
  // A trivially copyable value as a DDS reader's take_as hands it over: sizeof(T) bytes, zero-filled at the end.
  template <class T>
  [[nodiscard]] T value() {
    T v{};
    const auto b = take(sizeof(T));
    std::memcpy(&v, b.data(), b.size());
    return v;
  }

 private:
  std::span<const std::byte> bytes_;
};

}  // namespace rejuv::fuzz
