// `rejuv faults`: the fault campaign (docs/design.md §7 "Faults", §11). Missions of a launch graph
// fly one after another (or in --jobs parallel processes, each with its own DDS domain), each with a few
// faults injected at moments and phases drawn from the seed; after each one the campaign records the path by
// which the kernel recovered, whether the vehicle stayed inside the safety set, whether anything leaked and
// whether the mission hung. This header is the plan and the per-injection record (fault_plan.cpp); fault_campaign.cpp flies
// the missions, cmd_faults.cpp is the command (table, JSON).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/time.hpp"
#include "rejuv/kernel/kernel.hpp"

namespace rejuv::cli::faults {

// What is done to which process.
enum class FaultKind : std::uint8_t {
  KillLive,    // SIGKILL the live incarnation of a rejuvenated service
  HangLive,    // SIGSTOP it: hung past the idle (or snapshot) deadline
  KillImage,   // SIGKILL every copy of one image (the newest generation's, or the one being restored)
  StopImage,   // SIGSTOP them: the image cannot answer its Resume
  KillImages,  // SIGKILL every image of a service (all generations)
  KillGroup,   // SIGKILL the live incarnation and every image of a service: nothing left to restore
  StallPlant,  // SIGSTOP the plant for 1 s of wall time, then SIGCONT: the lockstep link stalls
  KillDriver,  // SIGKILL output_driver (driver level, never rolled back): the run must end cleanly, exit 1
  KillPlant,   // SIGKILL the plant: the run must end cleanly, exit 1
};
inline constexpr std::array kAllFaultKinds{FaultKind::KillLive,   FaultKind::HangLive,  FaultKind::KillImage,
                                           FaultKind::StopImage,  FaultKind::KillImages, FaultKind::KillGroup,
                                           FaultKind::StallPlant, FaultKind::KillDriver, FaultKind::KillPlant};
[[nodiscard]] std::string_view to_string(FaultKind kind);
// A fault after which the run cannot go on (what cannot be rejuvenated): the last of its mission.
[[nodiscard]] bool is_terminal(FaultKind kind);

// When: at a lockstep step in a mode, or exactly at a phase boundary inside a checkpoint or a rollback
// (kernel::ImagePhase, the kernel's fault-injection seam).
enum class Where : std::uint8_t {
  MC,                       // a step in mission control
  SecureInterval,           // a step in SC, UPDATE or CP
  CheckpointSnapshotsSent,  // between the Snapshots and the Takens
  CheckpointTaken,          // between the last Taken and the commit
  RollbackKilled,           // between the kill of the live services and the first Resume
  RollbackResumesSent,      // between the Resumes and the last Resumed
};
inline constexpr std::array kAllWheres{Where::MC,
                                       Where::SecureInterval,
                                       Where::CheckpointSnapshotsSent,
                                       Where::CheckpointTaken,
                                       Where::RollbackKilled,
                                       Where::RollbackResumesSent};
[[nodiscard]] std::string_view to_string(Where where);
// The (kind, where) pairs the campaign draws from: a live incarnation is no target inside a rollback (it
// is already cut off).
[[nodiscard]] bool makes_sense(FaultKind kind, Where where);

struct Planned {
  FaultKind kind = FaultKind::KillLive;
  Where where = Where::MC;
  std::string target{};  // a rejuvenated service, "output_driver" or "plant"
  Nanos at{0};           // flight time (after the alignment) from which it is armed
};

struct Mission {
  std::uint32_t index = 0;
  std::vector<Planned> faults{};  // by time; a terminal one last
};

// The whole campaign from the seed: missions of up to `per_mission` faults, `injections` in all, every
// (kind, where) pair drawn in turn from a seeded shuffle; terminal faults about one in ten. In real time
// (`realtime`) StallPlant is not drawn: there the plant is the world, not a lockstep link — stopped for 1 s and
// continued, it integrates the missed second at once with the motors held (plant/app run_realtime catches up with
// the clock), a 1 s flight without control that no recovery of the software can prevent (flown: max V 10.4).
[[nodiscard]] std::vector<Mission> plan(std::uint64_t seed, std::uint32_t injections, std::uint32_t per_mission,
                                        const std::vector<std::string>& rejuvenated, Nanos flight,
                                        bool realtime = false);

// What became of one planned fault.
struct Outcome {
  std::uint32_t mission = 0;
  Planned fault{};
  bool fired = false;        // false: its phase or a target never came in its window (not an injection)
  double fired_at_s = 0;     // flight time
  std::string path{};        // how the kernel recovered: rollback, fallback, cold restart, clean stop, ...
  bool recovered = false;
  bool unsafe = false;       // max V >= 1, or the mission not completed where it should
  bool leaked = false;       // its mission left fds, children or RSS above the baseline
  bool hung = false;         // its mission exceeded the wall-clock bound
  // The recovery's real duration [ms]: from the injection to the first control update routed after the first
  // rollback or cold restart that followed it (the vehicle controlled again), on the monotonic clock; < 0 when
  // none came (a fault that needed no rollback, a terminal one, a mission that ended first). In real time this
  // is what the vehicle lived through.
  double recovery_ms = -1;
  std::string note{};
  // Why it could not be judged: the next fault or the mission's end came before its target was seen back (an
  // incarnation the fault did not hit, alive). Empty: judged. Neither recovered nor a failure.
  std::string not_judged{};
};

// What a fault's verdict is taken from, when its target is back, 10 s of flight after it fired, when the next
// fault is about to fire, or when the mission has ended.
struct VerdictInput {
  FaultKind kind = FaultKind::KillLive;
  std::string target{};
  std::string path{};           // the recovery path since it fired (recovery_path)
  bool back = false;            // its target seen back: an incarnation it did not hit, alive (StallPlant: the plant)
  bool ended = false;           // the mission has ended
  bool next_fault = false;      // the next fault is about to fire
  bool stopped = false;         // the run has a stop reason (it is ending for something)
  std::uint32_t keep = 2;       // sr.keep_generations
  std::size_t others_at_fire = 0;  // generations in the store the fault did not hit, when it fired
  double max_v = 0;             // the flight's max V now, and when it fired
  double max_v_at_fire = 0;
};
struct Verdict {
  bool recovered = false;
  bool unsafe = false;
  std::string not_judged{};  // why not (Outcome::not_judged); empty: judged
  std::string note{};        // appended to the outcome's note
};
// The verdict (docs/design.md §7 "Faults"): recovered once the target is back and the run goes on; not judged when
// the next fault or the mission's end comes before it is back; not recovered when 10 s of flight pass without it,
// or when a cold restart followed the loss of one image although another generation was in the store; unsafe when
// max V crossed 1 after it fired.
[[nodiscard]] Verdict judge(const VerdictInput& in);

struct JobConfig {
  std::filesystem::path graph{};
  std::uint32_t dds_domain = 120;
  int cpu = 0;
  Nanos mission_wall_bound{std::chrono::seconds{300}};
  std::filesystem::path log{};  // the kernels' log lines
  // What a checkpoint or rollback costs the flight (docs/design.md §6). Measured by default here: a fault that stalls a
  // resume or forces a fallback costs the vehicle its real duration, which is what the campaign judges.
  kernel::KernelOptions::Charge charge = kernel::KernelOptions::Charge::Measured;
  // Real time (`rejuv faults --realtime`): the kernel's clock is CLOCK_MONOTONIC and the graph's real-time plan
  // (its `realtime` section: SCHED_FIFO, pinning) applies, as in `rejuv run --realtime`; `cpu` is then not
  // pinned to (the plan places the processes). A recovery costs the vehicle what it lasts, nothing is charged.
  bool realtime = false;
};

// Flies `missions` in this process, one after another. Returns every outcome; the mission-level leak and
// hang checks are applied to the outcomes of their mission.
[[nodiscard]] std::vector<Outcome> run_job(const JobConfig& config, const std::vector<Mission>& missions);

// One outcome per line (tab-separated; the job processes hand them to the parent).
[[nodiscard]] std::string encode(const Outcome& o);
[[nodiscard]] bool decode(std::string_view line, Outcome& o);

}  // namespace rejuv::cli::faults
