// rejuv_plant: the outside world of a Rejuv run (docs/design.md §2, §9) — the quadrotor, its sensors and wind in
// their own process, talking DDS to the kernel the way jMAVSim talks to PX4 over sockets in paper §VI-A. The
// kernel sees only DDS samples; it cannot reach into the physics. Protocol: rejuv/dds/plant_topics.hpp and
// docs/protocol.md ("Lockstep with the plant").
#include <signal.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <iterator>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "os.hpp"
#include "rejuv/dds/dds.hpp"
#include "rejuv/dds/plant_topics.hpp"
#include "rejuv/plant_app/options.hpp"
#include "rejuv/plant_app/plant_sim.hpp"
#include "rejuv/sys/event.hpp"

namespace rejuv::plant_app {
namespace {

namespace topics = dds::plant_topics;

// A kernel that charges more than this for one step is broken, not checkpointing: refuse rather than run
// physics for hours on its behalf.
constexpr Nanos kMaxChargePerStep = std::chrono::seconds{60};
// The kernel may publish a few actuator outputs per step; the reader must hold them all until the ack.
constexpr std::int32_t kActuatorDepth = 64;

void log(const std::string& line) {
  std::fprintf(stderr, "rejuv_plant: %s\n", line.c_str());
}

std::string seconds_text(Nanos t) {
  return std::to_string(to_seconds(t).count()) + " s";
}

// Every DDS endpoint of the plant. Readers first, then writers, sim_step last: the kernel's discovery sees
// them in that order (plant_topics.hpp, step 1).
// The DDS partition of every endpoint: the run's (--run-id), else "" (the default partition).
std::string partition_of(const PlantOptions& o) { return o.run_id ? dds::run_partition(*o.run_id) : std::string(); }
// ", partition rejuv.<id>" for a log line, or "" in the default partition.
std::string in_partition(const PlantOptions& o) {
  const std::string p = partition_of(o);
  return p.empty() ? std::string() : ", partition " + p;
}

struct Endpoints {
  dds::Participant participant;
  dds::Reader actuator_outputs;
  std::optional<dds::Reader> ack;  // lockstep only
  std::vector<dds::Writer> samples;  // by row of the step table (plant_topics.hpp, kStepSamples)
  std::optional<dds::Writer> sim_step;  // lockstep only

