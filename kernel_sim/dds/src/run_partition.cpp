#include "rejuv/dds/run_partition.hpp"

#include <charconv>
#include <random>
#include <string>

namespace rejuv::dds {

namespace {
constexpr std::size_t kHexDigits = 16;
}  // namespace

RunId random_run_id() {
  std::random_device source;  // libstdc++: getrandom(2), or the CPU's RDRAND where it has one
  std::uint64_t bits = 0;
  for (int half = 0; half < 2; ++half) bits = (bits << 32U) | static_cast<std::uint32_t>(source());
  return RunId{bits};
}

std::string to_string(RunId id) {
  std::string out(kHexDigits, '0');
  std::uint64_t v = id.value();
  for (std::size_t i = kHexDigits; i-- > 0; v >>= 4U) out[i] = "0123456789abcdef"[v & 0xFU];
  return out;
}

std::optional<RunId> parse_run_id(std::string_view text) {
  if (text.size() != kHexDigits) return std::nullopt;
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v, 16);
  if (ec != std::errc{} || end != text.data() + text.size()) return std::nullopt;
  return RunId{v};
}

Result<RunId, std::string> parse_run_id(std::string_view flag, std::string_view text) {
  if (auto id = parse_run_id(text)) return *id;
  return fail(std::string(flag) + ": expected " + std::to_string(kHexDigits) + " hex digits, got '" +
              std::string(text) + "'");
}

std::string run_partition(RunId id) {
  return "rejuv." + to_string(id);
}

}  // namespace rejuv::dds
