// Floods cost only the flooder (docs/sandbox.md "Floods cost only the flooder", docs/ulog.md "Profiles and
// the size budget"): a compromised ext_link publishes 2000 messages at every 2 ms tick of each MC window on
// mission_upload (FLOOD_BROKER, magnitude 2000: 10⁶/s, the attack that once grew the run's ULog 142-fold).
// Flown as a user flies it — `rejuv run` on launch/quad_square with the flood added — in lockstep and in real
// time, next to the same flight without the flood. Judged by effect: the ULog stays within 2× of the flight
// without the flood (the default profile and, in lockstep, `--ulog-profile full`, where the size budget cuts
// the topic and the log says so); ext_link's excess is dropped by its publication budget, counted and
// attributed to it, its accepted publications within its budget; no other service has a publication dropped,
// and in lockstep every other service publishes exactly what it publishes without the flood; the kernel
// reports it at most once per second as a SecurityEvent; in real time the kernel pauses the flooder's channel
// rather than read its whole flood; the vehicle stays safe (max V < 1). No timing is asserted.
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "rejuv_cli.hpp"
#include "summary.pb.h"
#include "test_domain.hpp"

namespace rejuv::testing {
namespace {

namespace fs = std::filesystem;
using test_support::kRepo;
using test_support::slurp;

constexpr const char* kFloodLine = "attacks { kind: FLOOD_BROKER service: \"ext_link\" magnitude: 2000 }";
constexpr double kFlightS = 10.0;

enum class Clock : std::uint8_t { Lockstep, Realtime };
enum class Flood : std::uint8_t { Off, On };

class FloodAttack : public test_support::ScratchDirTest {
 protected:
  FloodAttack() : ScratchDirTest("rejuv_flood_") {}
  [[nodiscard]] bool keep_on_failure() const override { return true; }

  // launch/quad_square in the scratch folder, over an edited copy of the paper's square: the policy by
  // absolute path, a short alignment and, with the flood, ext_link flooding from the first MC window on.
  void write_graph(Flood flood, const fs::path& to) {
    std::string t = slurp(kRepo / "launch/quad_square_paper.launch.pbtxt");
    const auto replace = [&](const std::string& from, const std::string& with) {
      const std::size_t at = t.find(from);
      ASSERT_NE(at, std::string::npos) << "launch/quad_square_paper.launch.pbtxt has no '" << from << "'";
      t.replace(at, from.size(), with);
    };
    replace("policy: \"../policies/quad_sr.policy.pbtxt\"",
            "policy: \"" + (kRepo / "policies/quad_sr.policy.pbtxt").string() + "\"");
    replace("alignment_s: 20", "alignment_s: 8");
    if (flood == Flood::On) {
      replace("attacks { kind: WORST_CASE_CONTROL service: \"lqr_control\" }",
              "attacks { kind: WORST_CASE_CONTROL service: \"lqr_control\" }\n  " + std::string(kFloodLine));
    }
    const fs::path paper = to.parent_path() / (to.stem().string() + "_paper.launch.pbtxt");
    std::ofstream(paper) << t;
    test_support::write_extending("quad_square.launch.pbtxt", paper, to);
  }

  // `rejuv run` of the square with or without the flood; its summary (the ULog in `name`.ulg).
  proto::RunSummary fly(Clock clock, Flood flood, const std::string& profile, const std::string& name) {
    const fs::path graph = dir_ / (name + ".launch.pbtxt");
    write_graph(flood, graph);
    std::vector<std::string> args{"run",
                                  graph.string(),
                                  "--duration",
                                  std::to_string(kFlightS),
                                  "--domain",
                                  std::to_string(test_support::kOwnDdsDomain),
                                  "--net-port",
                                  "0",
                                  "--ulog",
                                  (dir_ / (name + ".ulg")).string(),
                                  "--ulog-profile",
                                  profile,
                                  "--summary-json",
                                  (dir_ / (name + ".json")).string()};
    if (clock == Clock::Realtime) args.emplace_back("--realtime");
    const test_support::CliOutcome run = test_support::run_rejuv(dir_ / "", args);
    EXPECT_EQ(run.exit_code, 0) << name << ": " << run.err;
    proto::RunSummary summary;
    EXPECT_TRUE(google::protobuf::util::JsonStringToMessage(slurp(dir_ / (name + ".json")), &summary).ok())
        << name;
    return summary;
  }

  static std::map<std::string, const proto::ServiceSummary*> by_name(const proto::RunSummary& s) {
    std::map<std::string, const proto::ServiceSummary*> out;
    for (const proto::ServiceSummary& sv : s.services()) out[sv.name()] = &sv;
    return out;
  }