  // Every endpoint in `partition` (empty: the default partition), its topic named as `naming` says
  // (plant_topics::dds_topic, as the kernel's bridge names them).
  static dds::DdsResult<Endpoints> open(dds::DomainId domain, const std::string& partition, DdsNaming naming,
                                        ClockMode clock);
};

// A step that the kernel charged for a checkpoint or rollback (docs/design.md §6) covers more than one sensor period:
// the writers keep enough history that a reliable reader loses none of a long step's samples.
constexpr std::int32_t kSensorDepth = 256;
template <class T>
dds::DdsResult<dds::Writer> make_writer(const dds::Participant& p, const std::string& partition, DdsNaming naming,
                                        topics::Topic<T> topic) {
  const msgs::DdsTopic t = topics::dds_topic(topic, naming);
  return dds::Writer::create(p, t.name, *t.type, dds::EndpointQos{.history_depth = kSensorDepth, .partition = partition});
}
template <class T>
dds::DdsResult<dds::Reader> make_reader(const dds::Participant& p, DdsNaming naming, topics::Topic<T> topic,
                                        const dds::EndpointQos& qos) {
  const msgs::DdsTopic t = topics::dds_topic(topic, naming);
  return dds::Reader::create(p, t.name, *t.type, qos);
}

dds::DdsResult<Endpoints> Endpoints::open(dds::DomainId domain, const std::string& partition, DdsNaming naming,
                                          ClockMode clock) {
  const bool lockstep = clock == ClockMode::Lockstep;
  auto participant = dds::Participant::create(domain);
  if (!participant) return fail(participant.error());
  auto actuators = make_reader(*participant, naming, topics::kActuatorOutputs,
                               dds::EndpointQos{.history_depth = kActuatorDepth, .partition = partition});
  if (!actuators) return fail(actuators.error());
  std::optional<dds::Reader> ack;
  if (lockstep) {
    auto r = make_reader(*participant, naming, topics::kSimStepAck, dds::EndpointQos{.partition = partition});
    if (!r) return fail(r.error());
    ack = std::move(*r);
  }
  // A writer per kind of sample a step carries: where what does not fit (lockstep) or everything (realtime) goes.
  std::vector<dds::Writer> samples;
  dds::DdsResult<void> made;
  topics::for_each_step_kind([&](std::size_t /*row*/, const auto& kind) {
    if (!made) return;
    auto w = make_writer(*participant, partition, naming, kind.topic);
    if (!w) made = fail(w.error());
    else samples.push_back(std::move(*w));
  });
  if (!made) return fail(made.error());
  std::optional<dds::Writer> sim_step;
  if (lockstep) {
    auto w = make_writer(*participant, partition, naming, topics::kSimStep);
    if (!w) return fail(w.error());
    sim_step = std::move(*w);
  }
  return Endpoints{.participant = std::move(*participant),
                   .actuator_outputs = std::move(*actuators),
                   .ack = std::move(ack),
                   .samples = std::move(samples),
                   .sim_step = std::move(sim_step)};
}

// How a wait of the lockstep loop ended, when it did not get what it waited for: the process's exit code.
using ExitCode = int;

class PlantProcess {
 public:
  PlantProcess(const PlantOptions& options, sys::SignalFd signals, sys::Epoll epoll, Endpoints endpoints)
      : options_(options),
        signals_(std::move(signals)),
        epoll_(std::move(epoll)),
        io_(std::move(endpoints)),
        sim_(PlantSimConfig{
            .seed = options.seed,
            .start_N_m = options.start_N_m,
            .wind = plant::WindParams{.mean_N_m_s = plant::mean_wind_N(options.wind_mean_m_s, options.wind_toward_deg),
                                      .gust_std_m_s = options.wind_gust_m_s,
                                      .gust_time_constant_s = plant::WindParams{}.gust_time_constant_s},
            .physics_period = std::chrono::milliseconds{1},
            .alignment = options.alignment}) {}

  ExitCode run() {
    switch (options_.clock) {
      case ClockMode::Lockstep: return run_lockstep();
      case ClockMode::Realtime: return run_realtime();
    }
    return kExitFailure;
  }

 private:
  [[nodiscard]] bool done() const { return options_.duration > Nanos{0} && sim_.now() >= options_.duration; }

  ExitCode dds_failure(const dds::DdsError& e) const {
    log("DDS failure: " + e.to_string());
    return kExitFailure;
  }

  // A pending SIGINT/SIGTERM, if any (consumed).
  [[nodiscard]] Result<std::optional<int>, ExitCode> pending_signal() const {
    auto sig = signals_.read();
    if (!sig) {
      log(sig.error().to_string());
      return fail(kExitFailure);
    }
    return *sig;
  }

  // Lockstep wakes on the ack (and signals) only: the step's actuator outputs were written before it and are
  // taken with it, so the plant wakes once per step, not once per output. When the ack overtook an output
  // (DDS orders per writer only), the outputs reader is watched too until the ack's count is met.
  void watch_outputs(bool watch) {
    if (watch == watching_outputs_) return;
    watching_outputs_ = watch;
    io_.actuator_outputs.set_signalling(watch);  // unwatched, a sample costs no eventfd write or read
    const int fd = io_.actuator_outputs.ready_fd();
    const std::uint64_t token = static_cast<std::uint64_t>(fd);
    if (auto ok = watch ? epoll_.add(fd, token) : epoll_.remove(fd); !ok) log(ok.error().to_string());
  }

  // Sleeps until one of the plant's watched fds (ack, signals, maybe outputs) is readable or `timeout` passed.
  [[nodiscard]] Result<void, ExitCode> wait_any(Nanos timeout) const {
    std::array<sys::Event, 4> events{};
    if (auto n = epoll_.wait(events, std::max(Nanos{0}, timeout)); !n) {
      log(n.error().to_string());
      return fail(kExitFailure);
    }
    return {};
  }

