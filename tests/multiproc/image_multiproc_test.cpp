// The image store end to end (docs/design.md §7): real kernels, real service processes forking
// real images, lockstep driven by the test (TimeMaster::Manual). Graph: graphs/images.policy.pbtxt and the
// purpose-built services/image_service.cpp (counter, listener, driver, worker). No timing is asserted.
#include <gtest/gtest.h>

#include <filesystem>
#include <malloc.h>
#include <signal.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "graph_fixture.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/sys/sanitizer.hpp"

namespace rejuv::testing {
namespace {

struct ImageGraph {
  std::string counter{};    // extra params of the counter
  std::uint32_t keep = 2;   // sr.keep_generations
  bool worker = false;
  std::string worker_extra{};  // more lines in the worker's entry (`limits { … }`)
  bool hooked = false;         // the `worker` service in the role `hooked` (on_restored) instead
};

std::string param(const std::string& name, double v) {
  return "  params { name: \"" + name + "\" number: " + std::to_string(v) + " }\n";
}
std::string text_param(const std::string& name, const std::string& v) {
  return "  params { name: \"" + name + "\" text: \"" + v + "\" }\n";
}

std::string image_launch(const ImageGraph& g) {
  const auto service = [](const std::string& name, const std::string& role, const std::string& body) {
    return "services {\n  name: \"" + name + "\"\n  executable: \"rejuv_image_test_service\"\n" +
           text_param("role", role) + body + "}\n";
  };
  std::string t = "name: \"images\"\npolicy: \"images.policy.pbtxt\"\nclock: LOCKSTEP\nseed: 1\n";
  t += service("counter", "counter",
               g.counter + "  uses { object: \"numbers\" rights: \"W\" }\n  uses { object: \"verdicts\" rights: \"W\" }\n"
                           "  uses { object: \"checkpoint\" rights: \"W\" }\n  uses { object: \"cycles\" rights: \"RW\" }\n");
  t += service("listener", "listener",
               "  uses { object: \"numbers\" rights: \"R\" }\n  uses { object: \"echoes\" rights: \"W\" }\n");
  t += service("driver", "driver",
               "  rejuvenate: false\n  uses { object: \"numbers\" rights: \"R\" }\n  uses { object: \"echoes\" rights: \"W\" }\n");
  t += service("worker",
               g.hooked   ? "hooked"
               : g.worker ? "worker"
                          : "idle",
               "  uses { object: \"verdicts\" rights: \"W\" }\n" + g.worker_extra);
  t += "sr { enabled: true t_mc_s: 0.3 t_est_s: 3 rho_m: 0.1 rho_s: 0.05 keep_generations: " + std::to_string(g.keep) +
       " box { position_m: 0.5 velocity_m_s: 1 angle_rad: 0.3 rate_rad_s: 2 } restricted_limit_fraction: 0.3 }\n";
  t += "mission { waypoints { north_m: 0 east_m: 0 down_m: -3 } acceptance_radius_m: 0.1 timeout_s: 600 }\n";
  return t;
}

// Records every publication and the broker's queue state at every checkpoint and restore.
class ImageRecorder final : public kernel::Observer {
 public:
  void on_publication(const kernel::Publication& p) override {
    if (latest_only) {  // replace the previous one of the same topic and publisher
      std::erase_if(publications.seen, [&](const Seen& s) { return s.topic == p.name && s.publisher == p.publisher; });
    }
    publications.on_publication(p);
  }
  void on_checkpoint(Generation g, const broker::Broker& b) override {
    if (!latest_only) at_checkpoint[g.value()] = b.snapshot();
  }
  void on_restore(Generation g, const broker::Broker& b) override {
    if (!latest_only) restores.emplace_back(g.value(), b.snapshot());
  }
  // Keep only the latest publication of each topic and publisher and no queue snapshots, so that this test
  // process's memory is the kernel's (the soak checks of ThousandCycles).
  bool latest_only = false;
  Recorder publications;
  std::map<std::uint64_t, broker::BrokerSnapshot> at_checkpoint;
  std::vector<std::pair<std::uint64_t, broker::BrokerSnapshot>> restores;
};

class Images : public ::testing::Test {
 protected:
  void start(const ImageGraph& g) {
    auto loaded = launch::parse_launch(image_launch(g), kGraphs / "images.launch.pbtxt");
    ASSERT_TRUE(loaded.has_value()) << loaded.error().to_string();
    kernel::KernelOptions o = test_options();
    // On stderr when asked (verbose); else kept in a file and shown if the test fails (TearDown): a fallback or
    // a lost image under load is named there.
    o.verbose = std::getenv("REJUV_TEST_LOG") != nullptr;
    o.log = o.verbose ? stderr : log_;
    o.images_by_pages = !fork_only_;
    auto k = kernel::Kernel::create(std::move(*loaded), o, &recorder);
    ASSERT_TRUE(k.has_value()) << k.error().to_string() << "\n" << ::testing::PrintToString(k.error().findings);
    k_ = std::move(*k);
    auto booted = k_->boot();
    ASSERT_TRUE(booted.has_value()) << booted.error().to_string();
  }
  ServiceId id(std::string_view name) const { return *k_->find_service(name); }
  // Steps until `done` holds (or `limit` steps); fails on a stop.
  template <class F>
  void step_until(F done, int limit) {
    for (int i = 0; i < limit && !done(); ++i) {
      auto r = k_->step(k_->now() + std::chrono::milliseconds{4});
      ASSERT_TRUE(r.has_value()) << r.error().to_string();
      ASSERT_FALSE(k_->stop_reason().has_value()) << k_->stop_detail();
    }
    ASSERT_TRUE(done()) << "condition not reached in " << limit << " steps";
  }
  // Records of `topic` published by `who`.
  std::vector<rejuv_msg_SensorBaro> records(std::string_view topic, std::string_view who) const {
    std::vector<rejuv_msg_SensorBaro> out;
    for (const Seen* s : recorder.publications.on(topic)) {
      if (s->publisher == id(who)) out.push_back(Recorder::as<rejuv_msg_SensorBaro>(*s));
    }
    return out;
  }
  // Every echo of a listener: it got every number exactly once, in order, in its own history.
  void expect_exactly_once(std::string_view who) const {
    const auto echoes = records("echoes", who);
    ASSERT_FALSE(echoes.empty());
    for (const auto& e : echoes) {
      ASSERT_EQ(e.pressure_pa, e.altitude_m) << who << " received number " << e.pressure_pa << " as its "
                                             << e.altitude_m << "th message (epoch " << e.temperature_c << ")";
    }
  }
  // A counter bursting 20 numbers per step across a checkpoint and two rollbacks (K = 2), until 200 numbers;
  // the listener saw each exactly once.
  void fly_burst_across_a_checkpoint() {
    ASSERT_NO_FATAL_FAILURE(start({.counter = param("burst", 20) + param("checkpoint_at", 3) +
                                              param("rollback_at", 6) + param("max_cycles", 2),
                                   .keep = 2,
                                   .worker = false}));
    ASSERT_NO_FATAL_FAILURE(step_until(
        [&] { return k_->sr_stats().rollbacks == 2 && records("numbers", "counter").size() >= 200; }, 200));
    expect_exactly_once("listener");
  }

