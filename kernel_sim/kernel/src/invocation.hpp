// An Invoke frame decoded per object kind, seL4's way (decodeInvocation → decodeCNodeInvocation, … →
// invoke…): the operation's row in cap::kOperations names the kind of object it acts on, and the frame's
// arguments (docs/protocol.md "Invoke") become the typed fields of that kind's invocation. The kernel then
// checks the authority (CapSystem::decode, the same table) and invokes it on the part that owns the kind:
//   any kind (Copy, Mint, Revoke, Delete)  → the capability system (CapSystem::decode_and_invoke)
//   Checkpoint (Create, Rollback, TimerArm) → the image coordinator (rejuvenator.cpp)
//   Network (NetSend, NetReceive)           → the network gate (netgate.cpp)
//   Limits, Persistent                      → the kernel objects' cells (ObjectInfo)
//   Mode (ModeRequest)                      → the mode manager (set_mode)
// Publish and Subscribe have frames of their own: an Invoke of either is a BadArgument.
#pragma once

#include <cstdint>
#include <span>
#include <variant>

#include "rejuv/cap/cap_system.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"

namespace rejuv::kernel {

// Copy, Mint (arg0: destination, arg1: rights mask and badge) and Revoke, Delete (no argument).
struct CapInvocation {
  cap::Operation op = cap::Operation::Revoke;
  cap::Args args{};
};

// The image coordinator's object (the paper's §V create_checkpoint, rollback, do_timer).
struct CheckpointInvocation {
  struct Create {};
  struct Rollback {};
  struct ArmTimer {  // the rejuvenation timer: arg0 = delay [ns] (≤ INT64_MAX), arg1 ≠ 0: periodic
    Nanos delay{0};
    bool periodic = false;
  };
  std::variant<Create, Rollback, ArmTimer> what;
};

// The network gate's object.
struct NetInvocation {
  struct Send {  // the data: one datagram, 1 … kMaxDatagramBytes bytes
    std::span<const std::byte> datagram;
  };
  struct Verdict {  // NetReceive: arg0 = a relayed datagram's id (≠ 0), arg1 = 0 valid, else a refusal reason
    std::uint64_t datagram = 0;
    std::uint64_t reason = 0;
  };
  std::variant<Send, Verdict> what;
};

// The Limits cell (§IV-C: the restricted limits Ū, written by checkpoint_p, read by the output driver).
struct LimitsInvocation {
  struct Write {  // at most kMaxLimitsBytes
    std::span<const std::byte> data;
  };
  struct Read {};
  std::variant<Write, Read> what;
};

// A Persistent cell (§III: survives rollback). Offsets are checked against the cell when invoked.
struct PersistentInvocation {
  struct Read {  // arg0 = offset, arg1 = length (0: to the end)
    std::uint64_t offset = 0;
    std::uint64_t length = 0;
  };
  struct Write {  // arg0 = offset; the data
    std::uint64_t offset = 0;
    std::span<const std::byte> data;
  };
  std::variant<Read, Write> what;
};

// The mode manager's object (Fig. 1 transitions requested by checkpoint_p): arg0 = the mode.
struct ModeInvocation {
  SrMode mode = SrMode::SC;
};

using ObjectInvocation = std::variant<CapInvocation, CheckpointInvocation, NetInvocation, LimitsInvocation,
                                      PersistentInvocation, ModeInvocation>;

inline constexpr std::size_t kMaxLimitsBytes = 4096;

// Why an Invoke's arguments do not decode. `before_authority`: answered without looking at the cap (an
// Invoke of Publish/Subscribe; a Copy/Mint destination, which CapSystem::decode needs to check the
// authority); otherwise a denial of the cap answers first, as seL4 looks the cap up before the arguments.
struct BadInvoke {
  wire::OpError error = wire::OpError::BadArgument;
  bool before_authority = false;
};

// The arguments of `op` (a valid operation) from an Invoke frame. Pure: no state is read or changed.
[[nodiscard]] Result<ObjectInvocation, BadInvoke> decode_invocation(cap::Operation op, const wire::InvokeHeader& head,
                                                                    std::span<const std::byte> data);

}  // namespace rejuv::kernel
