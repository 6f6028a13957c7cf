// A flight of the square (mission::load_square, no attack but the graph's) watched from the kernel's own thread by
// an observer of the test's, beside the run recorder: the set-up and the summary that hung_service_test.cpp and
// realtime_plan_kept_test.cpp share. `watcher.attach(kernel)` is called before the run; `inspect(kernel)` after it,
// before the kernel is torn down.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <optional>

#include "mission_support.hpp"
#include "run_recorder.hpp"
#include "run_summary.hpp"

namespace rejuv::testing::mission {

struct ObservedFlight {
  std::optional<kernel::RunOutcome> outcome;
  proto::RunSummary summary;
  RunLog log;
};

// The square in real time or lockstep for `flight` after its alignment; `watcher` is made with the alignment
// (the mission's t = 0 on the kernel clock); `options`, if given, changes the kernel's options. Fatal
// failures of the set-up are the caller's (ASSERT_NO_FATAL_FAILURE).
template <typename Watcher>
void fly_observed(bool realtime, std::chrono::seconds flight,
                  const std::function<Watcher(Nanos alignment)>& make,
                  const std::function<void(const kernel::Kernel&, const Watcher&)>& inspect,
                  ObservedFlight& out,
                  const std::function<void(kernel::KernelOptions&)>& options_change = nullptr) {
  std::optional<launch::LoadedLaunch> graph;
  ASSERT_NO_FATAL_FAILURE(load_square(realtime, {}, graph));
  auto reference = cli::run_reference(*graph, std::nullopt);
  ASSERT_TRUE(reference.has_value()) << reference.error();
  ASSERT_NE(out.log.get(), nullptr);
  kernel::KernelOptions options = mission_options(out.log.get());
  options.duration = reference->alignment + Nanos{flight};
  if (options_change) options_change(options);
  Watcher watcher = make(reference->alignment);
  SessionGuard guard;
  cli::RunRecorder recorder(std::move(*reference), nullptr, cli::RunRecorder::Progress::Off);
  kernel::ObserverFanout fanout({&recorder, &watcher});
  auto k = kernel::Kernel::create(std::move(*graph), options, &fanout);
  ASSERT_TRUE(k.has_value()) << k.error().to_string();
  watcher.attach(k->get());
  recorder.on_vehicle_lost([kernel = k->get()] { (*kernel).request_stop(); });
  auto outcome = (*k)->run();
  ASSERT_TRUE(outcome.has_value()) << outcome.error().to_string() << "\n" << out.log.text();
  cli::fill_summary(out.summary, **k, recorder, *outcome, cli::facts_of(**k, options));
  inspect(**k, watcher);
  out.outcome = *outcome;
}

}  // namespace rejuv::testing::mission
