// The boot script (docs/design.md §3; docs/protocol.md "Boot"): what the kernel tells a service after its Hello —
// Boot{BootHeader}, BootCap × cap_count (every cap the service may ever hold, with its rights per mode),
// BootParam × param_count, BootEnd. Its one encoder (the kernel's supervisor) and its one decoder (the SDK's
// connect), so that the two ends cannot drift (docs/conventions.md "One protocol, one codec").
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/channel/codes.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/core/graph_values.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/vocabulary.hpp"

namespace rejuv::channel {

// Who the service is: the BootHeader less the counts, which the script sets from what follows it.
struct BootIdentity {
  ServiceId service{};
  Epoch epoch{};
  std::string_view name{};  // truncated to the header's 47 bytes on the wire
};

// One cap of the script (a BootCap). Decoded, the views point into the wire::BootCap it came from.
struct BootCapEntry {
  Slot slot{};
  ObjectKind kind = ObjectKind::Topic;       // a kind this SDK does not know reads as Topic
  std::array<Rights, kModeCount> rights{};   // by index_of(mode)
  std::uint32_t payload_size = 0;            // Topic: the message size; Persistent: the cell size [bytes]
  std::string_view object{};                 // policy object name
  std::string_view type{};                   // Topic: IDL type name
};

// One launch parameter of the service (a BootParam): a number, a text or an integer (a graph-wide duration in
// ns, a switch or a count: rejuv/core/graph_values.hpp). Decoded, the views point into the wire::BootParam it
// came from.
struct BootParamEntry {
  std::string_view name{};
  double number = 0;
  std::string_view text{};
  bool is_text = false;
  std::int64_t integer = 0;
  bool is_integer = false;
};

// ---- encoding (the kernel) ----

[[nodiscard]] wire::BootCap encode_boot_cap(const BootCapEntry& cap);
[[nodiscard]] wire::BootParam encode_boot_param(const BootParamEntry& param);
// A graph-wide value (rejuv/core/graph_values.hpp) as the param `name`: an integer or a number. The entry views
// `name`.
[[nodiscard]] BootParamEntry boot_param_of(std::string_view name, const graph_values::Value& value);

// The whole script, frame by frame: each is built in `tx` and handed to `emit(std::span<const std::byte>)`
// in order. Boot's counts are the spans' sizes; aux = wire::kProtocolVersion.
template <class Emit>
void write_boot_script(wire::FrameBuffer& tx, const BootIdentity& who, std::span<const wire::BootCap> caps,
                       std::span<const wire::BootParam> params, Emit&& emit) {
  wire::BootHeader head{};
  head.service_id = who.service.value();
  head.epoch = who.epoch.value();
  head.cap_count = static_cast<std::uint32_t>(caps.size());
  head.param_count = static_cast<std::uint32_t>(params.size());
  head.generation = 0;
  (void)wire::copy_name(head.name, who.name);
  if (tx.build_with(wire::FrameKind::Boot, 0, 0, wire::kProtocolVersion, head)) emit(tx.bytes());
  for (const wire::BootCap& c : caps) {
    if (tx.build_with(wire::FrameKind::BootCap, 0, 0, 0, c)) emit(tx.bytes());
  }
  for (const wire::BootParam& p : params) {
    if (tx.build_with(wire::FrameKind::BootParam, 0, 0, 0, p)) emit(tx.bytes());
  }
  if (tx.build(wire::FrameKind::BootEnd, 0, 0, 0)) emit(tx.bytes());
}

// ---- decoding (the SDK) ----

enum class BootError : std::uint8_t {
  UnexpectedFrame,  // a frame of another kind than the script has next
  VersionMismatch,  // Boot's aux names another protocol version
  SlotOutOfRange,   // a BootCap slot at or past wire::kCSpaceSlots
};
// A refused script: what went wrong, the kind expected and the kind (or version, or slot) found.
struct BootFailure {
  BootError error = BootError::UnexpectedFrame;
  wire::FrameKind expected = wire::FrameKind::Boot;
  std::uint64_t found = 0;  // UnexpectedFrame: the FrameKind; VersionMismatch: the version; SlotOutOfRange: the slot
};
[[nodiscard]] std::string to_string(const BootFailure& failure);

// The script as it arrives, one decoded frame at a time. Every frame is checked against the script's order
// and ranges as it comes, and the service builds nothing from it before BootEnd (decode-then-invoke). The
// kernel is trusted, but a slot out of the CSpace would size a service's tables: it is refused here
// (found by tests/fuzz sdk_frames).
class BootDecoder {
 public:
  // Takes the script's next frame; true once BootEnd has completed it.
  [[nodiscard]] Result<bool, BootFailure> take(const wire::FrameView& frame);

  [[nodiscard]] BootIdentity identity() const;  // views into the decoder
  [[nodiscard]] std::size_t cap_count() const { return caps_.size(); }
  [[nodiscard]] BootCapEntry cap(std::size_t i) const;      // views into the decoder
  [[nodiscard]] std::size_t param_count() const { return params_.size(); }
  [[nodiscard]] BootParamEntry param(std::size_t i) const;  // views into the decoder

 private:
  enum class Stage : std::uint8_t { Boot, Caps, Params, End, Done };
  [[nodiscard]] Stage after_caps() const;
  Stage stage_ = Stage::Boot;
  wire::BootHeader header_{};
  std::vector<wire::BootCap> caps_;
  std::vector<wire::BootParam> params_;
};

// A BootCap or BootParam as its entry (views into the argument).
[[nodiscard]] BootCapEntry decode_boot_cap(const wire::BootCap& cap);
[[nodiscard]] BootParamEntry decode_boot_param(const wire::BootParam& param);
// The value of a number or integer param; nullopt for a text.
[[nodiscard]] std::optional<graph_values::Value> value_of(const BootParamEntry& param);

}  // namespace rejuv::channel
