// The kernel's vocabulary (kernel.hpp): the names of its clock modes, stop reasons and image phases, which
// stop reasons are failures and which end a run gracefully, and KernelError.
#include <array>
#include <cstdio>
#include <string>

#include "impl.hpp"

namespace rejuv::kernel {

std::string_view to_string(ClockMode mode) {
  switch (mode) {
    case ClockMode::Lockstep: return "lockstep";
    case ClockMode::Realtime: return "realtime";
  }
  return "?";
}

std::string_view to_string(StopReason reason) {
  switch (reason) {
    case StopReason::MissionDone: return "mission completed";
    case StopReason::MissionTimeout: return "mission timeout";
    case StopReason::Duration: return "duration reached";
    case StopReason::Signal: return "signal";
    case StopReason::ServiceFailed: return "service failed";
    case StopReason::PlantExited: return "plant exited";
    case StopReason::PlantProtocol: return "plant protocol broken";
    case StopReason::Requested: return "stop requested";
  }
  return "?";
}

std::string_view to_string(ImagePhase phase) {
  switch (phase) {
    case ImagePhase::CheckpointSnapshotsSent: return "checkpoint:snapshots-sent";
    case ImagePhase::CheckpointTaken: return "checkpoint:taken";
    case ImagePhase::RollbackKilled: return "rollback:killed";
    case ImagePhase::RollbackResumesSent: return "rollback:resumes-sent";
  }
  return "?";
}

bool is_failure(StopReason reason) {
  switch (reason) {
    case StopReason::MissionDone:
    case StopReason::Duration:
    case StopReason::Signal:
    case StopReason::Requested: return false;
    case StopReason::MissionTimeout:
    case StopReason::ServiceFailed:
    case StopReason::PlantExited:
    case StopReason::PlantProtocol: return true;
  }
  return true;
}

bool graceful(StopReason reason) {
  // These wait for the step in progress to be acknowledged; the others end the loop at once.
  switch (reason) {
    case StopReason::MissionDone:
    case StopReason::MissionTimeout:
    case StopReason::Duration:
    case StopReason::Requested: return true;
    case StopReason::Signal:
    case StopReason::ServiceFailed:
    case StopReason::PlantExited:
    case StopReason::PlantProtocol: return false;
  }
  return false;
}

namespace {
std::string_view kind_name(KernelError::Kind kind) {
  switch (kind) {
    case KernelError::Kind::Policy: return "policy";
    case KernelError::Kind::Audit: return "policy audit failed";
    case KernelError::Kind::Config: return "configuration";
    case KernelError::Kind::Dds: return "DDS";
    case KernelError::Kind::System: return "system";
    case KernelError::Kind::Boot: return "boot";
  }
  return "?";
}
}  // namespace

KernelError kernel_error(KernelError::Kind kind, std::string message) {
  return KernelError{.kind = kind, .message = std::move(message), .findings = {}};
}

std::string KernelError::to_string() const {
  std::string out = std::string(kind_name(kind)) + ": " + message;
  for (const std::string& f : findings) out += "\n  " + f;
  return out;
}

bool KernelError::is_bad_input() const {
  // README "Exit codes": an audit finding is a verdict on a well-formed policy (exit 1, as `rejuv audit`
  // gives it), not a file the loader refused (exit 2).
  switch (kind) {
    case Kind::Policy:
    case Kind::Config: return true;
    case Kind::Audit:
    case Kind::Dds:
    case Kind::System:
    case Kind::Boot: return false;
  }
  return false;
}

std::string log_line(const char* format, va_list args) {
  std::array<char, kMaxLogLine + 1> buf{};
  std::vsnprintf(buf.data(), buf.size(), format, args);
  return buf.data();
}

}  // namespace rejuv::kernel
