// The real rejuv_plant process (docs/design.md §2, §6; jMAVSim over sockets in paper §VI-A) driven by this test
// acting as a minimal kernel over DDS. Every plant is a sys::ChildProcess: killed and reaped on every path
// out of a test, failures included.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <deque>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "dds_test_support.hpp"
#include "rejuv/dds/dds.hpp"
#include "rejuv/dds/plant_topics.hpp"
#include "rejuv/plant/quadrotor.hpp"
#include "rejuv/sys/process.hpp"

namespace rejuv::dds {
namespace {

using namespace std::chrono_literals;
namespace pt = plant_topics;
using test_support::kLiveness;
using test_support::readable_within;

const std::string kPlant = std::string(REJUV_BINARY_DIR) + "/bin/rejuv_plant";
constexpr std::uint64_t kStepNs = 4'000'000;  // --step-ms 4 (the default)

std::vector<std::string> plant_args(std::uint64_t seed, std::vector<std::string> extra = {}) {
  // No pre-flight alignment: these tests fly (or step) from the first step.
  std::vector<std::string> args{"--domain", std::to_string(test_support::test_domain().value()), "--seed",
                                std::to_string(seed), "--align-s", "0"};
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

// The plant's stdout/stderr go to ours (or stderr to `stderr_fd`), so its messages appear in the test log.
sys::ChildProcess spawn_plant(std::vector<std::string> args, int stderr_fd = STDERR_FILENO) {
  auto child =
      sys::spawn(sys::SpawnSpec{.executable = kPlant,
                                .args = std::move(args),
                                .env = {"CYCLONEDDS_URI=" + test_support::kCycloneUri},
                                .fds = {{STDOUT_FILENO, STDOUT_FILENO}, {STDERR_FILENO, stderr_fd}}});
  REJUV_ASSERT(child.has_value(), "spawn rejuv_plant (is it built?)");
  return std::move(*child);
}

// Waits (bounded) for the plant to exit and reaps it; nullopt if it is still running at the bound.
std::optional<sys::ExitStatus> wait_exit(sys::ChildProcess& plant) {
  if (!readable_within(plant.pidfd(), kLiveness)) return std::nullopt;
  auto status = plant.wait();
  if (!status) return std::nullopt;
  return *status;
}

double hover_level() {
  return plant::QuadParams::jmavsim_default().hover_level();
}

// The kernel side of the lockstep protocol (plant_topics.hpp), reduced to what the tests need: it records
// every sample the plant publishes (in its SimSteps and on their own topics), answers each SimStep with an
// ack that carries the actuator outputs (or with the outputs on their own topic first).
class MinimalKernel {
 public:
  // Readers first with sim_step last, writers with sim_step_ack last (the protocol's creation order; the
  // members are initialised in declaration order). A reader per row of the step table, as the kernel's
  // adapter has: whatever sensors the plant has, every sample it publishes on its own topic is counted.
  explicit MinimalKernel(DomainId domain)
      : participant_(make_participant(domain)),
        samples_(sample_readers(participant_)),
        sim_step_(reader(participant_, pt::kSimStep)),
        actuators_(writer(participant_, pt::kActuatorOutputs)),
        ack_(writer(participant_, pt::kSimStepAck)) {}

  // Both sides matched (bounded).
  [[nodiscard]] bool connect() const {
    return sim_step_.wait_for_writers(1, kLiveness).has_value() &&
           ack_.wait_for_readers(1, kLiveness).has_value() &&
           actuators_.wait_for_readers(1, kLiveness).has_value();
  }

  // The next SimStep, once every sample it counts has arrived (DDS orders per writer only); nullopt when
  // the plant exited or the bound passed.
  std::optional<rejuv_msg_SimStep> next_step(const sys::ChildProcess& plant) {
    const auto deadline = std::chrono::steady_clock::now() + kLiveness;
    while (std::chrono::steady_clock::now() < deadline) {
      collect();
      auto n = sim_step_.take_as<rejuv_msg_SimStep>([&](const rejuv_msg_SimStep& s) {
        steps_.push_back(s);
        for (const auto& g : pt::step_kind_of<rejuv_msg_SensorGyro>().samples(s)) gyro.push_back(g);
        for (const auto& a : pt::step_kind_of<rejuv_msg_SensorAccel>().samples(s)) accel.push_back(a);
        truth.push_back(s.ground_truth);
        in_steps_ += pt::samples_in(s);
      });
      REJUV_ASSERT(n.has_value(), "take sim_step");
      if (!steps_.empty() && samples_on_topics() >= steps_.front().samples_published) {
        const rejuv_msg_SimStep s = steps_.front();
        steps_.pop_front();
        return s;
      }
      // Any sample may complete the step: wake on all of them (level-triggered poll, bounded slices).
      std::vector<pollfd> fds;
      for (const Reader& r : samples_) fds.push_back(pollfd{.fd = r.ready_fd(), .events = POLLIN, .revents = 0});
      fds.push_back(pollfd{.fd = sim_step_.ready_fd(), .events = POLLIN, .revents = 0});
      const std::size_t i = fds.size();
      fds.push_back(pollfd{.fd = plant.pidfd(), .events = POLLIN, .revents = 0});
      (void)::poll(fds.data(), fds.size(), 100);
      if ((fds[i].revents & POLLIN) != 0) {  // the plant exited: whatever it sent has arrived or never will
        collect();
        return std::nullopt;
      }
    }
    return std::nullopt;
  }

  // Samples that came on their own topics (what SimStep.samples_published counts), and in the steps.
  [[nodiscard]] std::uint64_t samples_on_topics() const { return on_topics_; }
  [[nodiscard]] std::uint64_t samples_in_steps() const { return in_steps_; }

  enum class Outputs : std::uint8_t { InAck, OnTopic };
  // The ack of `step` with actuator outputs at `level` on every motor: in the ack, or on their own topic
  // before it (what the kernel does with the outputs an ack cannot hold).
  [[nodiscard]] bool ack(const rejuv_msg_SimStep& step, double level, std::uint64_t charged_ns = 0,
                         Outputs outputs = Outputs::InAck) {
    rejuv_msg_ActuatorOutputs u{};
    u.timestamp_ns = step.time_ns;
    for (double& m : u.motor) m = level;
    rejuv_msg_SimStepAck a{};
    a.step = step.step;
    a.time_ns = step.time_ns;
    a.charged_ns = charged_ns;
    if (outputs == Outputs::OnTopic) {
      if (!actuators_.write_value(u)) return false;
      ++outputs_published_;
    } else {
      a.outputs[a.outputs_count++] = u;
    }
    a.outputs_published = outputs_published_;
    return ack_.write_value(a).has_value();
  }

  // Runs `count` steps at hover; the steps seen, in order.
  std::vector<rejuv_msg_SimStep> run_hover(const sys::ChildProcess& plant, std::size_t count) {
    std::vector<rejuv_msg_SimStep> seen;
    for (std::size_t i = 0; i < count; ++i) {
      auto s = next_step(plant);
      if (!s) break;
      seen.push_back(*s);
      if (!ack(*s, hover_level())) break;
    }
    return seen;
  }

  // Takes every sample that has arrived.
  void collect() {
    const auto counted = [&](DdsResult<std::size_t> n) {
      REJUV_ASSERT(n.has_value(), "take");
      on_topics_ += *n;
    };
    pt::for_each_step_kind([&](std::size_t row, const auto& kind) {
      using T = typename std::remove_cvref_t<decltype(kind.topic)>::type;
      counted(samples_[row].take_as<T>([&](const T& sample) {
        if constexpr (std::is_same_v<T, rejuv_msg_SensorGyro>) gyro.push_back(sample);
        if constexpr (std::is_same_v<T, rejuv_msg_SensorAccel>) accel.push_back(sample);
        if constexpr (std::is_same_v<T, rejuv_msg_GroundTruth>) truth.push_back(sample);
      }));
    });
  }

  std::vector<rejuv_msg_SensorGyro> gyro;
  std::vector<rejuv_msg_SensorAccel> accel;
  std::vector<rejuv_msg_GroundTruth> truth;

 private:
  static Participant make_participant(DomainId domain) {
    test_support::use_loopback_config();
    auto p = Participant::create(domain);
    REJUV_ASSERT(p.has_value(), "participant");
    return std::move(*p);
  }
  template <class T>
  static Reader reader(const Participant& participant, pt::Topic<T> topic) {
    // Deep enough to hold a whole run: the test collects between steps.
    auto r = Reader::create(participant, topic.name, pt::type_of(topic), EndpointQos{.history_depth = 4096});
    REJUV_ASSERT(r.has_value(), "reader");
    return std::move(*r);
  }
  static std::vector<Reader> sample_readers(const Participant& participant) {
    std::vector<Reader> readers;
    pt::for_each_step_kind(
        [&](std::size_t /*row*/, const auto& kind) { readers.push_back(reader(participant, kind.topic)); });
    return readers;
  }
  template <class T>
  static Writer writer(const Participant& participant, pt::Topic<T> topic) {
    auto w = Writer::create(participant, topic.name, pt::type_of(topic));
    REJUV_ASSERT(w.has_value(), "writer");
    return std::move(*w);
  }

  Participant participant_;
  std::vector<Reader> samples_;  // by row of the step table (pt::kStepSamples)
  Reader sim_step_;
  Writer actuators_, ack_;
  std::deque<rejuv_msg_SimStep> steps_;
  std::uint64_t on_topics_ = 0, in_steps_ = 0;
  std::uint64_t outputs_published_ = 0;
};

class PlantProcessTest : public ::testing::Test {
 protected:
  void SetUp() override { test_support::use_loopback_config(); }
  void TearDown() override {
    // Every plant was reaped by its ChildProcess; nothing of this test may outlive it.
    auto children = sys::count_children(::getpid());
    ASSERT_TRUE(children.has_value());
    EXPECT_EQ(*children, 0);
  }
};

TEST_F(PlantProcessTest, Lockstep_Steps_ConsecutiveWithExactTimes) {
  MinimalKernel kernel(test_support::test_domain());
  sys::ChildProcess plant = spawn_plant(plant_args(3, {"--ack-timeout-ms", "20000"}));
  ASSERT_TRUE(kernel.connect());

  const auto steps = kernel.run_hover(plant, 50);
  ASSERT_EQ(steps.size(), 50U);
  for (std::uint64_t k = 0; k < steps.size(); ++k) {
    EXPECT_EQ(steps[k].step, k);
    EXPECT_EQ(steps[k].time_ns, (k + 1) * kStepNs);  // each step advances exactly --step-ms
  }
  ASSERT_TRUE(plant.signal(SIGTERM).has_value());
  const auto status = wait_exit(plant);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->success()) << status->to_string();
}

// The gyro samples and ground truth of one lockstep run of `steps` steps (next_step waits for every sample
// a step counts, so the record is complete).
struct RunRecord {
  std::vector<rejuv_msg_SensorGyro> gyro;
  std::vector<rejuv_msg_GroundTruth> truth;
};

RunRecord record_run(std::uint64_t seed, std::size_t steps) {
  MinimalKernel kernel(test_support::test_domain());
  sys::ChildProcess plant = spawn_plant(plant_args(seed, {"--ack-timeout-ms", "20000"}));
  RunRecord record;
  if (!kernel.connect()) return record;
  if (kernel.run_hover(plant, steps).size() != steps) return record;
  record.gyro = kernel.gyro;
  record.truth = kernel.truth;
  (void)plant.signal(SIGTERM);
  (void)wait_exit(plant);
  return record;
}

TEST_F(PlantProcessTest, Lockstep_SameSeed_SameSensorSamples) {
  const RunRecord a = record_run(11, 30);
  const RunRecord b = record_run(11, 30);
  ASSERT_EQ(a.gyro.size(), 30U);  // 250 Hz gyro, one per 4 ms step
  ASSERT_EQ(a.gyro.size(), b.gyro.size());
  for (std::size_t i = 0; i < a.gyro.size(); ++i) {
    EXPECT_EQ(std::memcmp(&a.gyro[i], &b.gyro[i], sizeof a.gyro[i]), 0) << "gyro sample " << i;
  }
  ASSERT_EQ(a.truth.size(), b.truth.size());
  for (std::size_t i = 0; i < a.truth.size(); ++i) {
    EXPECT_EQ(std::memcmp(&a.truth[i], &b.truth[i], sizeof a.truth[i]), 0) << "ground truth " << i;
  }
}

TEST_F(PlantProcessTest, Lockstep_OtherSeed_OtherSensorSamples) {
  const RunRecord a = record_run(11, 5);
  const RunRecord b = record_run(12, 5);
  ASSERT_FALSE(a.gyro.empty());
  ASSERT_FALSE(b.gyro.empty());
  EXPECT_NE(std::memcmp(&a.gyro[0], &b.gyro[0], sizeof a.gyro[0]), 0);
}

// 60 steps at full throttle, the outputs sent `how`: the plant applies them and the vehicle climbs.
void expect_climb_at_full_throttle(MinimalKernel::Outputs how) {
  MinimalKernel kernel(test_support::test_domain());
  sys::ChildProcess plant = spawn_plant(plant_args(3, {"--ack-timeout-ms", "20000"}));
  ASSERT_TRUE(kernel.connect());
  for (int i = 0; i < 60; ++i) {
    const auto s = kernel.next_step(plant);
    ASSERT_TRUE(s.has_value());
    ASSERT_TRUE(kernel.ack(*s, 1.0, 0, how));
  }
  ASSERT_TRUE(kernel.next_step(plant).has_value());  // its samples have all arrived
  ASSERT_EQ(kernel.truth.size(), 61U);
  EXPECT_LT(kernel.truth.back().p_N_m[2], -3.05);  // NED: climbing makes z more negative
}

TEST_F(PlantProcessTest, Lockstep_FullThrottle_VehicleClimbs) {
  expect_climb_at_full_throttle(MinimalKernel::Outputs::InAck);
}

// Outputs the ack could not hold come on their own topic first: the plant waits for them and applies them.
TEST_F(PlantProcessTest, Lockstep_OutputsOnTheirTopic_WaitedForAndApplied) {
  expect_climb_at_full_throttle(MinimalKernel::Outputs::OnTopic);
}

// Real time charged for a checkpoint or rollback passes in the world too (docs/design.md §6), and a step it stretches
// has more samples than its SimStep holds: the rest come on their own topics, the step waits for them, and
// none is lost or doubled.
TEST_F(PlantProcessTest, Lockstep_ChargedTime_AddedToSimulatedTimeExtraSamplesOnTheirTopics) {
  MinimalKernel kernel(test_support::test_domain());
  sys::ChildProcess plant = spawn_plant(plant_args(3, {"--ack-timeout-ms", "20000"}));
  ASSERT_TRUE(kernel.connect());
  const auto s0 = kernel.next_step(plant);
  ASSERT_TRUE(s0.has_value());
  EXPECT_EQ(s0->samples_published, 0U);  // a usual step travels whole
  ASSERT_TRUE(kernel.ack(*s0, hover_level(), 20'000'000));  // 20 ms charged: the next step is 24 ms long
  const auto s1 = kernel.next_step(plant);
  ASSERT_TRUE(s1.has_value());
  EXPECT_EQ(s1->step, 1U);
  EXPECT_EQ(s1->time_ns, 2 * kStepNs + 20'000'000);
  EXPECT_GT(s1->samples_published, 0U);
  EXPECT_EQ(kernel.samples_on_topics(), s1->samples_published);  // next_step waited for every one
  std::vector<std::uint64_t> stamps;
  for (const rejuv_msg_SensorGyro& g : kernel.gyro) stamps.push_back(g.timestamp_ns);
  std::sort(stamps.begin(), stamps.end());
  ASSERT_EQ(stamps.size(), 7U);  // 250 Hz over 28 ms, each once
  for (std::size_t i = 1; i < stamps.size(); ++i) EXPECT_EQ(stamps[i] - stamps[i - 1], kStepNs) << i;
}

TEST_F(PlantProcessTest, Lockstep_AcksStop_ExitsKernelLost) {
  MinimalKernel kernel(test_support::test_domain());
  sys::ChildProcess plant = spawn_plant(plant_args(3, {"--ack-timeout-ms", "300"}));
  ASSERT_TRUE(kernel.connect());
  ASSERT_EQ(kernel.run_hover(plant, 3).size(), 3U);
  ASSERT_TRUE(kernel.next_step(plant).has_value());  // step 3 arrives, and is never acknowledged
  const auto status = wait_exit(plant);
  ASSERT_TRUE(status.has_value()) << "the plant hangs without acks";
  EXPECT_EQ(status->how, sys::ExitStatus::How::Exited);
  EXPECT_EQ(status->value, 3) << status->to_string();
}

TEST_F(PlantProcessTest, Lockstep_NoKernel_ExitsKernelLost) {
  sys::ChildProcess plant = spawn_plant(plant_args(3, {"--connect-timeout-ms", "200"}));
  const auto status = wait_exit(plant);
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->how, sys::ExitStatus::How::Exited);
  EXPECT_EQ(status->value, 3) << status->to_string();
}

TEST_F(PlantProcessTest, Lockstep_Sigterm_ExitsZeroAndNothingLeft) {
  MinimalKernel kernel(test_support::test_domain());
  sys::ChildProcess plant = spawn_plant(plant_args(3, {"--ack-timeout-ms", "20000"}));
  ASSERT_TRUE(kernel.connect());
  ASSERT_EQ(kernel.run_hover(plant, 5).size(), 5U);
  const pid_t pid = plant.pid();
  ASSERT_TRUE(plant.signal(SIGTERM).has_value());
  const auto status = wait_exit(plant);
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->how, sys::ExitStatus::How::Exited) << status->to_string();
  EXPECT_EQ(status->value, 0);
  EXPECT_EQ(::kill(pid, 0), -1);  // reaped: the pid is gone
  EXPECT_EQ(errno, ESRCH);
}