  ImageRecorder recorder;
  // Opened before the test counts its fds.
  void SetUp() override {
    if (std::getenv("REJUV_TEST_LOG") == nullptr) log_ = std::tmpfile();
  }
  void TearDown() override {
    k_.reset();  // its shutdown logs too
    if (log_ == nullptr) return;
    if (HasFailure()) {
      std::fflush(log_);
      std::rewind(log_);
      std::printf("---- the kernel's log ----\n");
      for (char line[1024]; std::fgets(line, sizeof line, log_) != nullptr;) std::fputs(line, stdout);
    }
    std::fclose(log_);
    log_ = nullptr;
  }
  std::FILE* log_ = nullptr;  // the kernel's log when not on stderr
  std::unique_ptr<kernel::Kernel> k_;
  bool fork_only_ = false;
};

TEST_F(Images, CounterContinuesFromTheCheckpointAndTheQueuesAreRestored) {
  ASSERT_NO_FATAL_FAILURE(
      start({.counter = param("checkpoint_at", 5) + param("rollback_at", 10) + param("max_cycles", 1),
             .keep = 2,
             .worker = false}));
  const int driver_pid = k_->stats(id("driver")).pid;
  const int listener_pid = k_->stats(id("listener")).pid;
  ASSERT_NO_FATAL_FAILURE(step_until(
      [&] { return k_->sr_stats().rollbacks == 1 && records("numbers", "counter").size() >= 15; }, 100));
  // 1..9, then from the checkpoint at 5: 6, 7, … (10 was published in the same round as the rollback
  // request: what a retired incarnation has not had routed yet is erased with it).
  const auto numbers = records("numbers", "counter");
  for (std::size_t i = 0; i < 9; ++i) EXPECT_EQ(numbers[i].pressure_pa, static_cast<double>(i + 1));
  EXPECT_EQ(numbers[9].pressure_pa, 6.0);
  EXPECT_EQ(numbers[9].altitude_m, 1.0);  // the persistent cell counted the cycle
  EXPECT_EQ(k_->epoch().value(), 1U);
  // Queue state right after the restore equals the state saved at the checkpoint (rings, generations, cursors).
  ASSERT_EQ(recorder.restores.size(), 1U);
  const auto& [g, restored] = recorder.restores.front();
  ASSERT_TRUE(recorder.at_checkpoint.contains(g));
  EXPECT_EQ(restored, recorder.at_checkpoint.at(g));
  // The listener (rejuvenated) got every number exactly once relative to the cut; the driver (never rolled
  // back) kept its process and counts on across the rollback.
  expect_exactly_once("listener");
  EXPECT_NE(k_->stats(id("listener")).pid, listener_pid);
  EXPECT_EQ(k_->stats(id("driver")).pid, driver_pid);
  // The retired incarnation, stopped during the rollback, is killed and reaped once the images settle.
  k_->settle_images();
  errno = 0;
  EXPECT_EQ(::kill(listener_pid, 0), -1);
  EXPECT_EQ(errno, ESRCH);
  const auto driver = records("echoes", "driver");
  EXPECT_EQ(driver.back().altitude_m, static_cast<double>(driver.size()));
  EXPECT_EQ(k_->sr_stats().checkpoints, 2U);  // g1, and g2 taken by the restored counter
  EXPECT_EQ(k_->sr_stats().fallbacks, 0U);
}

// A sanitized build's services take every image by fork (memory_image::prepare_self refuses: the sanitizer's
// allocator keeps its heap outside the tracked layout), so what is asserted about images by written pages holds only without one.
constexpr bool kImagesByPagesPossible = !sys::kSanitizerBuild;

TEST_F(Images, BurstAcrossACheckpoint_NothingLostOrDuplicated) {
  ASSERT_NO_FATAL_FAILURE(fly_burst_across_a_checkpoint());
  const auto driver = records("echoes", "driver");
  EXPECT_EQ(driver.back().altitude_m, static_cast<double>(driver.size()));
  // The second rollback restored g2, whose images were taken by written pages against g1 (the services are
  // static): what the listener and the counter did after it is checked above.
  if (kImagesByPagesPossible) {
    EXPECT_GT(k_->sr_stats().images_by_pages, 0U);
  }
}

// The same burst with every image by fork (KernelOptions::images_by_pages off): the other way gives the same.
TEST_F(Images, BurstAcrossACheckpoint_ImagesByForkOnly) {
  fork_only_ = true;
  ASSERT_NO_FATAL_FAILURE(fly_burst_across_a_checkpoint());
  EXPECT_EQ(k_->sr_stats().images_by_pages, 0U);
  EXPECT_GT(k_->sr_stats().images_by_fork, 0U);
}


// The memory of this process (the kernel) [kB]: its RSS, from /proc/self/status. In a sanitizer build only,
// the bytes its allocations hold instead: under ASan what it frees waits in the allocator's quarantine (256 MiB
// by default) rather than being reused, so its RSS grows with every byte freed until the quarantine is full,
// and a drained one (__sanitizer_purge_allocator) still leaves shadow and scattered pages resident; under
// TSan the shadow of every address touched stays resident. What leaks through mappings rather than
// allocations is checked by the build without one.
long memory_kb() {
#if defined(REJUV_SANITIZED)
  return static_cast<long>(sys::heap_in_use_bytes() / 1024U);
#else
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.starts_with("VmRSS:")) return std::strtol(line.c_str() + 6, nullptr, 10);
  }
  return -1;
#endif
}

