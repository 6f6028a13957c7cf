// The run summary's attacks by kind (idl/summary.proto AttackKindSummary): for each attack of the launch
// plan, the windows it fired in, what the kernel denied its service in them, what the sandbox contained, and
// the vehicle's worst V while it acted. A kernel observer's view, fed by the run recorder (run_recorder.hpp):
//   - windows: the plan's rule (rejuv/core/attack_window.hpp), the one the hooks in the services act by,
//     applied to the kernel's clock, mode and epoch at every step; ESCAPE_HELPER fires once, at boot;
//   - denied / contained: the kernel's SecurityEvents (a policy without a SecurityEvent topic the kernel
//     publishes gives none) of the attack's service while the attack is live — from the start of one of its
//     windows to the start of the next MC window of a later epoch (the window, the rollback that ends it and
//     the secure interval after it, where what it left behind is swept); without SR, to the end;
//   - max V: ‖x − x_sp‖²_P over the same spans (the plant's ground truth).
// An event in a span that two attacks on one service share is counted once, for the first of them in the
// plan.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "launch.pb.h"
#include "rejuv/core/attack_window.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "summary.pb.h"

namespace rejuv::cli {

class AttackLedger {
 public:
  using FindService = std::function<std::optional<ServiceId>(std::string_view)>;
  // The attacks of `graph`'s plan, as the kernel hands them to the services: start_s is flight time, so
  // `flight_start` (the pre-flight alignment) is added. Empty when attacks are off.
  AttackLedger(const proto::Launch& graph, bool attacks_on, Rejuvenation sr, Nanos flight_start,
               const FindService& find_service);

  // The kernel published mode `mode` for epoch `epoch` (an SrMode message).
  void on_mode(SrMode mode, Epoch epoch);
  // After a step at kernel time `t` in `mode`: windows that begin now, spans that end now.
  void on_step(Nanos t, SrMode mode);
  void on_security_event(const rejuv_msg_SecurityEvent& event);
  // V of a ground-truth sample in flight (after the alignment).
  void on_V(double V);

  // One AttackKindSummary per attack of the plan, in plan order.
  void fill(proto::RunSummary& s) const;
  [[nodiscard]] bool empty() const { return attacks_.empty(); }

 private:
  struct Entry {
    std::string kind;
    std::string service;
    std::optional<ServiceId> service_id;
    std::optional<AttackWindowClock> clock{};  // nullopt: fires once, at boot (ESCAPE_HELPER)
    AttackWindowKind window = AttackWindowKind::MissionControl;
    bool live = false;                  // inside a span (see the file comment)
    std::optional<Epoch> live_epoch{};  // the epoch of the window that opened the span
    std::uint64_t windows = 0;
    std::uint64_t denied = 0;
    std::uint64_t contained = 0;
    double max_V = 0;
  };
  std::vector<Entry> attacks_;
  Epoch epoch_{};
  bool booted_ = false;
};

}  // namespace rejuv::cli