  [[nodiscard]] dds::DdsResult<void> publish_sensors(const std::vector<SensorMessage>& messages) {
    for (const SensorMessage& m : messages) {
      auto ok = std::visit([&](const auto& s) { return publish_sample(s); }, m);
      if (!ok) return ok;
      ++samples_published_;
    }
    return {};
  }

  // On the sample's own topic (the writer of its row of the step table).
  template <class T>
  [[nodiscard]] dds::DdsResult<void> publish_sample(const T& sample) {
    return io_.samples[topics::step_row_of<T>()].write_value(sample);
  }

  [[nodiscard]] dds::DdsResult<void> publish_ground_truth() {
    if (auto ok = publish_sample(sim_.ground_truth()); !ok) return ok;
    ++samples_published_;
    return {};
  }

  // The last command applied is held until the next (docs/design.md §6).
  void apply(const rejuv_msg_ActuatorOutputs& u) {
    if (!sim_.set_motor_command(u) && !warned_non_finite_) {
      log("ignoring actuator outputs with a non-finite motor command (holding the previous one)");
      warned_non_finite_ = true;
    }
  }

  // Applies the actuator outputs that came on their own topic, as they arrive.
  [[nodiscard]] dds::DdsResult<void> take_actuator_outputs() {
    auto n = io_.actuator_outputs.take_as<rejuv_msg_ActuatorOutputs>([&](const rejuv_msg_ActuatorOutputs& u) {
      ++outputs_received_;
      apply(u);
    });
    if (!n) return fail(n.error());
    return {};
  }

  // ---- lockstep (docs/design.md §6; protocol in plant_topics.hpp) ----

  ExitCode run_lockstep() {
    if (auto connected = connect(); !connected) return connected.error();
    Nanos charged{0};
    for (std::uint64_t k = 0;; ++k) {
      batch_.clear();
      overflow_.clear();
      sim_.advance(options_.step + charged, batch_);
      // The step carries its samples and the ground truth; only what does not fit goes out on its own.
      rejuv_msg_SimStep step{};
      pack_step(batch_, sim_.ground_truth(), step, overflow_);
      if (auto ok = publish_sensors(overflow_); !ok) return dds_failure(ok.error());
      step.step = k;
      step.time_ns = static_cast<std::uint64_t>(sim_.now().count());
      step.samples_published = samples_published_;
      if (auto ok = io_.sim_step->write_value(step); !ok) return dds_failure(ok.error());

      auto ack = wait_for_step_done(step);
      if (!ack) return ack.error();
      if (ack->charged_ns > static_cast<std::uint64_t>(kMaxChargePerStep.count())) {
        log("step " + std::to_string(k) + ": the kernel charged " + std::to_string(ack->charged_ns) +
            " ns, more than the " + seconds_text(kMaxChargePerStep) + " one step may charge");
        return kExitFailure;
      }
      // Real time spent in checkpoint/rollback passes in the world too, with the motors held (docs/design.md §6).
      charged = Nanos{static_cast<std::int64_t>(ack->charged_ns)};
      if (done()) {
        log("duration reached after step " + std::to_string(k) + " (t = " + seconds_text(sim_.now()) + ")");
        return kExitOk;
      }
    }
  }