// The bytes the allocations of this process hold [kB] (sys::heap_in_use_bytes): what a leak grows.
long heap_kb() { return static_cast<long>(sys::heap_in_use_bytes() / 1024U); }

// Memory too: between cycle 10 and cycle 1000 the kernel's memory (memory_kb) grows by at most 512 kB, the
// bound of `rejuv soak` (a leak of one allocation per cycle per service would pass it only below ≈ 100
// bytes), and its heap in use by at most 32 kB (≈ 32 bytes per cycle).
TEST_F(Images, ThousandCycles_ProcessAndFdCountsStayFlat) {
  const Resources before = Resources::now();
  recorder.latest_only = true;
  {
    ASSERT_NO_FATAL_FAILURE(
        start({.counter = param("checkpoint_at", 2) + param("rollback_at", 3) + param("max_cycles", 1000),
               .keep = 2,
               .worker = false}));
    ASSERT_NO_FATAL_FAILURE(step_until([&] { return k_->sr_stats().rollbacks >= 10; }, 100));
    k_->settle_images();
    const Resources early = Resources::now();
    const long early_memory_kb = memory_kb();
    const long early_heap_kb = heap_kb();
    ASSERT_NO_FATAL_FAILURE(step_until([&] { return k_->sr_stats().rollbacks == 1000; }, 5000));
    ASSERT_NO_FATAL_FAILURE(step_n(*k_, 3));
    k_->settle_images();
    const Resources late = Resources::now();
    const long late_memory_kb = memory_kb();
    const long late_heap_kb = heap_kb();
    EXPECT_EQ(late.children, early.children);
    EXPECT_EQ(late.fds, early.fds);
    ASSERT_GT(early_memory_kb, 0);
    EXPECT_LE(late_memory_kb - early_memory_kb, 512)
        << "kernel memory " << early_memory_kb << " kB at cycle 10, " << late_memory_kb
        << " kB at cycle 1000";
    std::printf("kernel memory: %ld kB at cycle 10, %ld kB at cycle 1000; heap in use %ld kB, %ld kB\n",
                early_memory_kb, late_memory_kb, early_heap_kb, late_heap_kb);
    // The heap in use is flat: nothing the kernel keeps grows with the cycles (a burst of a service's queued
    // publications at one instant would show here as the stage's room for them).
    EXPECT_LE(late_heap_kb - early_heap_kb, 32) << "heap in use " << early_heap_kb << " kB at cycle 10, "
                                                << late_heap_kb << " kB at cycle 1000";
    EXPECT_EQ(k_->generations().size(), 2U);
    EXPECT_EQ(records("numbers", "counter").back().altitude_m, 1000.0);  // the persistent cell
    EXPECT_EQ(k_->sr_stats().fallbacks, 0U);
    if (kImagesByPagesPossible) {
      EXPECT_GT(k_->sr_stats().images_by_pages, k_->sr_stats().images_by_fork);  // by written pages once tracking
    }
    k_->shutdown();
    k_.reset();
  }
  const Resources after = Resources::now();
  EXPECT_EQ(after.children, before.children);
  EXPECT_EQ(after.fds, before.fds);
}

