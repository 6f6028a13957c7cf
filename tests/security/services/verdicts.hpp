// The reports the security tests' service publishes on `verdicts` (attack_service.cpp), one record type per
// kind of report, and their one encoding: the policy gives `verdicts` a compiled-in topic type, SensorBaro,
// whose pressure_pa carries the kind's tag and altitude_m, temperature_c the record's two numbers. The
// service encodes with `encode`, the tests (attack_test.cpp, hostile_test.cpp) decode with `decode<T>`, so
// that neither reads a field by a name that means something else.
#pragma once

#include <cstdint>
#include <optional>

#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::test_services::verdicts {

// driver: the restricted limits it read (LimitsRead).
struct LimitsRead {
  static constexpr double kTag = 1;
  double first_limit = 0;  // the first of the 16 doubles
  double bytes = 0;        // the Reply's data size
};
// rejuv: the persistent cell as it read it before its own write (a uint64 as a double).
struct CellRead {
  static constexpr double kTag = 2;
  double cell = 0;
  double unused = 0;
};
// rejuv: a checkpoint it took (CheckpointOutcome Taken).
struct CheckpointTaken {
  static constexpr double kTag = 3;
  double generation = 0;
  double unused = 0;
};
// Any service: one attempt of the attack the launch plan gave it (attacks::Attempt); tagged 100 + its kind.
struct AttackAttempt {
  static constexpr double kTagBase = 100;
  double code = 0;  // attacks::Attempt::code: 0 accepted, 1 + CapError denied, >= 100 an OpError, or an errno
  double target = 0;  // the slot (requests) or pid (signals, ptrace) it aimed at
};
// worker: an escape that returned (escapes.hpp Outcome; escapes::kTag).
struct EscapeReport {
  static constexpr double kTag = 300;
  double value = 0;
  double detail = 0;
};

// Any service with a CUSTOM attack (rejuv/sdk/attack_hook.hpp): a window of it began (on_attack's callback).
struct CustomWindow {
  static constexpr double kTag = 400;
  double mode = 0;       // index_of(mode()) when it began
  double magnitude = 0;  // AttackWindow::magnitude
};
// Any service with a CUSTOM attack: a tick at which the hook said a window is in force (active()).
struct CustomActive {
  static constexpr double kTag = 401;
  double epoch = 0;
  double mode = 0;  // index_of(mode()) then
};

inline rejuv_msg_SensorBaro encode(double tag, double a, double b, std::uint64_t timestamp_ns) {
  rejuv_msg_SensorBaro r{};
  r.timestamp_ns = timestamp_ns;
  r.pressure_pa = tag;
  r.altitude_m = a;
  r.temperature_c = b;
  return r;
}
inline rejuv_msg_SensorBaro encode(const LimitsRead& v, std::uint64_t t) {
  return encode(LimitsRead::kTag, v.first_limit, v.bytes, t);
}
inline rejuv_msg_SensorBaro encode(const CellRead& v, std::uint64_t t) {
  return encode(CellRead::kTag, v.cell, v.unused, t);
}
inline rejuv_msg_SensorBaro encode(const CheckpointTaken& v, std::uint64_t t) {
  return encode(CheckpointTaken::kTag, v.generation, v.unused, t);
}
inline rejuv_msg_SensorBaro encode(double attack_kind, const AttackAttempt& v, std::uint64_t t) {
  return encode(AttackAttempt::kTagBase + attack_kind, v.code, v.target, t);
}
inline rejuv_msg_SensorBaro encode(const EscapeReport& v, std::uint64_t t) {
  return encode(EscapeReport::kTag, v.value, v.detail, t);
}
inline rejuv_msg_SensorBaro encode(const CustomWindow& v, std::uint64_t t) {
  return encode(CustomWindow::kTag, v.mode, v.magnitude, t);
}
inline rejuv_msg_SensorBaro encode(const CustomActive& v, std::uint64_t t) {
  return encode(CustomActive::kTag, v.epoch, v.mode, t);
}

// The record of type T that `r` carries, or nullopt when it carries another kind of report.
template <class T>
std::optional<T> decode(const rejuv_msg_SensorBaro& r, double tag = T::kTag) {
  if (r.pressure_pa != tag) return std::nullopt;
  return T{r.altitude_m, r.temperature_c};
}
// An attempt of attack kind `attack_kind`.
inline std::optional<AttackAttempt> decode_attempt(const rejuv_msg_SensorBaro& r, double attack_kind) {
  return decode<AttackAttempt>(r, AttackAttempt::kTagBase + attack_kind);
}

}  // namespace rejuv::test_services::verdicts
