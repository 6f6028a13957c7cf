// The kernel's observers of what it routes (mission_watch.hpp): the run's Observer, the mission's end and
// the security events, fed by the routing core through one hook (watch_publication) and drain_denials.
#include <cstring>
#include <string>

#include "impl.hpp"

namespace rejuv::kernel {

bool MissionWatch::on_setpoint(std::span<const std::byte> payload) {
  if (done_ || payload.size() != sizeof(rejuv_msg_Setpoint)) return false;
  rejuv_msg_Setpoint sp{};
  std::memcpy(&sp, payload.data(), sizeof(sp));
  done_ = sp.mission_done == 1;
  return done_;
}

void Router::watch_publication(const ObjectInfo& o, std::span<const std::byte> payload,
                               broker::TopicGeneration g, std::optional<ServiceId> publisher) {
  if (o.is_actuator_outputs && publisher) {
    k.rejuvenator.on_control_update(k.wall());  // the image work may run (rejuvenator.cpp), the slack begins
  }
  if (k.observer != nullptr) {
    k.observer->on_publication(Publication{.topic = o.id,
                                           .name = o.name,
                                           .type = o.type->name,
                                           .payload = payload,
                                           .generation = g,
                                           .t = k.now(),
                                           .publisher = publisher});
    if (o.is_actuator_outputs && publisher) k.observer->on_control_update(k.now(), k.wall());
  }
  if (o.is_setpoint && publisher && mission.on_setpoint(payload)) {
    const std::string who = k.services[publisher->value()].name;
    if (k.options.stop_on_mission_done) {
      k.stop_run(StopReason::MissionDone, "'" + who + "' reported mission_done at t = " +
                                              std::to_string(to_seconds(k.now()).count()) + " s");
    } else {
      k.log("'%s' reported mission_done; running on to the duration limit", who.c_str());
    }
  }
}

void Router::drain_denials() {
  const cap::AuditLog& audit = k.caps.audit_log();
  if (audit.pushed() == denials_drained) return;
  for (std::size_t i = audit.first_index_from(denials_drained); i < audit.size(); ++i) {
    const cap::Denial& d = audit[i];
    const bool known = d.service.value() < k.services.size();
    if (known) {
      ServiceRuntime& s = k.services[d.service.value()];
      ++s.stats.denials;
      if (s.sandbox.limiter.allow(k.wall())) {
        k.log("denied: '%s' %s on slot %u: %s (mode %s)", s.name.c_str(),
              std::string(cap::to_string(d.operation)).c_str(), d.slot.value(),
              std::string(cap::to_string(d.error)).c_str(), std::string(to_string(d.mode)).c_str());
      } else {
        ++s.stats.log_suppressed;
      }
    }
    // docs/design.md §3: every denial is also published as a SecurityEvent.
    publish_security_event(d.at, d.service, d.slot.value(), rejuv_msg_SECURITY_CAPABILITY_DENIAL, d.mode,
                           static_cast<std::uint8_t>(d.operation), static_cast<std::uint8_t>(d.error));
  }
  denials_drained = audit.pushed();
}

}  // namespace rejuv::kernel