TEST_F(Images, AKilledImage_RollsBackToThePreviousGeneration) {
  ASSERT_NO_FATAL_FAILURE(
      start({.counter = param("checkpoint_at", 3) + param("rollback_at", 8) + param("max_cycles", 2),
             .keep = 2,
             .worker = false}));
  ASSERT_NO_FATAL_FAILURE(
      step_until([&] { return k_->generations().size() == 2; }, 100));  // g1 and, after one rollback, g2
  // Every frozen copy of the listener in g2: the image and its spare, once the spare has reported.
  k_->settle_images();
  const auto pids = k_->image_pids(id("listener"), k_->generations().back());
  ASSERT_EQ(pids.size(), 2U) << "the image and its spare";
  for (const int pid : pids) ASSERT_EQ(::kill(pid, SIGKILL), 0);
  ASSERT_NO_FATAL_FAILURE(step_until([&] { return k_->sr_stats().rollbacks == 2; }, 100));
  EXPECT_EQ(k_->sr_stats().fallbacks, 1U);
  EXPECT_EQ(k_->sr_stats().cold_restarts, 0U);
  ASSERT_NO_FATAL_FAILURE(step_n(*k_, 5));
  EXPECT_FALSE(k_->stop_reason().has_value());
  expect_exactly_once("listener");
}

