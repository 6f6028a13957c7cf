// The security tests' graph (graphs/attacks.policy.pbtxt), shared by attack_test.cpp and hostile_test.cpp:
// four services of one binary (services/attack_service.cpp), their role named by the text param `role`:
// `rejuv` runs the SR cycle in miniature (checkpoint, timer, MC), `worker` publishes numbers, `link` holds the
// network in MC, `driver` (never rolled back) writes actuator_outputs. Lockstep, SR on, so that rollbacks
// happen in a few hundred steps.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <string>

#include "graph_fixture.hpp"

namespace rejuv::testing {

struct SecurityGraph {
  std::string worker_extra{};  // more lines in the worker's entry (`params { … }`, `limits { … }`)
  std::string attack{};        // the launch plan's `attack { … }` section, if any
};

inline std::string security_launch(const SecurityGraph& g) {
  const auto service = [](const std::string& name, const std::string& body) {
    return "services {\n  name: \"" + name + "\"\n  executable: \"rejuv_attack_test_service\"\n" +
           "  params { name: \"role\" text: \"" + name + "\" }\n" + body + "}\n";
  };
  std::string t = "name: \"attacks\"\npolicy: \"attacks.policy.pbtxt\"\nclock: LOCKSTEP\nseed: 1\n";
  t += service("rejuv",
               "  uses { object: \"verdicts\" rights: \"W\" }\n  uses { object: \"checkpoint\" rights: \"W\" }\n"
               "  uses { object: \"limits\" rights: \"W\" }\n  uses { object: \"mode\" rights: \"W\" }\n"
               "  uses { object: \"cell\" rights: \"RW\" }\n");
  t += service("worker", "  uses { object: \"numbers\" rights: \"W\" }\n  uses { object: \"verdicts\" rights: \"W\" }\n" +
                             g.worker_extra);
  t += service("link", "  uses { object: \"net\" rights: \"RW\" }\n  uses { object: \"verdicts\" rights: \"W\" }\n");
  t += service("driver",
               "  rejuvenate: false\n  uses { object: \"numbers\" rights: \"R\" }\n  uses { object: \"limits\" rights: \"R\" }\n"
               "  uses { object: \"actuator_outputs\" rights: \"W\" }\n  uses { object: \"verdicts\" rights: \"W\" }\n");
  t += "sr { enabled: true t_mc_s: 0.04 t_est_s: 0.01 rho_m: 0.1 rho_s: 0.05 keep_generations: 2"
       " box { position_m: 0.5 velocity_m_s: 1 angle_rad: 0.3 rate_rad_s: 2 } restricted_limit_fraction: 0.3 }\n";
  t += "mission { waypoints { north_m: 0 east_m: 0 down_m: -3 } acceptance_radius_m: 0.1 timeout_s: 600 }\n";
  t += "network { bind_address: \"127.0.0.1\" bind_port: 0 }\n";
  t += g.attack;
  return t;
}

// Wall-clock deadline of step_until_rollbacks: far above what a test of these suites needs (a few seconds,
// also under a sanitizer on a loaded machine) and below ctest's timeout, so that a run that stalls fails
// here, naming what it waited for, instead of being killed by ctest without a word.
inline constexpr std::chrono::seconds kStepDeadline{120};

// Steps the kernel 4 ms at a time until `n` rollbacks have happened (the run must go on meanwhile), then one
// more step: the images of the last rollback are resumed and live (still in the secure interval). A failure
// is returned for the calling test to assert (ASSERT_TRUE(step_until_rollbacks(…))), so that it stops there.
[[nodiscard]] inline ::testing::AssertionResult step_until_rollbacks(kernel::Kernel& k, std::uint64_t n,
                                                                     int limit = 600) {
  const auto step = [&]() -> ::testing::AssertionResult {
    auto r = k.step(k.now() + std::chrono::milliseconds{4});
    if (!r) return ::testing::AssertionFailure() << "step: " << r.error().to_string();
    return ::testing::AssertionSuccess();
  };
  const auto deadline = std::chrono::steady_clock::now() + kStepDeadline;
  for (int i = 0; i < limit && k.sr_stats().rollbacks < n; ++i) {
    if (std::chrono::steady_clock::now() >= deadline) {
      return ::testing::AssertionFailure() << "deadline: " << k.sr_stats().rollbacks << " of " << n
                                           << " rollbacks after " << i << " steps in " << kStepDeadline.count()
                                           << " s";
    }
    if (auto ok = step(); !ok) return ok;
    if (k.stop_reason()) return ::testing::AssertionFailure() << "the run stopped: " << k.stop_detail();
  }
  if (k.sr_stats().rollbacks < n) {
    return ::testing::AssertionFailure() << "not enough SR cycles: " << k.sr_stats().rollbacks << " of " << n
                                         << " rollbacks in " << limit << " steps";
  }
  if (k.stop_reason()) return ::testing::AssertionSuccess();  // stopped at the last rollback: nothing to step
  return step();
}

}  // namespace rejuv::testing