  // Waits until the kernel's endpoints are matched with ours: volatile samples written before a match are
  // lost, and losing step 0 would stall the lockstep. SIGINT/SIGTERM end the wait (exit 0).
  Result<void, ExitCode> connect() {
    const Nanos deadline = sys::monotonic_now() + options_.connect_timeout;
    constexpr Nanos kSlice = std::chrono::milliseconds{50};  // how often the signal fd is looked at
    const auto wait_matched = [&](auto&& wait_slice) -> Result<void, ExitCode> {
      for (;;) {
        auto sig = pending_signal();
        if (!sig) return fail(sig.error());
        if (*sig) {
          log("signal " + std::to_string(**sig) + " while connecting; exiting");
          return fail(kExitOk);
        }
        const Nanos left = std::max(Nanos{0}, deadline - sys::monotonic_now());
        auto ok = wait_slice(std::min(kSlice, left));
        if (ok) return {};
        if (ok.error().kind != dds::DdsError::Kind::Timeout) return fail(dds_failure(ok.error()));
        if (left <= kSlice) {
          log("no kernel: its DDS endpoints did not appear within " + seconds_text(options_.connect_timeout) +
              " (domain " + std::to_string(options_.domain) +
              in_partition(options_) + ")");
          return fail(kExitKernelLost);
        }
      }
    };
    if (auto ok = wait_matched([&](Nanos s) { return io_.sim_step->wait_for_readers(1, s); }); !ok) return ok;
    if (auto ok = wait_matched([&](Nanos s) { return io_.ack->wait_for_writers(1, s); }); !ok) return ok;
    return wait_matched([&](Nanos s) { return io_.actuator_outputs.wait_for_writers(1, s); });
  }

  // Step k is done when its ack has arrived and, with it, every actuator output the ack counts on their own
  // topic (DDS orders samples per writer only, so those may trail the ack); then the ack's own outputs, the
  // newest, are applied. Returns the ack, or the exit code: 0 on a signal, kExitKernelLost when
  // --ack-timeout-ms passes first.
  Result<rejuv_msg_SimStepAck, ExitCode> wait_for_step_done(const rejuv_msg_SimStep& step) {
    const Nanos deadline = sys::monotonic_now() + options_.ack_timeout;
    std::optional<rejuv_msg_SimStepAck> ack;
    for (;;) {
      auto n = io_.ack->take_as<rejuv_msg_SimStepAck>([&](const rejuv_msg_SimStepAck& a) {
        if (a.step == step.step) ack = a;  // an ack of another step is stale or a duplicate: ignored
      });
      if (!n) return fail(dds_failure(n.error()));
      if (auto ok = take_actuator_outputs(); !ok) return fail(dds_failure(ok.error()));
      if (ack && outputs_received_ >= ack->outputs_published) {
        watch_outputs(false);
        for (std::size_t i = 0; i < std::min<std::size_t>(ack->outputs_count, std::size(ack->outputs)); ++i) {
          apply(ack->outputs[i]);
        }
        return *ack;
      }
      if (ack && !watching_outputs_) {
        watch_outputs(true);
        continue;  // take once more: an output that came before signalling was on wakes nobody
      }

      auto sig = pending_signal();
      if (!sig) return fail(sig.error());
      if (*sig) {
        log("signal " + std::to_string(**sig) + " at step " + std::to_string(step.step) + "; exiting");
        return fail(kExitOk);
      }
      const Nanos left = deadline - sys::monotonic_now();
      if (left <= Nanos{0}) {
        const std::string what = ack ? "its ack came, but only " + std::to_string(outputs_received_) +
                                           " of the " + std::to_string(ack->outputs_published) +
                                           " actuator outputs it counts"
                                     : "no sim_step_ack";
        log("step " + std::to_string(step.step) + " (t = " + seconds_text(Nanos{step.time_ns}) +
            "): " + what + " within " + seconds_text(options_.ack_timeout) + "; the kernel is gone, exiting");
        return fail(kExitKernelLost);
      }
      if (auto ok = wait_any(left); !ok) return fail(ok.error());
    }
  }

  // ---- realtime (docs/design.md §6): physics follows CLOCK_MONOTONIC in 1 ms ticks, outputs applied on arrival,
  // ground truth every --step-ms ----

