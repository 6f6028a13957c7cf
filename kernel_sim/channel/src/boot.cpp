#include "rejuv/channel/boot.hpp"

namespace rejuv::channel {

wire::BootCap encode_boot_cap(const BootCapEntry& cap) {
  wire::BootCap out{};
  out.slot = cap.slot.value();
  out.kind = static_cast<std::uint8_t>(cap.kind);
  for (std::size_t m = 0; m < kModeCount; ++m) out.rights_by_mode[m] = rights_bits(cap.rights[m]);
  out.payload_size = cap.payload_size;
  (void)wire::copy_name(out.object, cap.object);
  (void)wire::copy_name(out.type, cap.type);
  return out;
}

wire::BootParam encode_boot_param(const BootParamEntry& param) {
  wire::BootParam out{};
  (void)wire::copy_name(out.name, param.name);
  if (param.is_text) {
    (void)wire::copy_name(out.text, param.text);
    out.is_text = 1;
  } else if (param.is_integer) {
    out.integer = param.integer;
    out.is_integer = 1;
  } else {
    out.number = param.number;
  }
  return out;
}

BootParamEntry boot_param_of(std::string_view name, const graph_values::Value& value) {
  const auto* integer = std::get_if<std::int64_t>(&value);
  return BootParamEntry{.name = name,
                        .number = integer != nullptr ? 0.0 : std::get<double>(value),
                        .text = {},
                        .is_text = false,
                        .integer = integer != nullptr ? *integer : 0,
                        .is_integer = integer != nullptr};
}

std::optional<graph_values::Value> value_of(const BootParamEntry& param) {
  if (param.is_text) return std::nullopt;
  if (param.is_integer) return graph_values::Value{param.integer};
  return graph_values::Value{param.number};
}

BootCapEntry decode_boot_cap(const wire::BootCap& cap) {
  BootCapEntry out;
  out.slot = Slot(cap.slot);
  out.kind = cap.kind < kAllObjectKinds.size() ? static_cast<ObjectKind>(cap.kind) : ObjectKind::Topic;
  for (std::size_t m = 0; m < kModeCount; ++m) out.rights[m] = rights_from_bits(cap.rights_by_mode[m]);
  out.payload_size = cap.payload_size;
  out.object = wire::read_name(cap.object);
  out.type = wire::read_name(cap.type);
  return out;
}

BootParamEntry decode_boot_param(const wire::BootParam& param) {
  return BootParamEntry{.name = wire::read_name(param.name),
                        .number = param.number,
                        .text = wire::read_name(param.text),
                        .is_text = param.is_text != 0,
                        .integer = param.integer,
                        .is_integer = param.is_text == 0 && param.is_integer != 0};
}

std::string to_string(const BootFailure& failure) {
  switch (failure.error) {
    case BootError::UnexpectedFrame: {
      std::string out = "expected " + std::string(wire::to_string(failure.expected));
      if (failure.expected == wire::FrameKind::Boot) {
        out += ", got " + std::string(wire::to_string(static_cast<wire::FrameKind>(failure.found)));
      }
      return out;
    }
    case BootError::VersionMismatch: return "kernel speaks version " + std::to_string(failure.found);
    case BootError::SlotOutOfRange: return "BootCap slot " + std::to_string(failure.found) + " out of range";
  }
  return "?";
}

BootDecoder::Stage BootDecoder::after_caps() const {
  return params_.size() < header_.param_count ? Stage::Params : Stage::End;
}

Result<bool, BootFailure> BootDecoder::take(const wire::FrameView& frame) {
  const auto unexpected = [&](wire::FrameKind expected) {
    return fail(BootFailure{.error = BootError::UnexpectedFrame, .expected = expected,
                            .found = static_cast<std::uint64_t>(frame.kind)});
  };
  switch (stage_) {
    case Stage::Boot:
      if (frame.kind != wire::FrameKind::Boot) return unexpected(wire::FrameKind::Boot);
      if (frame.header.aux != wire::kProtocolVersion && frame.header.aux != 0) {
        return fail(BootFailure{.error = BootError::VersionMismatch, .expected = wire::FrameKind::Boot,
                                .found = frame.header.aux});
      }
      header_ = wire::payload_as<wire::BootHeader>(frame);
      stage_ = header_.cap_count > 0 ? Stage::Caps : after_caps();
      return false;
    case Stage::Caps: {
      if (frame.kind != wire::FrameKind::BootCap) return unexpected(wire::FrameKind::BootCap);
      const auto cap = wire::payload_as<wire::BootCap>(frame);
      if (cap.slot >= wire::kCSpaceSlots) {
        return fail(BootFailure{.error = BootError::SlotOutOfRange, .expected = wire::FrameKind::BootCap,
                                .found = cap.slot});
      }
      caps_.push_back(cap);
      if (caps_.size() == header_.cap_count) stage_ = after_caps();
      return false;
    }
    case Stage::Params:
      if (frame.kind != wire::FrameKind::BootParam) return unexpected(wire::FrameKind::BootParam);
      params_.push_back(wire::payload_as<wire::BootParam>(frame));
      stage_ = after_caps();
      return false;
    case Stage::End:
      if (frame.kind != wire::FrameKind::BootEnd) return unexpected(wire::FrameKind::BootEnd);
      stage_ = Stage::Done;
      return true;
    case Stage::Done: return true;
  }
  return false;
}

BootIdentity BootDecoder::identity() const {
  return BootIdentity{.service = ServiceId(header_.service_id), .epoch = Epoch(header_.epoch),
                      .name = wire::read_name(header_.name)};
}

BootCapEntry BootDecoder::cap(std::size_t i) const { return decode_boot_cap(caps_.at(i)); }
BootParamEntry BootDecoder::param(std::size_t i) const { return decode_boot_param(params_.at(i)); }

}  // namespace rejuv::channel