TEST_F(Images, OneDeadCopy_TheSpareStillRestoresTheGeneration) {
  ASSERT_NO_FATAL_FAILURE(
      start({.counter = param("checkpoint_at", 3) + param("rollback_at", 8) + param("max_cycles", 1),
             .keep = 2,
             .worker = false}));
  ASSERT_NO_FATAL_FAILURE(step_until([&] { return k_->generations().size() == 1; }, 100));
  k_->settle_images();  // the spare copies have reported
  const auto pids = k_->image_pids(id("listener"), k_->generations().back());
  ASSERT_EQ(pids.size(), 2U) << "the image and its spare";
  ASSERT_EQ(::kill(pids.front(), SIGKILL), 0);
  ASSERT_NO_FATAL_FAILURE(step_until([&] { return k_->sr_stats().rollbacks == 1; }, 100));
  EXPECT_EQ(k_->sr_stats().fallbacks, 0U);
  EXPECT_EQ(k_->sr_stats().cold_restarts, 0U);
  ASSERT_NO_FATAL_FAILURE(step_n(*k_, 5));
  EXPECT_FALSE(k_->stop_reason().has_value());
  expect_exactly_once("listener");
}

TEST_F(Images, NoIntactGeneration_ColdRestartInSafeControl) {
  ASSERT_NO_FATAL_FAILURE(
      start({.counter = param("checkpoint_at", 3) + param("rollback_at", 8) + param("max_cycles", 1),
             .keep = 2,
             .worker = false}));
  ASSERT_NO_FATAL_FAILURE(step_until([&] { return k_->generations().size() == 1; }, 100));
  k_->settle_images();  // the spare copies have reported
  const auto pids = k_->image_pids(id("counter"));
  ASSERT_EQ(pids.size(), 2U) << "the image and its spare";
  for (const int pid : pids) ASSERT_EQ(::kill(pid, SIGKILL), 0);
  ASSERT_NO_FATAL_FAILURE(step_until([&] { return k_->sr_stats().cold_restarts == 1; }, 100));
  EXPECT_EQ(k_->mode(), SrMode::SC);
  // The restarted counter boots from its binary, counts from 1 again and checkpoints afresh.
  ASSERT_NO_FATAL_FAILURE(step_until([&] { return k_->sr_stats().checkpoints >= 2; }, 200));
  EXPECT_FALSE(k_->stop_reason().has_value());
}

TEST_F(Images, HundredRollbacks_OneWorkerAndThePersistentCellSurvives) {
  ASSERT_NO_FATAL_FAILURE(
      start({.counter = param("checkpoint_at", 2) + param("rollback_at", 3) + param("max_cycles", 100),
             .keep = 2,
             .worker = true}));
  // Worker threads of the live incarnation (the threads named as the SDK names them: not its main thread, nor
  // a sanitizer runtime's), read from outside after every step.
  int most = 0;
  const auto workers_now = [&] {
    const std::string task = "/proc/" + std::to_string(k_->stats(id("worker")).pid) + "/task";
    std::error_code ec;
    int n = 0;
    for (auto it = std::filesystem::directory_iterator(task, ec); !ec && it != std::filesystem::directory_iterator();
         it.increment(ec)) {
      std::ifstream comm(it->path() / "comm");
      std::string name;
      if (std::getline(comm, name) && name == sdk::Service::kWorkerThreadName) ++n;
    }
    return n;
  };
  ASSERT_NO_FATAL_FAILURE(step_until(
      [&] {
        most = std::max(most, workers_now());
        return k_->sr_stats().rollbacks == 100;
      },
      1000));
  // The last re-spawned worker starts (a real thread): stepped until it runs (a deadline, not a measure),
  // then 20 steps more, in which no second one may appear.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds{10};
  while (workers_now() < 1 && std::chrono::steady_clock::now() < deadline)
    ASSERT_NO_FATAL_FAILURE(step_n(*k_, 1));
  ASSERT_EQ(workers_now(), 1) << "the re-spawned worker thread did not start within 10 s";
  for (int i = 0; i < 20; ++i) {
    ASSERT_NO_FATAL_FAILURE(step_n(*k_, 1));
    most = std::max(most, workers_now());
  }
  const auto verdicts = records("verdicts", "worker");
  ASSERT_FALSE(verdicts.empty());
  EXPECT_LE(most, 1) << "two worker instances at once";
  EXPECT_EQ(workers_now(), 1);
  EXPECT_EQ(verdicts.back().temperature_c, 100.0);  // re-spawned once per rollback
  EXPECT_EQ(records("numbers", "counter").back().altitude_m, 100.0);
}