  ExitCode run_realtime() {
    constexpr Nanos kTick = std::chrono::milliseconds{1};
    const Nanos start = sys::monotonic_now();
    Nanos next_truth = options_.step;
    for (;;) {
      auto sig = pending_signal();
      if (!sig) return sig.error();
      if (*sig) {
        log("signal " + std::to_string(**sig) + " at t = " + seconds_text(sim_.now()) + "; exiting");
        return kExitOk;
      }
      if (auto ok = take_actuator_outputs(); !ok) return dds_failure(ok.error());
      batch_.clear();
      sim_.advance(kTick, batch_);
      if (auto ok = publish_sensors(batch_); !ok) return dds_failure(ok.error());
      if (sim_.now() >= next_truth) {
        next_truth += options_.step;
        if (auto ok = publish_ground_truth(); !ok) return dds_failure(ok.error());
      }
      if (done()) {
        log("duration reached (t = " + seconds_text(sim_.now()) + ")");
        return kExitOk;
      }
      // After an overrun the deadline has passed and this returns at once: the world catches up.
      os::sleep_until(start + sim_.now());
    }
  }

  PlantOptions options_;
  // Declared before the endpoints so that it is destroyed after them: the signal mask stays in force until
  // Cyclone's threads are gone.
  sys::SignalFd signals_;
  sys::Epoll epoll_;
  Endpoints io_;
  PlantSim sim_;
  std::vector<SensorMessage> batch_;
  std::vector<SensorMessage> overflow_;  // lockstep: the step's samples that its SimStep cannot hold
  std::uint64_t samples_published_ = 0;  // samples published on their own topics (lockstep: for SimStep)
  std::uint64_t outputs_received_ = 0;   // outputs on their own topic, against SimStepAck.outputs_published
  bool watching_outputs_ = false;        // the outputs reader is in epoll (lockstep: only while short)
  bool warned_non_finite_ = false;
};

ExitCode run(std::span<const std::string_view> args) {
  auto command = parse_options(args);
  if (!command) {
    log(command.error());
    return kExitUsage;
  }
  if (std::holds_alternative<ShowHelp>(*command)) {
    std::fputs(usage().data(), stdout);
    return kExitOk;
  }
  const PlantOptions& options = std::get<PlantOptions>(*command);

  // Before the first Cyclone thread exists (Participant::create): every thread inherits the blocked mask, so
  // a SIGTERM can only ever surface here, as a readable fd.
  auto signals = sys::SignalFd::create({SIGINT, SIGTERM});
  if (!signals) {
    log(signals.error().to_string());
    return kExitFailure;
  }
  const std::string partition = partition_of(options);
  auto endpoints = Endpoints::open(dds::DomainId{options.domain}, partition, options.naming, options.clock);
  if (!endpoints) {
    log("DDS failure: " + endpoints.error().to_string());
    return kExitFailure;
  }
  auto epoll = sys::Epoll::create();
  if (!epoll) {
    log(epoll.error().to_string());
    return kExitFailure;
  }
  // Lockstep waits for the ack (PlantProcess::watch_outputs); realtime takes the outputs every tick.
  if (options.clock == ClockMode::Lockstep) endpoints->actuator_outputs.set_signalling(false);
  for (const int fd : {signals->fd(), endpoints->ack ? endpoints->ack->ready_fd() : -1}) {
    if (fd < 0) continue;
    if (auto ok = epoll->add(fd, static_cast<std::uint64_t>(fd)); !ok) {
      log(ok.error().to_string());
      return kExitFailure;
    }
  }
  log(std::string(to_string(options.clock)) + " on domain " + std::to_string(options.domain) +
      in_partition(options) + ", seed " +
      std::to_string(options.seed) + ", hovering at (" + std::to_string(options.start_N_m.x()) + ", " +
      std::to_string(options.start_N_m.y()) + ", " + std::to_string(options.start_N_m.z()) + ") m NED after " +
      seconds_text(options.alignment) + " of alignment at rest");
  PlantProcess process(options, std::move(*signals), std::move(*epoll), std::move(*endpoints));
  return process.run();
}

}  // namespace
}  // namespace rejuv::plant_app

int main(int argc, char** argv) {
  const std::vector<std::string_view> args(argv + 1, argv + argc);
  return rejuv::plant_app::run(args);
}
