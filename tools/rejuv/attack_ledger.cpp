#include "attack_ledger.hpp"

#include <algorithm>
#include <cmath>

namespace rejuv::cli {

AttackLedger::AttackLedger(const proto::Launch& graph, bool attacks_on, Rejuvenation sr, Nanos flight_start,
                           const FindService& find_service) {
  if (!attacks_on) return;
  for (const proto::Attack& a : graph.attack().attacks()) {
    Entry e{.kind = proto::AttackKind_Name(a.kind()),
            .service = a.service(),
            .service_id = find_service(a.service())};
    // The windows of launch.proto AttackKind: NETWORK_IN_SEI acts in the secure intervals, ESCAPE_HELPER once
    // at boot (services/attacks plan.cpp window_kind_of, occasion_of), every other kind in MC windows.
    e.window = a.kind() == proto::NETWORK_IN_SEI ? AttackWindowKind::SecureInterval
                                                 : AttackWindowKind::MissionControl;
    if (a.kind() != proto::ESCAPE_HELPER) {
      e.clock.emplace(AttackSchedule{.start = flight_start + to_nanos(Seconds{a.start_s()}),
                                     .max_windows = a.max_windows(),
                                     .window = e.window,
                                     .sr = sr});
    }
    attacks_.push_back(std::move(e));
  }
}

void AttackLedger::on_mode(SrMode /*mode*/, Epoch epoch) {
  epoch_ = epoch;
}

void AttackLedger::on_step(Nanos t, SrMode mode) {
  if (!booted_) {
    booted_ = true;
    for (Entry& e : attacks_) {
      if (e.clock) continue;
      ++e.windows;  // carried out as the hooks are installed, at boot; its helper lives on
      e.live = true;
    }
  }
  for (Entry& e : attacks_) {
    if (!e.clock) continue;
    // The span of the last window ends where the next MC window of a later epoch begins (an SI window's: at
    // the MC window after it). Without SR it never ends.
    if (e.live && e.clock->schedule().sr == Rejuvenation::On && mode == SrMode::MC &&
        (e.window == AttackWindowKind::SecureInterval || e.live_epoch != epoch_)) {
      e.live = false;
    }
    if (e.clock->begins(t, mode, epoch_)) {
      ++e.windows;
      e.live = true;
      e.live_epoch = epoch_;
    }
  }
}

void AttackLedger::on_security_event(const rejuv_msg_SecurityEvent& event) {
  const bool denial = event.kind == rejuv_msg_SECURITY_CAPABILITY_DENIAL;
  const bool violation =
      event.kind == rejuv_msg_SECURITY_FORBIDDEN_CALL || event.kind == rejuv_msg_SECURITY_STRAY_PROCESS ||
      event.kind == rejuv_msg_SECURITY_OUT_OF_MEMORY;
  if (!denial && !violation) return;
  for (Entry& e : attacks_) {
    if (!e.live || !e.service_id || e.service_id->value() != event.service_id) continue;
    ++(denial ? e.denied : e.contained);
    return;  // once, for the first live attack of that service in the plan
  }
}

void AttackLedger::on_V(double V) {
  if (!std::isfinite(V)) return;
  for (Entry& e : attacks_) {
    if (e.live) e.max_V = std::max(e.max_V, V);
  }
}

void AttackLedger::fill(proto::RunSummary& s) const {
  for (const Entry& e : attacks_) {
    proto::AttackKindSummary& row = *s.add_attacks_by_kind();
    row.set_kind(e.kind);
    row.set_service(e.service);
    row.set_windows_fired(e.windows);
    row.set_denied(e.denied);
    row.set_contained(e.contained);
    row.set_max_v(e.max_V);
    row.set_left_safety_set(e.max_V >= 1.0);
  }
}

}  // namespace rejuv::cli
