// The kernel's refusals at creation (docs/design.md §4: it refuses to start a graph whose policy fails the audit;
// §7: no SR without the image store; bad configuration). Nothing is spawned.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "rejuv/kernel/kernel.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/sys/event.hpp"

namespace rejuv::kernel {
namespace {

namespace fs = std::filesystem;

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A scratch folder with the multi-process test policy and a launch graph over it.
class KernelConfig : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() / ("rejuv_kernel_config_" + std::to_string(sys::current_pid()) + "_" +
                                       ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir);
    policy = read(fs::path(REJUV_SOURCE_DIR) / "tests/multiproc/graphs/test.policy.pbtxt");
  }
  void TearDown() override { fs::remove_all(dir); }

  std::string launch(const std::string& exe, const std::string& extra = "") const {
    std::string t = "name: \"cfg\"\npolicy: \"p.policy.pbtxt\"\n" + extra;
    const auto svc = [&](const std::string& name, const std::string& uses) {
      t += "services { name: \"" + name + "\" executable: \"" + exe + "\" " + uses + " }\n";
    };
    svc("source", "uses { object: \"numbers\" rights: \"W\" }");
    svc("echo", "uses { object: \"numbers\" rights: \"R\" } uses { object: \"echoes\" rights: \"W\" }");
    svc("sink", "uses { object: \"numbers\" rights: \"R\" } uses { object: \"echoes\" rights: \"R\" } "
                "uses { object: \"security_event\" rights: \"R\" } uses { object: \"digest\" rights: \"W\" }");
    svc("stall", "uses { object: \"numbers\" rights: \"R\" }");
    svc("intruder", "uses { object: \"numbers\" rights: \"R\" }");
    t += "mission { waypoints { down_m: -3 } acceptance_radius_m: 0.1 timeout_s: 10 }\n";
    return t;
  }

  Result<std::unique_ptr<Kernel>, KernelError> create(const std::string& policy_text, const std::string& launch_text,
                                                      KernelOptions options = manual()) {
    std::ofstream(dir / "p.policy.pbtxt") << policy_text;
    std::ofstream(dir / "g.launch.pbtxt") << launch_text;
    auto loaded = launch::load_launch(dir / "g.launch.pbtxt");
    EXPECT_TRUE(loaded.has_value()) << loaded.error().to_string();
    return Kernel::create(std::move(*loaded), std::move(options));
  }
  static KernelOptions manual() {
    KernelOptions o;
    o.time_master = TimeMaster::Manual;
    o.log = nullptr;
    return o;
  }

  fs::path dir;
  std::string policy;
};

TEST_F(KernelConfig, ValidGraph_IsCreatedWithoutStartingAnything) {
  auto k = create(policy, launch("/bin/true"));
  ASSERT_TRUE(k.has_value()) << k.error().to_string();
  EXPECT_EQ((*k)->service_count(), 5U);
  EXPECT_FALSE((*k)->stats(ServiceId{0}).started);
  EXPECT_EQ((*k)->mode(), SrMode::MC);
}

TEST_F(KernelConfig, PolicyFailingTheAudit_IsRefusedWithItsFindings) {
  const std::string broken = policy + "objects { name: \"orphan\" kind: TOPIC type: \"rejuv::msg::SensorBaro\" }\n";
  auto k = create(broken, launch("/bin/true"));
  ASSERT_FALSE(k.has_value());
  EXPECT_EQ(k.error().kind, KernelError::Kind::Audit);
  ASSERT_FALSE(k.error().findings.empty());
  EXPECT_NE(k.error().findings[0].find("orphan"), std::string::npos) << k.error().findings[0];
  EXPECT_NE(k.error().findings[0].find("p.policy.pbtxt:"), std::string::npos) << "findings carry file:line";
  EXPECT_FALSE(k.error().is_bad_input());  // a finding, exit 1 like `rejuv audit` (README "Exit codes")
}

TEST_F(KernelConfig, UnreadablePolicy_IsAPolicyError) {
  auto k = create("services { name: ", launch("/bin/true"));
  ASSERT_FALSE(k.has_value());
  EXPECT_EQ(k.error().kind, KernelError::Kind::Policy);
}

TEST_F(KernelConfig, SrRequested_StartsInSafeControl_NoSrStartsInMissionControl) {
  const std::string sr = "sr { enabled: true t_mc_s: 0.3 t_est_s: 3 rho_m: 0.1 rho_s: 0.05 "
                         "box { position_m: 0.5 velocity_m_s: 1 angle_rad: 0.3 rate_rad_s: 2 } "
                         "restricted_limit_fraction: 0.3 }\n";
  // SR needs a rejuvenation service that can take checkpoints (audit invariant `checkpoint`): `stall` is one.
  std::string sr_policy = policy + "objects { name: \"checkpoint\" kind: CHECKPOINT }\n"
                                   "grants { service: \"stall\" object: \"checkpoint\" rights: \"W\" modes: [RB, SC, UPDATE, CP] }\n";
  sr_policy.replace(sr_policy.find("services { name: \"stall\" }"), 26, "services { name: \"stall\" rejuvenation: true }");
  std::string sr_launch = launch("/bin/true", sr);
  const std::string stall_uses = "name: \"stall\" executable: \"/bin/true\" uses { object: \"numbers\" rights: \"R\" }";
  sr_launch.insert(sr_launch.find(stall_uses) + stall_uses.size(), " uses { object: \"checkpoint\" rights: \"W\" }");
  auto k = create(sr_policy, sr_launch);
  ASSERT_TRUE(k.has_value()) << k.error().to_string() << ::testing::PrintToString(k.error().findings);
  EXPECT_TRUE((*k)->sr_enabled());
  EXPECT_EQ((*k)->mode(), SrMode::SC);  // docs/design.md §7 Faults: the safe mode, network off
  KernelOptions o = manual();
  o.no_sr = true;
  auto without = create(sr_policy, sr_launch, o);
  ASSERT_TRUE(without.has_value()) << without.error().to_string();
  EXPECT_FALSE((*without)->sr_enabled());
  EXPECT_EQ((*without)->mode(), SrMode::MC);
}

TEST_F(KernelConfig, MissingExecutable_NamesTheServiceAndTheSkipFlag) {
  auto k = create(policy, launch("/nonexistent/rejuv_nothing"));
  ASSERT_FALSE(k.has_value());
  EXPECT_EQ(k.error().kind, KernelError::Kind::Config);
  EXPECT_NE(k.error().message.find("'source'"), std::string::npos) << k.error().message;
  EXPECT_NE(k.error().message.find("--skip"), std::string::npos);
  // Where the executable was named: the launch file's line of `executable` (services[0] is on line 3).
  EXPECT_NE(k.error().message.find("g.launch.pbtxt:3:"), std::string::npos) << k.error().message;
  EXPECT_NE(k.error().message.find(": error: "), std::string::npos) << k.error().message;
}

TEST_F(KernelConfig, LockstepWithoutAPlant_NeedsManualStepping) {
  KernelOptions o = manual();
  o.time_master = TimeMaster::Plant;
  auto k = create(policy, launch("/bin/true"), o);
  ASSERT_FALSE(k.has_value());
  EXPECT_EQ(k.error().kind, KernelError::Kind::Config);
}

TEST_F(KernelConfig, ManualSteppingInRealtime_IsRefused) {
  KernelOptions o = manual();
  o.clock = ClockMode::Realtime;
  auto k = create(policy, launch("/bin/true"), o);
  ASSERT_FALSE(k.has_value());
  EXPECT_EQ(k.error().kind, KernelError::Kind::Config);
}

}  // namespace
}  // namespace rejuv::kernel
