// Building blocks of the multi-process tests: the test graph (graphs/test.policy.pbtxt + a launch text made
// per test), kernel options for a test run, and a recorder of every routed publication.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>
#include <cstring>
#include <ostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "rejuv/kernel/kernel.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/sys/event.hpp"
#include "rejuv/sys/fd.hpp"
#include "rejuv/sys/process.hpp"
#include "../test_domain.hpp"

namespace rejuv::testing {

inline const std::filesystem::path kGraphs = std::filesystem::path(REJUV_SOURCE_DIR) / "tests/multiproc/graphs";
inline const std::filesystem::path kServiceDir = std::filesystem::path(REJUV_BINARY_DIR) / "bin";

// Params of one test service: role plus extras, in launch text.
struct Role {
  std::string role;
  std::string extra;  // more `params { ... }` entries
};

struct GraphSpec {
  std::uint64_t seed = 1;
  Role source{"source", ""};
  Role echo{"echo", ""};
  Role sink{"sink", ""};
  Role stall{"idle", ""};
  Role intruder{"intruder", ""};
  std::string clock = "LOCKSTEP";
  std::string extra{};  // e.g. a dds section
};

inline std::string service_text(const std::string& name, const Role& r, const std::string& uses) {
  return "services {\n  name: \"" + name + "\"\n  executable: \"rejuv_test_service\"\n  params { name: \"role\" text: \"" +
         r.role + "\" }\n" + r.extra + uses + "}\n";
}

inline std::string launch_text(const GraphSpec& g) {
  std::string t = "name: \"multiproc\"\npolicy: \"test.policy.pbtxt\"\nclock: " + g.clock +
                  "\nseed: " + std::to_string(g.seed) + "\n";
  t += service_text("source", g.source, "  uses { object: \"numbers\" rights: \"W\" }\n");
  t += service_text("echo", g.echo,
                    "  uses { object: \"numbers\" rights: \"R\" }\n  uses { object: \"echoes\" rights: \"W\" }\n");
  t += service_text("sink", g.sink,
                    "  uses { object: \"numbers\" rights: \"R\" }\n  uses { object: \"echoes\" rights: \"R\" }\n"
                    "  uses { object: \"security_event\" rights: \"R\" }\n  uses { object: \"digest\" rights: \"W\" }\n");
  t += service_text("stall", g.stall, "  uses { object: \"numbers\" rights: \"R\" }\n");
  t += service_text("intruder", g.intruder, "  uses { object: \"numbers\" rights: \"R\" }\n");
  t += "mission { waypoints { north_m: 0 east_m: 0 down_m: -3 } acceptance_radius_m: 0.1 timeout_s: 600 }\n";
  t += g.extra;
  return t;
}

inline launch::LoadedLaunch load(const GraphSpec& g) {
  auto loaded = launch::parse_launch(launch_text(g), kGraphs / "test.launch.pbtxt");
  if (!loaded) ADD_FAILURE() << loaded.error().to_string();
  return std::move(*loaded);
}

inline kernel::KernelOptions test_options() {
  kernel::KernelOptions o;
  o.time_master = kernel::TimeMaster::Manual;
  o.service_dir = kServiceDir;
  o.repo_root = REJUV_SOURCE_DIR;
  o.boot_deadline = std::chrono::seconds{20};
  o.idle_deadline = std::chrono::seconds{3};
  o.shutdown_grace = std::chrono::seconds{3};
  o.dds_domain = test_support::kOwnDdsDomain;  // this process's own (tests/test_domain.hpp)
  return o;
}

// One routed publication, as the test sees it.
struct Seen {
  std::string topic;
  std::optional<ServiceId> publisher;
  std::uint64_t generation = 0;
  std::vector<std::byte> payload;
  std::int64_t t_ns = 0;
  friend bool operator==(const Seen&, const Seen&) = default;
  // What a failed comparison prints: the fields, the payload in hex (not the object's bytes, whose pointers
  // differ between any two runs).
  friend void PrintTo(const Seen& s, std::ostream* os) {
    *os << s.topic << " from " << (s.publisher ? std::to_string(s.publisher->value()) : std::string("the kernel"))
        << ", generation " << s.generation << ", t " << s.t_ns << " ns, payload";
    for (const std::byte b : s.payload) *os << ' ' << std::hex << std::to_integer<int>(b) << std::dec;
  }
};

class Recorder final : public kernel::Observer {
 public:
  void on_publication(const kernel::Publication& p) override {
    seen.push_back(Seen{std::string(p.name), p.publisher, p.generation.value(),
                        std::vector<std::byte>(p.payload.begin(), p.payload.end()), p.t.count()});
  }
  [[nodiscard]] std::vector<const Seen*> on(std::string_view topic) const {
    std::vector<const Seen*> out;
    for (const Seen& s : seen) {
      if (s.topic == topic) out.push_back(&s);
    }
    return out;
  }
  template <class T>
  static T as(const Seen& s) {
    T v{};
    std::memcpy(&v, s.payload.data(), std::min(sizeof(T), s.payload.size()));
    return v;
  }
  std::vector<Seen> seen;
};

// Process-level resources of this test process, to compare before and after a run.
struct Resources {
  int children = 0;
  int fds = 0;
  static Resources now() {
    auto c = sys::count_children(sys::current_pid());
    auto f = sys::count_open_fds();
    EXPECT_TRUE(c.has_value());
    EXPECT_TRUE(f.has_value());
    return Resources{c.value_or(-1), f.value_or(-1)};
  }
};

// Steps a manual kernel `n` times, 4 ms apart, from its current time.
inline void step_n(kernel::Kernel& k, int n) {
  for (int i = 0; i < n; ++i) {
    auto r = k.step(k.now() + std::chrono::milliseconds{4});
    ASSERT_TRUE(r.has_value()) << r.error().to_string();
    if (k.stop_reason()) return;
  }
}

}  // namespace rejuv::testing