  // What holds in either clock, for a flooded flight next to its flight without the flood.
  void expect_only_the_flooder_pays(Clock clock, const proto::RunSummary& base,
                                    const proto::RunSummary& flood) {
    // The ULog within 2× of the flight without the flood.
    ASSERT_GT(base.ulog().bytes(), 0U);
    EXPECT_LE(flood.ulog().bytes(), 2 * base.ulog().bytes())
        << "flood " << flood.ulog().bytes() << " B, without " << base.ulog().bytes() << " B";
    // ext_link's excess dropped, counted and attributed to it; what it got through within its budget (2000/s
    // of kernel time, the alignment included, with a burst of one second's worth).
    const auto services = by_name(flood);
    ASSERT_TRUE(services.contains("ext_link"));
    const proto::ServiceSummary& flooder = *services.at("ext_link");
    EXPECT_GT(flooder.publications_over_budget(), 0U);
    EXPECT_LE(flooder.publishes(), static_cast<std::uint64_t>(2000.0 * (flood.sim_time_s() + 1.0)));
    EXPECT_EQ(flood.denials().at("PublicationsOverBudget"), flooder.publications_over_budget());
    // No other service had a publication dropped; without the flood, nobody did.
    const auto honest = by_name(base);
    for (const auto& [name, sv] : services) {
      if (name == "ext_link") continue;
      EXPECT_EQ(sv->publications_over_budget(), 0U) << name;
      ASSERT_TRUE(honest.contains(name)) << name;
      EXPECT_EQ(honest.at(name)->publications_over_budget(), 0U) << name;
      // In lockstep the flight is the same: every other service publishes what it publishes without the
      // flood.
      if (clock == Clock::Lockstep) {
        EXPECT_EQ(sv->publishes(), honest.at(name)->publishes()) << name;
      }
    }
    EXPECT_FALSE(base.denials().contains("PublicationsOverBudget"));
    // Reported, at most once per second of kernel time, as a SecurityEvent.
    const auto events = flood.ulog().routed_by_topic().find("security_event");
    ASSERT_NE(events, flood.ulog().routed_by_topic().end());
    EXPECT_GE(events->second, 1U);
    EXPECT_LE(events->second, static_cast<std::uint64_t>(flood.sim_time_s()) + 1U);
    // The vehicle as safe as ever.
    EXPECT_LT(flood.max_v(), 1.0);
    EXPECT_LT(base.max_v(), 1.0);
  }
};

TEST_F(FloodAttack, Lockstep_FlooderDroppedAndCounted_LogWithinTwiceAndOthersUnaffected) {
  const proto::RunSummary base = fly(Clock::Lockstep, Flood::Off, "default", "base");
  const proto::RunSummary flood = fly(Clock::Lockstep, Flood::On, "default", "flood");
  ASSERT_FALSE(HasFailure());
  expect_only_the_flooder_pays(Clock::Lockstep, base, flood);
  // The default profile writes mission_upload at its interval, not at the flood's rate.
  EXPECT_LT(flood.ulog().logged_by_topic().at("mission_upload"),
            flood.ulog().routed_by_topic().at("mission_upload"));
}

TEST_F(FloodAttack, LockstepFullProfile_SizeBudgetCutsTheTopic_LogSaysSo) {
  const proto::RunSummary base = fly(Clock::Lockstep, Flood::Off, "full", "base_full");
  const proto::RunSummary flood = fly(Clock::Lockstep, Flood::On, "full", "flood_full");
  ASSERT_FALSE(HasFailure());
  expect_only_the_flooder_pays(Clock::Lockstep, base, flood);
  // Every routed message of the honest flight written; in the flood, only mission_upload cut by the budget.
  EXPECT_TRUE(base.ulog().over_budget_by_topic().empty()) << base.ulog().DebugString();
  ASSERT_EQ(flood.ulog().over_budget_by_topic_size(), 1) << flood.ulog().DebugString();
  EXPECT_GT(flood.ulog().over_budget_by_topic().at("mission_upload"), 0U);
  // … and the log says what was not written, and whose it was.
  const std::string ulg = slurp(dir_ / "flood_full.ulg");
  EXPECT_NE(ulg.find("ulog: topic 'mission_upload' over its share of the log's size budget"),
            std::string::npos);
  EXPECT_NE(ulg.find("published by 'ext_link' from t = "), std::string::npos);
}

TEST_F(FloodAttack, Realtime_FlooderDroppedAndCounted_LogWithinTwiceAndOthersUnaffected) {
  const proto::RunSummary base = fly(Clock::Realtime, Flood::Off, "default", "base_rt");
  const proto::RunSummary flood = fly(Clock::Realtime, Flood::On, "default", "flood_rt");
  ASSERT_FALSE(HasFailure());
  expect_only_the_flooder_pays(Clock::Realtime, base, flood);
  // The kernel stops reading the flooder's channel for 10 ms after each wakeup that found it over budget: at
  // most 100 wakeups a second, each a few hundred frames at most (without the pause: ≈ 10⁵ a second, all the
  // kernel could read). What it decided on and dropped stays under that bound; the flooder waits instead.
  const auto services = by_name(flood);
  ASSERT_TRUE(services.contains("ext_link"));
  EXPECT_LE(services.at("ext_link")->publications_over_budget(),
            static_cast<std::uint64_t>(20000.0 * flood.sim_time_s()));
}

}  // namespace
}  // namespace rejuv::testing
