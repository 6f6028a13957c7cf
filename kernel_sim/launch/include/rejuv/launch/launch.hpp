// The launch graph (docs/design.md §1, §10): what runs, wired how, with which SR parameters, mission and attack
// plan. `load_launch` parses a *.launch.pbtxt and validates everything that a later stage would otherwise
// discover mid-flight; every refusal names file:line:column and what was expected (docs/conventions.md "Errors are
// values"). Fields whose default is not the proto's zero are read through the accessors below, so the
// defaults live in one place and the parsed proto stays exactly what the user wrote.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "launch.pb.h"
#include "params.pb.h"
#include "rejuv/core/dds_name.hpp"
#include "rejuv/core/graph_values.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/mavlink/frame.hpp"
#include "rejuv/textproto/textproto.hpp"
#include "rejuv/core/time.hpp"

namespace rejuv::launch {

// A validated launch graph with the location of every field (for later semantic findings, e.g. the
// `coverage` audit of docs/design.md §4) and the policy file it names, resolved against the launch file's folder.
struct LoadedLaunch {
  proto::Launch graph;
  TextLocations locations;
  std::filesystem::path path;         // the launch file as given
  std::filesystem::path policy_path;  // resolved; exists and is a regular file
  // The graph's `policy_include` fragments, resolved against the file naming each: load_policy merges them.
  std::vector<ExtraFragment> policy_includes;
};

// Reads, parses and validates a launch graph with the fragments it includes (idl/launch.proto `include`;
// a path a fragment writes is made relative to this file's folder, where every reader resolves it).
// CannotRead / Syntax / Semantic errors at the file:line:column of the fragment concerned, never an exception.
[[nodiscard]] Result<LoadedLaunch, LoadError> load_launch(const std::filesystem::path& path);

// Several launch files as one graph (as ROS 2 launch takes several): composed in order by the rules of
// `include`, as if a file beside the first included each of them — repeated fields appended, a singular field
// set by two of the files refused at the second one's line:column. One path: load_launch(path).
[[nodiscard]] Result<LoadedLaunch, LoadError> load_launch(std::span<const std::filesystem::path> paths);

// The same from text; `as_path` names the file in messages and anchors the relative policy path and the
// includes (tests, fuzzing).
[[nodiscard]] Result<LoadedLaunch, LoadError> parse_launch(std::string_view text,
                                                           const std::filesystem::path& as_path);

// The network gate's MAVLink 2 signing key: `network.signing_key` (64 hex digits) or the file named by
// `network.signing_key_file` (relative to the launch file's folder; 64 hex digits, surrounding white space
// ignored; not readable by group or others). nullopt: neither is set. The error says what is wrong (the
// validator reports it at the field's file:line; the kernel reads the key again at start).
struct KeyError {
  std::string field;    // "signing_key" or "signing_key_file"
  std::string message;
};
[[nodiscard]] Result<std::optional<mavlink::SigningKey>, KeyError> signing_key(const proto::NetworkSpec& network,
                                                                              const std::filesystem::path& launch_path);

// `network.ground_address` split into its IPv4 address and port ("a.b.c.d:port", port 1 … 65535).
struct HostPort {
  std::string ip;
  std::uint16_t port = 0;
};
[[nodiscard]] std::optional<HostPort> ground_address(std::string_view text);

// ---- defaults (one place; the proto keeps what the user wrote) ----
namespace defaults {
inline constexpr std::uint32_t kKeepGenerations = graph_values::kKeepGenerations.fallback;  // docs/design.md §7
inline constexpr double kPhysicsRateHz = 1000.0;       // docs/design.md §9: RK4 at 1 kHz
inline constexpr Seconds kCheckPeriod = to_seconds(graph_values::kCheckPeriod.fallback);  // §V-B: every 2 ms
// Lockstep charges (docs/design.md §6, idl/launch.proto LockstepTiming): what `rejuv bench realtime` measured the
// vehicle lose at a checkpoint and at a rollback in real time on the project's 2-vCPU machines (docs/
// performance.md "Deterministic lockstep"), for a graph that sets none.
inline constexpr Seconds kCheckpointCharge{0.0003};
inline constexpr Seconds kRollbackCharge{0.0003};
inline constexpr Seconds kCatchUpChargePerSample{2e-6};  // lockstep.catch_up_charge_us_per_sample
inline constexpr double kMaxCatchUpChargeUs = 1000.0;
inline constexpr Seconds kAlignment{20.0};             // pre-flight alignment before the mission's t = 0
inline constexpr double kMaxChargeMs = 1000.0;         // the plant refuses a step charged more than 1 s
inline constexpr double kMaxAlignmentS = 3600.0;       // the plant's --align-s bound
inline constexpr std::size_t kMaxWaypoints = 16;       // idl/control.idl MissionWaypoints.waypoints[16]
inline constexpr std::uint32_t kMaxDdsDomainId = 232;  // DDSI-RTPS port mapping limit
inline constexpr std::string_view kDdsNamePrefix = rejuv::kDdsNamePrefix;  // rejuv/core/dds_name.hpp
inline constexpr std::string_view kDdsConfig = "config/cyclonedds.xml";  // relative to the repository
// Sandbox limits of a service's processes (docs/design.md §7 "Protection"): a live incarnation, K generations of
// images with a spare each, workers; a few hundred fds; the address space of a service with room to spare.
inline constexpr std::uint32_t kSandboxProcesses = 64;
inline constexpr std::uint32_t kSandboxMemoryMb = 4096;
inline constexpr std::uint32_t kSandboxOpenFiles = 256;
// No CPU quota by default: a CFS quota on a service's group made every rollback's resume ≈ 1.3 ms slower
// (docs/performance.md, `rejuv bench images`), the wake-up of a throttled group's restored image being slow;
// a graph that fears spinning strays more than that sets max_cpu_percent (100 = one CPU).
inline constexpr std::uint32_t kSandboxCpuPercent = 0;
inline constexpr std::uint32_t kSandboxGroupMemoryMb = 1024;
// A service's publication budget [1/s of kernel time] (docs/sandbox.md "Floods cost only the flooder"): the
// busiest honest service of the shipped graphs publishes ≈ 280/s (docs/performance.md "Publication rates"), so
// 2000/s is seven times that and never touches one; a burst of one second's worth passes.
inline constexpr std::uint32_t kSandboxPublicationsPerS = 2000;
inline constexpr std::uint32_t kMaxSandboxPublicationsPerS = 1'000'000;
inline constexpr std::uint32_t kMinSandboxOpenFiles = 16;  // below it the SDK cannot boot
// Bounds of what a graph may ask for (refused at load, file:line:column):
inline constexpr double kMaxDurationS = 1e6;           // any duration [s]: ~11 days, far inside int64 ns
inline constexpr double kMinPhysicsRateHz = 100.0;     // below the sensor and control rates the model breaks
inline constexpr double kMaxPhysicsRateHz = 100000.0;  // 10 µs RK4 steps: beyond, a run never ends
inline constexpr double kMaxWaypointOffsetM = 10000.0; // |north|, |east|, |down| of a waypoint [m]
// A mission timeout derived from the path (mission_timeout): the paper's scheme flies ≈ 65 s per metre under
// attack (the 4 m square in ≈ 260 s with SR), so 150 s per metre leaves ≈ 2.3×; the base covers a short path.
inline constexpr double kDerivedTimeoutBaseS = 60.0;
inline constexpr double kDerivedTimeoutPerMetreS = 150.0;
inline constexpr double kMinDerivedTimeoutS = 600.0;
}  // namespace defaults

// The attack kinds (idl/launch.proto AttackKind) that an in-tree service has a hook for (docs/design.md §9: a plan
// naming a kind that service has no hook for is refused at load), by executable file name; nullopt for an
// executable this table does not know (a service outside the tree, a test service): not checked.
[[nodiscard]] std::optional<std::vector<proto::AttackKind>> attack_hooks_of(std::string_view executable);

// K, the number of checkpoint generations kept (docs/design.md §7).
[[nodiscard]] std::uint32_t keep_generations(const proto::SrParams& sr);
// Period of the check of condition (1) (§V-B).
[[nodiscard]] Seconds check_period(const proto::SrParams& sr);
[[nodiscard]] Seconds t_mc(const proto::SrParams& sr);
[[nodiscard]] Seconds t_est(const proto::SrParams& sr);
[[nodiscard]] Seconds t_min(const proto::SrParams& sr);
// The fields of sr.ekf_rearm the launch file sets, by name (idl/launch.proto EstimatorRearm; `enabled` as 1 or
// 0): what ekf2 gets as its boot params sr.ekf_rearm.<name>, and the model as its flight::EkfRearm. Read by
// reflection, so that a field added to the message reaches both without being spelt again.
struct RearmField {
  std::string name;
  double value = 0.0;
  bool is_switch = false;  // `enabled`; every other field is a 1σ
  const graph_values::Key<double>* key = nullptr;  // a 1σ's graph-wide key; nullptr for the switch
};
[[nodiscard]] std::vector<RearmField> ekf_rearm_fields(const proto::EstimatorRearm& rearm);
// The mission's timeout_s, or unset, derived from the path (idl/launch.proto Mission.timeout_s):
// kDerivedTimeoutBaseS plus kDerivedTimeoutPerMetreS per metre of the waypoints' path, at least
// kMinDerivedTimeoutS and at most kMaxDurationS.
[[nodiscard]] Seconds mission_timeout(const proto::Mission& mission);
// The length of the mission's path: the first waypoint, where it starts hovering, through every other one [m].
[[nodiscard]] double path_length_m(const proto::Mission& mission);
// LockstepTiming with its defaults: the simulated time a checkpoint / rollback is charged, the alignment.
// The real-time plan's values with their defaults (docs/realtime.md): the kernel's and the plant's SCHED_FIFO
// priorities (0: SCHED_OTHER) and each SCHED_FIFO service's RLIMIT_RTTIME.
struct RealtimeValues {
  std::uint32_t kernel_priority = 60;
  std::uint32_t plant_priority = 70;
  std::uint32_t max_rt_time_ms = 100;
};
[[nodiscard]] RealtimeValues realtime_values(const proto::RealtimePlan& plan);
[[nodiscard]] Seconds checkpoint_charge(const proto::LockstepTiming& lockstep);
[[nodiscard]] Seconds rollback_charge(const proto::LockstepTiming& lockstep);
[[nodiscard]] Seconds catch_up_charge_per_sample(const proto::LockstepTiming& lockstep);
[[nodiscard]] Seconds alignment(const proto::LockstepTiming& lockstep);
// Physics rate of the plant [Hz]; 0 in the file means the default.
[[nodiscard]] double physics_rate_hz(const proto::PlantSpec& plant);
[[nodiscard]] Seconds physics_step(const proto::PlantSpec& plant);
// false = driver level, never rolled back (docs/design.md §2); default true.
[[nodiscard]] bool rejuvenate(const proto::ServiceSpec& service);
// Whose names the graph's bridged topics have on DDS: ROS 2's with dds.ros2_names (rejuv/core/dds_name.hpp).
[[nodiscard]] DdsNaming dds_naming(const proto::DdsSpec& dds);
// DDS topic name of a bridge of `dds`: as written, else dds_topic_name(topic, dds_naming(dds)): "rejuv/<topic>"
// or "rt/<topic>".
[[nodiscard]] std::string dds_name(const proto::DdsSpec& dds, const proto::Bridge& bridge);
// Cyclone XML config: as written (relative to the launch file), else config/cyclonedds.xml of `repo_root`.
[[nodiscard]] std::filesystem::path dds_config(const LoadedLaunch& launch,
                                               const std::filesystem::path& repo_root);

// A service's resource limits: its own `limits`, else the graph's `sandbox_limits`, else the defaults.
struct SandboxLimitValues {
  std::uint32_t max_processes = defaults::kSandboxProcesses;
  std::uint32_t max_memory_mb = defaults::kSandboxMemoryMb;  // 0 = no limit
  std::uint32_t max_open_files = defaults::kSandboxOpenFiles;
  std::uint32_t max_cpu_percent = defaults::kSandboxCpuPercent;            // 0 = no limit
  std::uint32_t max_group_memory_mb = defaults::kSandboxGroupMemoryMb;    // 0 = no limit
  std::uint32_t max_publications_per_s = defaults::kSandboxPublicationsPerS;  // [1/s of kernel time]
};
[[nodiscard]] SandboxLimitValues sandbox_limits(const proto::Launch& graph, const proto::ServiceSpec& service);

// The graph's hosts (idl/launch.proto Host, docs/across_hosts.md): the vehicle's is the first listed; "" for
// a graph without `hosts` (one host). A service's host: its `host`, else the vehicle's.
[[nodiscard]] std::string_view vehicle_host(const proto::Launch& graph);
[[nodiscard]] std::string_view host_of(const proto::Launch& graph, const proto::ServiceSpec& service);

// The service called `name`, or nullptr.
[[nodiscard]] const proto::ServiceSpec* find_service(const proto::Launch& graph, std::string_view name);

// ---- declared parameters (idl/params.proto; docs/writing_a_service.md "Declaring parameters") ----
// A service declares the `params` its launch entry may set in `<executable>.params.pbtxt`, installed beside its
// executable. check_declared_params refuses, at the param's file:line:column, a name the service does not declare
// (with "did you mean"), a value of the wrong type, not one of its choices or out of its range. A service whose
// executable has no such file is not checked (its params reach it as written).

// A declaration file, checked (load_params_file / parse_params_file), with where each field was written.
struct LoadedParams {
  proto::ServiceParams decls;
  TextLocations locations;
  std::filesystem::path path;
};

// `<executable>.params.pbtxt`: the declaration file of the service built as `executable`.
[[nodiscard]] std::filesystem::path params_file_of(const std::filesystem::path& executable);
// An `executable:` of a graph as the kernel starts it: absolute as written, else under `service_dir`.
[[nodiscard]] std::filesystem::path resolve_executable(std::string_view executable,
                                                       const std::filesystem::path& service_dir);

// Reads and checks one declaration file: a syntax error at its file:line:column; a declaration that cannot mean
// what was intended (no name or help, a duplicate, min above max, a range or choices its type has no use for, a
// default of the wrong type or outside its own range) at the field.
[[nodiscard]] Result<LoadedParams, LoadError> load_params_file(const std::filesystem::path& path);
[[nodiscard]] Result<LoadedParams, LoadError> parse_params_file(std::string_view text,
                                                                const std::filesystem::path& as_path);

// The declarations of the service built as `executable` (params_file_of): nullopt when it has no such file.
[[nodiscard]] Result<std::optional<LoadedParams>, LoadError> declared_params_of(const std::filesystem::path& executable);

// The params of graph service `service_index` against `declared` (its declaration file): the first problem, at
// the param's name (unknown) or value (type, choices, range) in the launch file.
[[nodiscard]] Result<void, LoadError> check_service_params(const LoadedLaunch& loaded, int service_index,
                                                           const LoadedParams& declared);

// Every service of the graph whose executable (resolved against `service_dir`) has a declaration file, checked
// as check_service_params; a declaration file that does not load is the error.
[[nodiscard]] Result<void, LoadError> check_declared_params(const LoadedLaunch& loaded,
                                                            const std::filesystem::path& service_dir);

// The declarations as a table for `rejuv run --help-service`: name, type, default, range or choices, unit, help.
[[nodiscard]] std::string format_declared_params(const proto::ServiceParams& decls);

}  // namespace rejuv::launch
