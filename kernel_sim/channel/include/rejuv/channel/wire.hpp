// The kernel ↔ service wire protocol (docs/design.md §2, §3, §6, §7): the kernel's ABI. A frame = a fixed 24-byte
// header + a payload whose size the header states exactly; a SOCK_SEQPACKET datagram carries one frame or
// several back to back (next_frame, below).
// The kernel never parses attacker-controlled bytes beyond this fixed framing: decode() checks the
// header, the kind, the direction and the payload size rule of the kind before anything looks inside.
#pragma once

#include <fcntl.h>

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string_view>
#include <type_traits>

#include "rejuv/core/result.hpp"

namespace rejuv::wire {

inline constexpr int kChannelFd = 3;     // a service's channel to the kernel is always fd 3
inline constexpr int kTimePageFd = 4;    // the kernel's read-only time page (memfd) is always fd 4
// The link between hosts (rejuv_host_link) only: its host's DDS Security private key, opened by the kernel
// (the key file is readable by its owner only, never by a service uid) and read once at boot.
inline constexpr int kHostLinkKeyFd = 5;
// The environment variable by which a kernel without root asks a service to stay dumpable ("1"): its
// pagemap, which images by written pages need, is out of that kernel's reach otherwise (sdk boot.cpp).
inline constexpr const char* kKeepDumpableEnv = "REJUV_KEEP_DUMPABLE";
inline constexpr std::size_t kMaxFrameBytes = 8192;
inline constexpr std::uint16_t kProtocolVersion = 2;  // 2: BootParam carries an integer form
// Slots of a service's CSpace (the kernel's CapSystemConfig::cspace_slots): a slot on the wire is below it.
inline constexpr std::size_t kCSpaceSlots = 256;

// Subscribe{aux}: a polled subscription (PX4's uORB::Subscription, not SubscriptionCallback). Its
// deliveries never wake the service: the kernel keeps them in the ring and hands them over just before the
// next frame that does (a timer, a delivery of a waking subscription, a reply), so the service sees the
// latest message whenever it runs, at no wake-up of its own.
inline constexpr std::uint64_t kSubscribePolled = 1;

// Who sends a kind of frame.
enum class Direction : std::uint8_t { ToKernel, ToService };

enum class FrameKind : std::uint16_t {
  // ---- service → kernel ----
  Hello = 1,        // first frame after exec; aux = kProtocolVersion. The kernel answers with Boot…BootEnd.
  Publish = 2,      // slot = Topic cap (Write); payload = the topic struct, exactly its size
  Subscribe = 3,    // slot = Topic cap (Read); aux = 0 or kSubscribePolled; deliveries follow as Deliver frames
  Invoke = 4,       // slot = a non-topic cap; payload = InvokeHeader + data; answered by Reply(seq)
  TimerArm = 5,     // payload = TimerSpec: a service timer (kernel object, docs/design.md §6)
  TimerCancel = 6,  // aux = timer id
  Log = 7,          // payload = LogHeader + text
  Idle = 8,         // aux = number of frames the service has received so far: all of them are handled
  Ready = 9,        // boot done (subscriptions and timers made): the graph may start
  Taken = 10,       // checkpoint (docs/design.md §7): aux = generation; payload = TakenBody
  Resumed = 11,     // a restored image is live on its new channel: aux = generation; payload = TakenBody
                    // (its own pid: which of g's frozen copies took the Resume)
  Copied = 12,      // on a resume socket: a frozen image forked a spare copy (Fork), or a copy of a base image
                    // made generation g's image from written pages (Patch): aux = g; payload = TakenBody
  TakenPages = 13,  // checkpoint by written pages (docs/design.md §7): aux = generation; payload = TakenPagesBody;
                    // carries one fd: a sealed memfd of the pages written since the base image
  // ---- kernel → service ----
  Boot = 100,       // payload = BootHeader; then BootCap × cap_count, BootParam × param_count, BootEnd
  BootCap = 101,    // payload = BootCap
  BootParam = 102,  // payload = BootParam
  BootEnd = 103,
  Deliver = 110,    // slot = the subscriber's Topic cap; aux = generation; payload = the message
  Reply = 111,      // seq = the request's seq; payload = ReplyHeader + data
  TimerFired = 112, // aux = timer id
  Snapshot = 113,   // aux = generation g; payload = SnapshotBody; carries one fd: the image's resume socket
                    // (docs/design.md §7)
  // 114 was RollbackSignal: the kernel publishes the rollback_signal topic instead (docs/design.md §7 step 3).
  Shutdown = 115,
  Resume = 116,     // on an image's resume socket (docs/design.md §7): aux = generation; payload = ResumeBody;
                    // carries one fd: the new channel
  NetDatagram = 117,  // network gate (docs/design.md §2): slot = the Network cap; payload = one datagram as received
  Fork = 118,       // on a resume socket: one of g's frozen copies forks a spare and answers Copied
  Patch = 119,      // on a base image's resume socket: aux = the base generation; payload = PatchBody; carries
                    // two fds: the sealed pages (TakenPages) and the new image's resume socket. One copy forks
                    // a copy that applies the pages and answers Copied on the new socket as the new image
  Committed = 120,  // aux = generation g: the checkpoint this service answered (Taken, TakenPages) is committed
                    // (docs/design.md §7): the service prepares its next image's record file now, in the vehicle's
                    // slack after the checkpoint, not when the next sample wakes it (on the control chain's path)
  Sync = 121,       // answer Idle once every frame before this one is handled, also in real time (where a service
                    // sends no Idle otherwise): the kernel paces the estimate catch-up's replay by it (catch_up.hpp)
};

[[nodiscard]] std::string_view to_string(FrameKind kind);
[[nodiscard]] Direction direction_of(FrameKind kind);

struct FrameHeader {
  std::uint16_t kind = 0;    // FrameKind
  std::uint16_t flags = 0;   // reserved, must be 0
  std::uint32_t slot = 0;    // CPtr in the sender's (or receiver's) CSpace, 0 when unused
  std::uint32_t seq = 0;     // request number (service → kernel), echoed in Reply
  std::uint32_t length = 0;  // payload bytes after the header
  std::uint64_t aux = 0;     // kind-specific scalar (generation, timer id, count)
};
static_assert(sizeof(FrameHeader) == 24 && std::is_trivially_copyable_v<FrameHeader>);
inline constexpr std::size_t kMaxPayloadBytes = kMaxFrameBytes - sizeof(FrameHeader);

// ---- payloads (fixed-layout, trivially copyable) ----

struct InvokeHeader {
  std::uint8_t operation = 0;  // cap::Operation
  std::uint8_t reserved[7] = {};
  std::uint64_t arg0 = 0;      // e.g. TimerArm: period [ns]; PersistentRead/Write: offset
  std::uint64_t arg1 = 0;      // e.g. TimerArm: 1 = periodic, 0 = once
};
struct ReplyHeader {
  std::int32_t error = 0;      // 0 = ok; otherwise a cap::CapError or an operation error, +1
  std::uint32_t reserved = 0;
  std::uint64_t value = 0;     // scalar result (e.g. the epoch, a generation)
};
// Operation errors in ReplyHeader::error (docs/protocol.md: 0 ok, 1 + cap::CapError for a denial, or an
// operation error ≥ kFirstOpError): the cap was valid but the operation could not be carried out.
inline constexpr std::int32_t kFirstOpError = 100;
enum class OpError : std::int32_t {
  AlreadySubscribed = 100,  // Subscribe: this service already subscribes to the topic
  NoSuchTopic = 101,        // Subscribe: the cap names no topic of the broker
  NotSupported = 102,       // the operation exists but this kernel does not provide it (yet)
  BadArgument = 103,        // an argument or the data of an Invoke is malformed
  OutOfRange = 104,         // Persistent: offset/length outside the cell
  Refused = 105,            // the kernel refuses it in the current state (e.g. a second timer arm per epoch)
};
[[nodiscard]] std::string_view to_string(OpError error);
struct TimerSpec {
  std::uint64_t id = 0;        // chosen by the service
  std::uint64_t first_ns = 0;  // first expiry, kernel clock [ns]
  std::uint64_t period_ns = 0; // 0 = one-shot [ns]
};
enum class LogLevel : std::uint8_t { Debug, Info, Warn, Error };
struct LogHeader {
  std::uint8_t level = 0;      // LogLevel
  std::uint8_t reserved[7] = {};
};
inline constexpr std::size_t kMaxLogText = 1024;
struct BootHeader {
  std::uint32_t service_id = 0;
  std::uint32_t epoch = 0;
  std::uint32_t cap_count = 0;
  std::uint32_t param_count = 0;
  std::uint64_t generation = 0;
  char name[48] = {};          // NUL-terminated service name
};
struct BootCap {
  std::uint32_t slot = 0;
  std::uint8_t kind = 0;       // rejuv::ObjectKind
  std::uint8_t rights_by_mode[5] = {};  // Rights bits per SrMode (index_of)
  std::uint8_t reserved[2] = {};
  std::uint32_t payload_size = 0;       // Topic: exact message size
  std::uint32_t reserved2 = 0;
  char object[48] = {};        // policy object name
  char type[64] = {};          // Topic: IDL type name
};
struct BootParam {
  double number = 0;
  std::uint8_t is_text = 0;
  std::uint8_t is_integer = 0;  // the value is `integer` (a duration in ns, a switch, a count: rejuv/core/graph_values.hpp)
  std::uint8_t reserved[6] = {};
  char name[48] = {};
  char text[128] = {};
  std::int64_t integer = 0;
};
struct TakenBody {
  std::int32_t image_pid = 0;  // the frozen image (docs/design.md §7)
  std::uint32_t reserved = 0;  // image_pid 0: the errno of the failed fork (Taken, Copied), or 0
};
// Snapshot: the generation whose image the kernel holds and keeps past this checkpoint and which the service
// may take its image against by written pages (TakenPages), if its memory derives from it; 0: by fork.
struct SnapshotBody {
  std::uint64_t base = 0;
};
inline constexpr std::uint64_t kMaxImagePages = 4096;  // written pages in one TakenPages at most (16 MB)
// The seals a TakenPages memfd carries: nothing can change its pages after the answer.
inline constexpr int kPagesSeals = F_SEAL_SEAL | F_SEAL_SHRINK | F_SEAL_GROW | F_SEAL_WRITE;
struct TakenPagesBody {
  std::uint64_t base = 0;   // the base generation (the Snapshot's)
  std::uint64_t pages = 0;  // pages in the memfd (memory_image.hpp record file)
};
struct PatchBody {
  std::uint64_t generation = 0;  // the new image's
  std::uint64_t pages = 0;
};
struct ResumeBody {
  std::uint32_t epoch = 0;     // the epoch the restored incarnation runs in
  std::uint32_t reserved = 0;
};
inline constexpr std::size_t kMaxDatagramBytes = 1400;  // network gate: larger datagrams are dropped
// NetReceive verdict codes (docs/protocol.md "Network gate"): 0 = valid, 1 … kNetVerdictCodes − 1 = the
// receiver's refusal reasons. One number for the kernel that counts them and the SDK that sends them.
inline constexpr std::uint32_t kNetVerdictCodes = 32;

// The time page (docs/design.md §6): written only by the kernel, mapped read-only by services; a seqlock.
struct TimePage {
  std::atomic<std::uint64_t> sequence{0};  // odd while the kernel writes
  std::atomic<std::uint64_t> now_ns{0};    // kernel clock [ns]
  std::atomic<std::uint32_t> mode{0};      // rejuv::SrMode in force
  std::atomic<std::uint32_t> epoch{0};
};
static_assert(std::atomic<std::uint64_t>::is_always_lock_free);

// ---- decoding (untrusted bytes) ----

enum class FrameError : std::uint8_t {
  TooShort,          // fewer bytes than a header
  TooLong,           // more than kMaxFrameBytes (or truncated on receive)
  LengthMismatch,    // header.length disagrees with the datagram size
  UnknownKind,
  WrongDirection,    // a kernel → service kind sent by a service (or the reverse)
  BadFlags,
  BadPayloadSize,    // the kind's payload size rule is broken
};
[[nodiscard]] std::string_view to_string(FrameError error);

// A checked view of one frame; payload points into the caller's buffer.
struct FrameView {
  FrameKind kind{};
  FrameHeader header{};
  std::span<const std::byte> payload{};
};

// Checks everything the framing promises: size, kind, direction, payload size of the kind. Topic payload
// sizes (Publish, Deliver) are checked later against the capability's topic, not here.
[[nodiscard]] Result<FrameView, FrameError> decode(std::span<const std::byte> bytes, Direction expected);

// A datagram carries one frame or several packed back to back, each starting at a multiple of kFrameAlign
// from the datagram's start (the gap after a frame is zero), the whole at most kMaxFrameBytes: a routing
// round's frames for one service, or a service's publications and its Idle, then wake the receiver once
// (sendmmsg of one datagram per frame could wake it once per frame). A datagram that carries an fd
// (Snapshot, Resume) carries that frame only. The kernel refuses a frame that does not decode and the rest
// of its datagram with it.
inline constexpr std::size_t kFrameAlign = 8;
[[nodiscard]] constexpr std::size_t aligned_frame_size(std::size_t size) {
  return (size + kFrameAlign - 1) & ~(kFrameAlign - 1);
}
// The frame of `datagram` that starts at `offset`: its header and the payload that header states, or, when
// the datagram holds less than that (or less than a header), everything left (decode() then refuses it).
// Advances `offset` past the frame and its padding (at most to the datagram's end). An empty datagram
// yields one empty frame.
[[nodiscard]] std::span<const std::byte> next_frame(std::span<const std::byte> datagram, std::size_t& offset);
// `frames`: frames laid out as in a datagram, possibly more than one datagram holds (a sender's queue). The
// length of its longest prefix of whole frames that fits in one datagram; never less than the first frame.
// The next datagram starts at aligned_frame_size(that length).
[[nodiscard]] std::size_t datagram_prefix(std::span<const std::byte> frames);

// Reads a fixed payload struct out of a frame (the caller has decoded the frame, so the size is right).
template <class T>
[[nodiscard]] T payload_as(const FrameView& frame) {
  static_assert(std::is_trivially_copyable_v<T>);
  T value{};
  std::memcpy(&value, frame.payload.data(), std::min(sizeof(T), frame.payload.size()));
  return value;
}

// ---- encoding ----

// A frame being built in a fixed buffer: no allocation on the hot path.
class FrameBuffer {
 public:
  FrameBuffer() = default;
  // Starts a frame; returns false (and stays empty) when the payload would not fit.
  [[nodiscard]] bool build(FrameKind kind, std::uint32_t slot, std::uint32_t seq, std::uint64_t aux,
                           std::span<const std::byte> payload = {}, std::span<const std::byte> more = {});
  template <class T>
  [[nodiscard]] bool build_with(FrameKind kind, std::uint32_t slot, std::uint32_t seq, std::uint64_t aux,
                                const T& body, std::span<const std::byte> more = {}) {
    static_assert(std::is_trivially_copyable_v<T>);
    return build(kind, slot, seq, aux, std::as_bytes(std::span(&body, 1)), more);
  }
  [[nodiscard]] std::span<const std::byte> bytes() const { return {bytes_.data(), size_}; }

 private:
  alignas(8) std::array<std::byte, kMaxFrameBytes> bytes_{};
  std::size_t size_ = 0;
};

// Copies a string into a fixed char array, NUL-terminated, truncating; false if it had to truncate.
template <std::size_t N>
bool copy_name(char (&out)[N], std::string_view in) {
  const std::size_t n = std::min(in.size(), N - 1);
  // An empty string_view may have a null data(): memcpy's arguments must be valid pointers even for 0 bytes.
  if (n > 0) std::memcpy(out, in.data(), n);
  out[n] = '\0';
  return n == in.size();
}
// Reads a NUL-terminated name out of a fixed array that an untrusted peer filled (may lack the NUL).
template <std::size_t N>
std::string_view read_name(const char (&in)[N]) {
  return {in, strnlen(in, N)};
}

}  // namespace rejuv::wire
