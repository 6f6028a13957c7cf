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

void Kernel::Impl::watch_publication(const ObjectInfo& o, std::span<const std::byte> payload, broker::TopicGeneration g,
                                     std::optional<ServiceId> publisher) {
  if (o.is_actuator_outputs && publisher) {
    coordinator.control_update_routed();  // the image work may run (images.cpp)
    pace.on_control_update(wall());
  }
  if (observer != nullptr) {
    observer->on_publication(Publication{.topic = o.id, .name = o.name, .type = o.type->name, .payload = payload,
                                         .generation = g, .t = now(), .publisher = publisher});
    if (o.is_actuator_outputs && publisher) observer->on_control_update(now(), wall());
  }
  if (o.is_setpoint && publisher && mission.on_setpoint(payload)) {
    const std::string who = services[publisher->value()].name;
    if (options.stop_on_mission_done) {
      stop_run(StopReason::MissionDone,
               "'" + who + "' reported mission_done at t = " + std::to_string(to_seconds(now()).count()) + " s");
    } else {
      log("'%s' reported mission_done; running on to the duration limit", who.c_str());
    }
  }
}

void Kernel::Impl::drain_denials() {
  const cap::AuditLog& audit = caps.audit_log();
  if (audit.pushed() == denials_drained) return;
  for (std::size_t i = audit.first_index_from(denials_drained); i < audit.size(); ++i) {
    const cap::Denial& d = audit[i];
    const bool known = d.service.value() < services.size();
    if (known) {
      ServiceRuntime& s = services[d.service.value()];
      ++s.stats.denials;
      if (s.sandbox.limiter.allow(wall())) {
        log("denied: '%s' %s on slot %u: %s (mode %s)", s.name.c_str(), std::string(cap::to_string(d.operation)).c_str(),
            d.slot.value(), std::string(cap::to_string(d.error)).c_str(), std::string(to_string(d.mode)).c_str());
      } else {
        ++s.stats.log_suppressed;
      }
    }
    // DESIGN §3: every denial is also published as a SecurityEvent.
    publish_kernel_message(rejuv_msg_SecurityEvent{.timestamp_ns = static_cast<std::uint64_t>(d.at.count()),
                                                   .service_id = d.service.value(),
                                                   .slot = d.slot.value(),
                                                   .operation = static_cast<std::uint8_t>(d.operation),
                                                   .error = static_cast<std::uint8_t>(d.error),
                                                   .mode = static_cast<rejuv_msg_SrModeKind>(index_of(d.mode)),
                                                   .kind = rejuv_msg_SECURITY_CAPABILITY_DENIAL});
  }
  denials_drained = audit.pushed();
}

}  // namespace rejuv::kernel