TEST_F(PlantProcessTest, Lockstep_SigintWhileWaitingForKernel_ExitsZero) {
  // Only a sim_step reader: the plant sees a half-present kernel and keeps waiting for the rest.
  auto participant = Participant::create(test_support::test_domain());
  ASSERT_TRUE(participant.has_value());
  auto steps = Reader::create(*participant, pt::kSimStep.name, pt::type_of(pt::kSimStep));
  ASSERT_TRUE(steps.has_value());
  sys::ChildProcess plant = spawn_plant(plant_args(3, {"--connect-timeout-ms", "60000"}));
  // Its sim_step writer exists, so it has blocked SIGINT/SIGTERM (before any DDS entity): a signal now is
  // an orderly request, not the default action.
  ASSERT_TRUE(steps->wait_for_writers(1, kLiveness).has_value());
  ASSERT_TRUE(plant.signal(SIGINT).has_value());
  const auto status = wait_exit(plant);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->success()) << status->to_string();
}

TEST_F(PlantProcessTest, Lockstep_Duration_ExitsAfterItsLastStep) {
  MinimalKernel kernel(test_support::test_domain());
  sys::ChildProcess plant = spawn_plant(plant_args(3, {"--duration", "0.04", "--ack-timeout-ms", "20000"}));
  ASSERT_TRUE(kernel.connect());
  const auto steps = kernel.run_hover(plant, 100);  // ends when the plant exits
  ASSERT_EQ(steps.size(), 10U);                     // 40 ms / 4 ms
  EXPECT_EQ(steps.back().time_ns, 40'000'000U);
  EXPECT_EQ(kernel.samples_on_topics(), steps.back().samples_published);  // the count is exact
  EXPECT_GT(kernel.samples_in_steps(), 2 * steps.size());  // gyro, accel and ground truth in every step
  const auto status = wait_exit(plant);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->success()) << status->to_string();
}

