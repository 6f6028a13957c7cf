#include "rejuv/channel/wire.hpp"

#include <algorithm>

namespace rejuv::wire {

namespace {

// The payload size rule of each kind: [min, max] bytes.
struct SizeRule {
  std::size_t min = 0;
  std::size_t max = 0;
};
constexpr SizeRule exactly(std::size_t n) { return {n, n}; }
constexpr SizeRule kEmpty = exactly(0);
constexpr SizeRule kMessage{1, kMaxPayloadBytes};

// nullopt-like: kind unknown.
bool rule_of(FrameKind kind, SizeRule& rule) {
  switch (kind) {
    case FrameKind::Hello:
    case FrameKind::Subscribe:
    case FrameKind::TimerCancel:
    case FrameKind::Idle:
    case FrameKind::Ready:
    case FrameKind::BootEnd:
    case FrameKind::TimerFired:
    case FrameKind::Fork:
    case FrameKind::Committed:
    case FrameKind::Sync:
    case FrameKind::Shutdown: rule = kEmpty; return true;
    case FrameKind::Publish:
    case FrameKind::Deliver: rule = kMessage; return true;
    case FrameKind::Invoke: rule = {sizeof(InvokeHeader), kMaxPayloadBytes}; return true;
    case FrameKind::TimerArm: rule = exactly(sizeof(TimerSpec)); return true;
    case FrameKind::Log: rule = {sizeof(LogHeader), sizeof(LogHeader) + kMaxLogText}; return true;
    case FrameKind::Taken:
    case FrameKind::Copied:
    case FrameKind::Resumed: rule = exactly(sizeof(TakenBody)); return true;
    case FrameKind::Resume: rule = exactly(sizeof(ResumeBody)); return true;
    case FrameKind::Snapshot: rule = exactly(sizeof(SnapshotBody)); return true;
    case FrameKind::TakenPages: rule = exactly(sizeof(TakenPagesBody)); return true;
    case FrameKind::Patch: rule = exactly(sizeof(PatchBody)); return true;
    case FrameKind::NetDatagram: rule = {1, kMaxDatagramBytes}; return true;
    case FrameKind::Boot: rule = exactly(sizeof(BootHeader)); return true;
    case FrameKind::BootCap: rule = exactly(sizeof(BootCap)); return true;
    case FrameKind::BootParam: rule = exactly(sizeof(BootParam)); return true;
    case FrameKind::Reply: rule = {sizeof(ReplyHeader), kMaxPayloadBytes}; return true;
  }
  return false;
}

}  // namespace

std::string_view to_string(FrameKind kind) {
  switch (kind) {
    case FrameKind::Hello: return "Hello";
    case FrameKind::Publish: return "Publish";
    case FrameKind::Subscribe: return "Subscribe";
    case FrameKind::Invoke: return "Invoke";
    case FrameKind::TimerArm: return "TimerArm";
    case FrameKind::TimerCancel: return "TimerCancel";
    case FrameKind::Log: return "Log";
    case FrameKind::Idle: return "Idle";
    case FrameKind::Ready: return "Ready";
    case FrameKind::Taken: return "Taken";
    case FrameKind::Resumed: return "Resumed";
    case FrameKind::Boot: return "Boot";
    case FrameKind::BootCap: return "BootCap";
    case FrameKind::BootParam: return "BootParam";
    case FrameKind::BootEnd: return "BootEnd";
    case FrameKind::Deliver: return "Deliver";
    case FrameKind::Reply: return "Reply";
    case FrameKind::TimerFired: return "TimerFired";
    case FrameKind::Snapshot: return "Snapshot";
    case FrameKind::Shutdown: return "Shutdown";
    case FrameKind::Resume: return "Resume";
    case FrameKind::NetDatagram: return "NetDatagram";
    case FrameKind::Fork: return "Fork";
    case FrameKind::Copied: return "Copied";
    case FrameKind::TakenPages: return "TakenPages";
    case FrameKind::Patch: return "Patch";
    case FrameKind::Committed: return "Committed";
    case FrameKind::Sync: return "Sync";
  }
  return "?";
}

Direction direction_of(FrameKind kind) {
  return static_cast<std::uint16_t>(kind) < 100 ? Direction::ToKernel : Direction::ToService;
}

std::string_view to_string(OpError error) {
  switch (error) {
    case OpError::AlreadySubscribed: return "AlreadySubscribed";
    case OpError::NoSuchTopic: return "NoSuchTopic";
    case OpError::NotSupported: return "NotSupported";
    case OpError::BadArgument: return "BadArgument";
    case OpError::OutOfRange: return "OutOfRange";
    case OpError::Refused: return "Refused";
  }
  return "unknown operation error";
}

std::string_view to_string(FrameError error) {
  switch (error) {
    case FrameError::TooShort: return "frame shorter than its header";
    case FrameError::TooLong: return "frame longer than the maximum";
    case FrameError::LengthMismatch: return "header length disagrees with the frame size";
    case FrameError::UnknownKind: return "unknown frame kind";
    case FrameError::WrongDirection: return "frame kind not allowed in this direction";
    case FrameError::BadFlags: return "reserved flags set";
    case FrameError::BadPayloadSize: return "payload size wrong for the frame kind";
  }
  return "?";
}

Result<FrameView, FrameError> decode(std::span<const std::byte> bytes, Direction expected) {
  if (bytes.size() < sizeof(FrameHeader)) {
    return fail(FrameError::TooShort);
  }
  if (bytes.size() > kMaxFrameBytes) {
    return fail(FrameError::TooLong);
  }
  FrameHeader header;
  std::memcpy(&header, bytes.data(), sizeof(header));
  if (header.length != bytes.size() - sizeof(FrameHeader)) {
    return fail(FrameError::LengthMismatch);
  }
  const auto kind = static_cast<FrameKind>(header.kind);
  SizeRule rule;
  if (!rule_of(kind, rule)) {
    return fail(FrameError::UnknownKind);
  }
  if (direction_of(kind) != expected) {
    return fail(FrameError::WrongDirection);
  }
  if (header.flags != 0) {
    return fail(FrameError::BadFlags);
  }
  if (header.length < rule.min || header.length > rule.max) {
    return fail(FrameError::BadPayloadSize);
  }
  return FrameView{kind, header, bytes.subspan(sizeof(FrameHeader))};
}

std::span<const std::byte> next_frame(std::span<const std::byte> datagram, std::size_t& offset) {
  const std::span<const std::byte> rest = datagram.subspan(std::min(offset, datagram.size()));
  std::size_t size = rest.size();
  if (rest.size() >= sizeof(FrameHeader)) {
    FrameHeader header;
    std::memcpy(&header, rest.data(), sizeof(header));
    const std::size_t whole = sizeof(FrameHeader) + std::size_t{header.length};
    if (whole <= rest.size()) size = whole;
  }
  offset = std::min(datagram.size(), datagram.size() - rest.size() + aligned_frame_size(size));
  return rest.first(size);
}

std::size_t datagram_prefix(std::span<const std::byte> frames) {
  std::size_t end = 0;
  for (std::size_t offset = 0; offset < frames.size();) {
    const std::span<const std::byte> frame = next_frame(frames, offset);
    const auto frame_end = static_cast<std::size_t>(frame.data() + frame.size() - frames.data());
    if (end > 0 && frame_end > kMaxFrameBytes) break;
    end = frame_end;
  }
  return end;
}

bool FrameBuffer::build(FrameKind kind, std::uint32_t slot, std::uint32_t seq, std::uint64_t aux,
                        std::span<const std::byte> payload, std::span<const std::byte> more) {
  size_ = 0;
  const std::size_t length = payload.size() + more.size();
  if (length > kMaxPayloadBytes) {
    return false;
  }
  const FrameHeader header{.kind = static_cast<std::uint16_t>(kind),
                           .flags = 0,
                           .slot = slot,
                           .seq = seq,
                           .length = static_cast<std::uint32_t>(length),
                           .aux = aux};
  std::memcpy(bytes_.data(), &header, sizeof(header));
  if (!payload.empty()) std::memcpy(bytes_.data() + sizeof(header), payload.data(), payload.size());
  if (!more.empty()) std::memcpy(bytes_.data() + sizeof(header) + payload.size(), more.data(), more.size());
  size_ = sizeof(header) + length;
  return true;
}

}  // namespace rejuv::wire
