// The run summary (proto::RunSummary) of a finished `rejuv run`, filled in one place: by `rejuv run` and by the
// end-to-end tests that fly a graph themselves (tests/multiproc), so that both report the same fields.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "rejuv/kernel/kernel.hpp"
#include "run_recorder.hpp"
#include "summary.pb.h"

namespace rejuv::cli {

// The charge's name in the summary and on the command line (--charge).
[[nodiscard]] std::string_view to_string(kernel::KernelOptions::Charge charge);

// How the run was started: what the summary says of it beside what the kernel and the recorder measured.
struct RunFacts {
  std::string graph;
  std::string runner = "run";
  bool attack = false;        // the graph's attack plan flown
  std::string attack_kind{};  // the attack on the vehicle, if any (vehicle_attack_kind)
  std::uint64_t seed = 0;
  bool insecure_sandbox = false;  // --insecure-sandbox: no namespaces
  kernel::KernelOptions::Charge charge = kernel::KernelOptions::Charge::Model;
};

// The facts of a run of `k` started with `options` (the attack flown unless options.no_attack, the seed the
// options give or the graph's).
[[nodiscard]] RunFacts facts_of(const kernel::Kernel& k, const kernel::KernelOptions& options);

// Everything of `s` but what is written after the run (the ULog's, the out directory's): the recorder's
// metrics, the denials by kind, the sandbox, each service's evidence, times, the network gate, the image
// store's counts and durations, the charge and the estimate catch-up.
void fill_summary(proto::RunSummary& s, const kernel::Kernel& k, const RunRecorder& recorder,
                  const kernel::RunOutcome& outcome, const RunFacts& facts);

}  // namespace rejuv::cli