TEST_F(PlantProcessTest, Realtime_Sigterm_ExitsZero) {
  MinimalKernel kernel(test_support::test_domain());
  sys::ChildProcess plant = spawn_plant(plant_args(3, {"--clock", "realtime"}));
  // Running: ground truth flows without any ack.
  const auto deadline = std::chrono::steady_clock::now() + kLiveness;
  while (kernel.truth.empty() && std::chrono::steady_clock::now() < deadline) {
    (void)readable_within(plant.pidfd(), 50ms);
    kernel.collect();
  }
  ASSERT_FALSE(kernel.truth.empty());
  ASSERT_TRUE(plant.signal(SIGTERM).has_value());
  const auto status = wait_exit(plant);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->success()) << status->to_string();
}

TEST_F(PlantProcessTest, Realtime_Duration_ExitsZero) {
  sys::ChildProcess plant = spawn_plant(plant_args(3, {"--clock", "realtime", "--duration", "0.2"}));
  const auto status = wait_exit(plant);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->success()) << status->to_string();
}

// Reads what the child wrote to the pipe until EOF (it has exited).
std::string read_all(int fd) {
  std::string out;
  std::array<char, 512> buf{};
  for (;;) {
    const ssize_t n = ::read(fd, buf.data(), buf.size());
    if (n <= 0) return out;
    out.append(buf.data(), static_cast<std::size_t>(n));
  }
}

TEST_F(PlantProcessTest, BadFlag_ExitsTwoNamingTheFlag) {
  std::array<int, 2> pipe_fds{};
  ASSERT_EQ(::pipe2(pipe_fds.data(), O_CLOEXEC), 0);
  sys::UniqueFd read_end(pipe_fds[0]);
  sys::UniqueFd write_end(pipe_fds[1]);
  sys::ChildProcess plant = spawn_plant({"--step-ms", "fast"}, write_end.get());
  write_end.reset();
  const auto status = wait_exit(plant);
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->how, sys::ExitStatus::How::Exited);
  EXPECT_EQ(status->value, 2);
  EXPECT_NE(read_all(read_end.get()).find("--step-ms"), std::string::npos);
}

TEST_F(PlantProcessTest, Help_ExitsZero) {
  sys::ChildProcess plant = spawn_plant({"--help"});
  const auto status = wait_exit(plant);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->success()) << status->to_string();
}

}  // namespace
}  // namespace rejuv::dds
