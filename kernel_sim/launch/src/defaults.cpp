// The launch graph's defaults and accessors (launch.hpp "defaults"): the fields whose default is not the
// proto's zero read in one place, the attack hooks of the in-tree services, service lookup and sandbox limits.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include "rejuv/launch/launch.hpp"

namespace rejuv::launch {

std::optional<std::vector<proto::AttackKind>> attack_hooks_of(std::string_view executable) {
  // services/*/main.cpp: lqr_control carries the worst-case control law (worst_case_attack.cpp) and the gain
  // overwrite of the attack library; checkpoint_p, commander, ext_link and ekf2 install the runtime hooks of
  // services/attacks (attacks::install), which carry out every runtime kind (ESCAPE_HELPER included); ekf2,
  // sensors and gen_set_point carry the attack library's laws on the estimate, the IMU data and x_sp
  // (docs/control.md "Attack library"); the others have none.
  const std::vector<proto::AttackKind> runtime{
      proto::INVOKE_CHECKPOINT, proto::ARM_TIMER,  proto::WRITE_LIMITS, proto::PUBLISH_ACTUATOR_OUTPUTS,
      proto::WRITE_PERSISTENT,  proto::FORGED_SLOT, proto::NETWORK_IN_SEI, proto::KILL_IMAGE,
      proto::OPEN_SOCKET,       proto::FLOOD_BROKER, proto::ESCAPE_HELPER,
      // the attacks on rollback itself (docs/sandbox.md)
      proto::SIGIO_IMAGES,      proto::SIGIO_KERNEL, proto::SIGIO_LOG_TRAP, proto::STRAY_SPINNERS,
      proto::STRAY_MEMORY,      proto::SPINNING_THREADS, proto::RETIRED_WORKER, proto::WORKER_RAISE,
      proto::FORGED_LOG,        proto::PAGEMAP_FRAMES,
      // a binary hostile from its first instruction (docs/sandbox.md "No trusted boot phase")
      proto::BOOT_TIME_PAGE,    proto::BOOT_PRLIMIT_KERNEL, proto::BOOT_READ_SECRETS,
      // its images out of the OOM killer's reach (docs/sandbox.md "A cgroup per service")
      proto::OOM_IMAGES};
  const std::string name = std::filesystem::path(executable).filename().string();
  if (name == "rejuv_lqr_control") {
    return std::vector<proto::AttackKind>{proto::WORST_CASE_CONTROL, proto::GAIN_OVERWRITE};
  }
  if (name == "rejuv_ekf2") {
    std::vector<proto::AttackKind> kinds = runtime;
    kinds.insert(kinds.end(), {proto::ESTIMATE_SHIFT, proto::ESTIMATE_DRIFT});
    return kinds;
  }
  if (name == "rejuv_sensors") {
    return std::vector<proto::AttackKind>{proto::SENSOR_BIAS, proto::SLOW_REPLAY, proto::LYING_REPLAY};
  }
  if (name == "rejuv_gen_set_point") return std::vector<proto::AttackKind>{proto::SETPOINT_SHIFT};
  if (name == "rejuv_checkpoint_p" || name == "rejuv_commander" || name == "rejuv_ext_link") {
    return runtime;
  }
  for (const char* none : {"rejuv_safety_control", "rejuv_output_driver"}) {
    if (name == none) {
      return std::vector<proto::AttackKind>{};
    }
  }
  return std::nullopt;
}

std::uint32_t keep_generations(const proto::SrParams& sr) {
  return sr.has_keep_generations() ? sr.keep_generations() : defaults::kKeepGenerations;
}
Seconds check_period(const proto::SrParams& sr) {
  return sr.has_check_period_s() ? Seconds(sr.check_period_s()) : defaults::kCheckPeriod;
}
Seconds t_mc(const proto::SrParams& sr) {
  return Seconds(sr.t_mc_s());
}
Seconds t_est(const proto::SrParams& sr) {
  return Seconds(sr.t_est_s());
}
Seconds t_min(const proto::SrParams& sr) {
  return Seconds(sr.t_min_s());
}
std::vector<RearmField> ekf_rearm_fields(const proto::EstimatorRearm& rearm) {
  std::vector<const google::protobuf::FieldDescriptor*> set;
  rearm.GetReflection()->ListFields(rearm, &set);
  std::vector<RearmField> out;
  for (const google::protobuf::FieldDescriptor* f : set) {
    const bool is_switch = f->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_BOOL;
    const double value = is_switch ? (rearm.GetReflection()->GetBool(rearm, f) ? 1.0 : 0.0)
                                   : rearm.GetReflection()->GetDouble(rearm, f);
    const graph_values::Key<double>* key = is_switch ? nullptr : graph_values::rearm_std(f->name());
    REJUV_ASSERT(is_switch || key != nullptr,
                 "an EstimatorRearm field without a key in rejuv/core/graph_values.hpp");
    out.push_back(RearmField{.name = f->name(), .value = value, .is_switch = is_switch, .key = key});
  }
  return out;
}
double path_length_m(const proto::Mission& mission) {
  double length = 0.0;
  for (int i = 1; i < mission.waypoints_size(); ++i) {
    const proto::Waypoint& a = mission.waypoints(i - 1);
    const proto::Waypoint& b = mission.waypoints(i);
    length += std::hypot(b.north_m() - a.north_m(), b.east_m() - a.east_m(), b.down_m() - a.down_m());
  }
  return length;
}

Seconds mission_timeout(const proto::Mission& mission) {
  if (mission.has_timeout_s()) return Seconds(mission.timeout_s());
  const double derived = defaults::kDerivedTimeoutBaseS + defaults::kDerivedTimeoutPerMetreS * path_length_m(mission);
  return Seconds(std::clamp(derived, defaults::kMinDerivedTimeoutS, defaults::kMaxDurationS));
}
RealtimeValues realtime_values(const proto::RealtimePlan& plan) {
  RealtimeValues v;
  if (plan.has_kernel_priority()) v.kernel_priority = plan.kernel_priority();
  if (plan.has_plant_priority()) v.plant_priority = plan.plant_priority();
  if (plan.has_max_rt_time_ms()) v.max_rt_time_ms = plan.max_rt_time_ms();
  return v;
}
Seconds checkpoint_charge(const proto::LockstepTiming& lockstep) {
  return lockstep.has_checkpoint_charge_ms() ? Seconds(lockstep.checkpoint_charge_ms() / 1000.0)
                                             : defaults::kCheckpointCharge;
}
Seconds rollback_charge(const proto::LockstepTiming& lockstep) {
  return lockstep.has_rollback_charge_ms() ? Seconds(lockstep.rollback_charge_ms() / 1000.0)
                                           : defaults::kRollbackCharge;
}
Seconds catch_up_charge_per_sample(const proto::LockstepTiming& lockstep) {
  return lockstep.has_catch_up_charge_us_per_sample() ? Seconds(lockstep.catch_up_charge_us_per_sample() / 1e6)
                                                      : defaults::kCatchUpChargePerSample;
}
Seconds alignment(const proto::LockstepTiming& lockstep) {
  return lockstep.has_alignment_s() ? Seconds(lockstep.alignment_s()) : defaults::kAlignment;
}

double physics_rate_hz(const proto::PlantSpec& plant) {
  return plant.physics_rate_hz() > 0.0 ? plant.physics_rate_hz() : defaults::kPhysicsRateHz;
}
Seconds physics_step(const proto::PlantSpec& plant) {
  return Seconds(1.0 / physics_rate_hz(plant));
}

bool rejuvenate(const proto::ServiceSpec& service) {
  return service.has_rejuvenate() ? service.rejuvenate() : true;
}

DdsNaming dds_naming(const proto::DdsSpec& dds) { return dds.ros2_names() ? DdsNaming::Ros2 : DdsNaming::Rejuv; }

std::string dds_name(const proto::DdsSpec& dds, const proto::Bridge& bridge) {
  return bridge.dds_name().empty() ? dds_topic_name(bridge.topic(), dds_naming(dds)) : bridge.dds_name();
}

std::filesystem::path dds_config(const LoadedLaunch& launch, const std::filesystem::path& repo_root) {
  const std::string& cfg = launch.graph.dds().config();
  if (cfg.empty()) {
    return repo_root / defaults::kDdsConfig;
  }
  const std::filesystem::path p(cfg);
  return (p.is_relative() ? launch.path.parent_path() / p : p).lexically_normal();
}

const proto::ServiceSpec* find_service(const proto::Launch& graph, std::string_view name) {
  for (const proto::ServiceSpec& s : graph.services()) {
    if (s.name() == name) {
      return &s;
    }
  }
  return nullptr;
}

SandboxLimitValues sandbox_limits(const proto::Launch& graph, const proto::ServiceSpec& service) {
  SandboxLimitValues v;
  for (const proto::SandboxLimits* l : {&graph.sandbox_limits(), &service.limits()}) {  // the service's last
    if (l->has_max_processes()) v.max_processes = l->max_processes();
    if (l->has_max_memory_mb()) v.max_memory_mb = l->max_memory_mb();
    if (l->has_max_open_files()) v.max_open_files = l->max_open_files();
    if (l->has_max_cpu_percent()) v.max_cpu_percent = l->max_cpu_percent();
    if (l->has_max_group_memory_mb()) v.max_group_memory_mb = l->max_group_memory_mb();
    if (l->has_max_publications_per_s()) v.max_publications_per_s = l->max_publications_per_s();
  }
  return v;
}

}  // namespace rejuv::launch