// A service with a worker takes every image by fork, in every build, and is offered a base (so it gets its
// pagemap) at every checkpoint after a restore. With the fewest open files a launch allows, an fd that each
// restored incarnation kept would fill its table within a few cycles, and the fds of a Resume would be
// refused: every image of the line lost (a fallback each time).
TEST_F(Images, FortyRollbacksByFork_FewOpenFiles_NoImageLost) {
  ASSERT_NO_FATAL_FAILURE(
      start({.counter = param("checkpoint_at", 2) + param("rollback_at", 3) + param("max_cycles", 40),
             .keep = 2,
             .worker = true,
             .worker_extra = "  limits { max_open_files: 16 }\n"}));
  ASSERT_NO_FATAL_FAILURE(step_until([&] { return k_->sr_stats().rollbacks == 40; }, 400));
  ASSERT_NO_FATAL_FAILURE(step_n(*k_, 3));
  EXPECT_EQ(k_->sr_stats().fallbacks, 0U);
  EXPECT_EQ(k_->sr_stats().cold_restarts, 0U);
  EXPECT_FALSE(k_->stop_reason().has_value());
}

constexpr double kRestoredMark =
    -1;  // pressure_pa of the `hooked` role's on_restored record (test_records.hpp)

// on_restored (service.hpp): once in every restored incarnation, with the epoch the time page shows, before
// any handler of that epoch runs (the `hooked` worker's ticks carry the epoch they ran in).
TEST_F(Images, OnRestored_OncePerRollbackWithItsEpochBeforeAnyHandlerOfIt) {
  ASSERT_NO_FATAL_FAILURE(
      start({.counter = param("checkpoint_at", 3) + param("rollback_at", 6) + param("max_cycles", 3),
             .keep = 2,
             .worker = false,
             .hooked = true}));
  ASSERT_NO_FATAL_FAILURE(step_until([&] { return k_->sr_stats().rollbacks == 3; }, 300));
  ASSERT_NO_FATAL_FAILURE(step_n(*k_, 5));
  const auto all = records("verdicts", "worker");
  std::vector<rejuv_msg_SensorBaro> hooks;
  for (const auto& r : all) {
    if (r.pressure_pa == kRestoredMark) hooks.push_back(r);
  }
  ASSERT_EQ(hooks.size(), 3U) << "one on_restored per rollback";
  for (std::size_t i = 0; i < hooks.size(); ++i) {
    EXPECT_EQ(hooks[i].altitude_m, static_cast<double>(i + 1)) << "the epoch it was restored into";
    EXPECT_EQ(hooks[i].temperature_c, hooks[i].altitude_m) << "the epoch the time page shows then";
  }
  EXPECT_EQ(k_->epoch().value(), 3U);
  // In every restored epoch the first record of it is the hook's: no tick of that epoch ran before it.
  for (std::uint32_t e = 1; e <= 3; ++e) {
    const auto first = std::find_if(all.begin(), all.end(), [&](const auto& r) { return r.altitude_m == e; });
    ASSERT_NE(first, all.end()) << "epoch " << e;
    EXPECT_EQ(first->pressure_pa, kRestoredMark) << "a handler of epoch " << e << " ran before on_restored";
  }
}

TEST_F(Images, RejuvenationTimer_OneArmPerEpoch_AndItRollsBack) {
  ASSERT_NO_FATAL_FAILURE(start({.counter = param("checkpoint_at", 3) + param("max_cycles", 3) +
                                            text_param("rollback_by", "timer") + param("arm_twice", 1),
                                 .keep = 2,
                                 .worker = false}));
  ASSERT_NO_FATAL_FAILURE(step_until([&] { return k_->sr_stats().rollbacks == 3; }, 200));
  ASSERT_NO_FATAL_FAILURE(step_n(*k_, 5));
  const kernel::SrStats& sr = k_->sr_stats();
  EXPECT_EQ(sr.timer_rollbacks, 3U);
  EXPECT_EQ(sr.timer_arms, 3U);
  EXPECT_EQ(sr.timer_arm_refused, 3U);
  const auto verdicts = records("verdicts", "counter");
  ASSERT_EQ(verdicts.size(), 3U);
  for (const auto& v : verdicts) {
    EXPECT_EQ(v.altitude_m, 1.0);  // the second arm was refused …
    EXPECT_EQ(v.temperature_c, static_cast<double>(wire::OpError::Refused));  // … as Refused
  }
}

}  // namespace
}  // namespace rejuv::testing
