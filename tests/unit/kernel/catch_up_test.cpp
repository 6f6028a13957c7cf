// CatchUp (kernel_sim/kernel/src/catch_up.hpp): the log of the plant's samples with the checkpoints' cuts, the
// replay after a rollback one sampling instant at a time, live samples behind it, and the chain's publications
// held from the services outside it while it runs.
#include "catch_up.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace rejuv::kernel {
namespace {

constexpr ObjectId kGyro{1};
constexpr ObjectId kGps{2};
constexpr ObjectId kCombined{3};  // chain → chain
constexpr ObjectId kState{4};     // chain → outside
constexpr ServiceId kEkf{0};
constexpr ServiceId kController{1};

CatchUp make(std::size_t capacity) {
  CatchUp::Plan plan{.logged = {false, true, true, false, false},
                     .cut_off = {false, false, false, false, true},
                     .chain = {true, false},
                     .estimate = {false, false, false, false, false}};
  return CatchUp(std::move(plan), capacity, 8);
}

std::array<std::byte, 8> sample(std::uint8_t v) {
  std::array<std::byte, 8> b{};
  b[0] = std::byte{v};
  return b;
}

using Samples = std::vector<std::pair<std::uint32_t, int>>;  // (topic, first byte) per sample

// Every instant of the replay, and what it released at its end into `released`.
std::vector<Samples> drain(CatchUp& c, Samples* released = nullptr) {
  std::vector<Samples> instants;
  Samples late;
  const auto record = [](Samples& into) {
    return [&into](ObjectId t, std::span<const std::byte> b) { into.emplace_back(t.value(), std::to_integer<int>(b[0])); };
  };
  for (;;) {
    Samples one;
    if (!c.replay_instant(record(one), record(late))) break;
    instants.push_back(std::move(one));
  }
  if (released != nullptr) *released = std::move(late);
  return instants;
}

TEST(CatchUp, Off_LogsNothing_NeverReplays) {
  CatchUp c;
  EXPECT_FALSE(c.enabled());
  EXPECT_FALSE(c.logs(kGyro));
  c.cut(Generation{1});
  EXPECT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::NothingToReplay);
  EXPECT_FALSE(c.replaying());
}

TEST(CatchUp, ReplaysTheSamplesSinceTheRestoredCut_OneInstantAtATime) {
  CatchUp c = make(16);
  EXPECT_TRUE(c.logs(kGyro));
  EXPECT_FALSE(c.logs(kCombined));
  EXPECT_FALSE(c.keep(kGyro, sample(1), 100));  // before the cut: in the queue state, not replayed
  c.cut(Generation{1});
  EXPECT_FALSE(c.keep(kGyro, sample(2), 200));
  EXPECT_FALSE(c.keep(kGps, sample(3), 200));
  EXPECT_FALSE(c.keep(kGyro, sample(4), 300));
  ASSERT_EQ(c.begin(Generation{1}, Nanos{5}), CatchUp::Begin::Replaying);
  EXPECT_TRUE(c.replaying());
  EXPECT_EQ(c.began_at(), Nanos{5});
  const auto instants = drain(c);
  ASSERT_EQ(instants.size(), 2u);
  EXPECT_EQ(instants[0], (Samples{{1, 2}, {2, 3}}));
  EXPECT_EQ(instants[1], (Samples{{1, 4}}));
  EXPECT_FALSE(c.replaying());
  EXPECT_EQ(c.replayed(), 3u);
  EXPECT_EQ(c.stats().samples, 3u);
  EXPECT_EQ(c.stats().replays, 1u);
}

TEST(CatchUp, ALiveSampleDuringTheReplay_WaitsBehindIt_ReleasedAsLiveWhenItEnds) {
  CatchUp c = make(16);
  c.cut(Generation{1});
  EXPECT_FALSE(c.keep(kGyro, sample(1), 100));
  ASSERT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::Replaying);
  EXPECT_TRUE(c.keep(kGyro, sample(2), 200)) << "the caller must not route it now";
  Samples released;
  const auto instants = drain(c, &released);
  ASSERT_EQ(instants.size(), 1u) << "the replay covers what was kept when it began";
  EXPECT_EQ(released, (Samples{{1, 2}}));
  EXPECT_FALSE(c.replaying()) << "released after the replay: its outputs go to everyone";
  EXPECT_EQ(c.replayed(), 1u);
  EXPECT_FALSE(c.keep(kGyro, sample(3), 300)) << "after the replay a sample is routed at once";
  ASSERT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::Replaying) << "a released sample is in the log";
  EXPECT_EQ(drain(c).size(), 3u);
}

TEST(CatchUp, TheChainsPublicationsForOutside_HeldOnlyWhileReplaying) {
  CatchUp c = make(16);
  c.cut(Generation{1});
  EXPECT_FALSE(c.keep(kGyro, sample(1), 100));
  EXPECT_FALSE(c.drops(kEkf, kState)) << "not replaying";
  ASSERT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::Replaying);
  EXPECT_TRUE(c.drops(kEkf, kState));
  EXPECT_FALSE(c.drops(kEkf, kCombined)) << "inside the chain: routed";
  EXPECT_FALSE(c.drops(kController, kState)) << "not the chain's";
  (void)drain(c);
  EXPECT_FALSE(c.drops(kEkf, kState));
  EXPECT_EQ(c.stats().dropped, 1u);
}

TEST(CatchUp, ARollbackAgainBeforeTheNextCut_ReplaysFromTheSameCut) {
  CatchUp c = make(16);
  c.cut(Generation{1});
  EXPECT_FALSE(c.keep(kGyro, sample(1), 100));
  ASSERT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::Replaying);
  (void)drain(c);
  EXPECT_FALSE(c.keep(kGyro, sample(2), 200));
  ASSERT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::Replaying);
  EXPECT_EQ(drain(c).size(), 2u);
}

TEST(CatchUp, AFallbackToAnOlderGeneration_ReplaysFromItsCut_AndForgetsTheErasedOnes) {
  CatchUp c = make(16);
  c.cut(Generation{1});
  EXPECT_FALSE(c.keep(kGyro, sample(1), 100));
  c.cut(Generation{2});
  EXPECT_FALSE(c.keep(kGyro, sample(2), 200));
  ASSERT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::Replaying);
  EXPECT_EQ(drain(c).size(), 2u);
  EXPECT_EQ(c.begin(Generation{2}, Nanos{0}), CatchUp::Begin::NoLog) << "erased by the rollback to 1";
  EXPECT_EQ(c.stats().without_log, 1u);
}

TEST(CatchUp, NothingSinceTheCut_NothingToReplay) {
  CatchUp c = make(16);
  c.cut(Generation{1});
  EXPECT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::NothingToReplay);
  EXPECT_FALSE(c.replaying());
  EXPECT_EQ(c.stats().replays, 0u);
}

TEST(CatchUp, ACutTheFullRingOverwrote_NoLog_TheRingStaysBounded) {
  CatchUp c = make(4);
  c.cut(Generation{1});
  for (std::uint8_t i = 0; i < 6; ++i) EXPECT_FALSE(c.keep(kGyro, sample(i), i));
  EXPECT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::NoLog);
  c.cut(Generation{2});
  EXPECT_FALSE(c.keep(kGyro, sample(9), 9));
  ASSERT_EQ(c.begin(Generation{2}, Nanos{0}), CatchUp::Begin::Replaying);
  const auto instants = drain(c);
  ASSERT_EQ(instants.size(), 1u);
  EXPECT_EQ(instants[0][0].second, 9);
}

TEST(CatchUp, CutShort_SkipsTheRest_ReleasesTheLiveOnes_RoutesTheChainAgain) {
  CatchUp c = make(16);
  c.cut(Generation{1});
  EXPECT_FALSE(c.keep(kGyro, sample(1), 100));
  EXPECT_FALSE(c.keep(kGyro, sample(2), 200));
  ASSERT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::Replaying);
  EXPECT_TRUE(c.keep(kGyro, sample(3), 300));
  Samples first;
  ASSERT_TRUE(c.replay_instant([&](ObjectId t, std::span<const std::byte> b) { first.emplace_back(t.value(), std::to_integer<int>(b[0])); },
                               [](ObjectId, std::span<const std::byte>) {}));
  Samples released;
  c.cut_short([&](ObjectId t, std::span<const std::byte> b) { released.emplace_back(t.value(), std::to_integer<int>(b[0])); });
  EXPECT_EQ(first, (Samples{{1, 1}}));
  EXPECT_EQ(released, (Samples{{1, 3}})) << "sample 2 skipped, the live sample 3 released";
  EXPECT_FALSE(c.replaying());
  EXPECT_FALSE(c.drops(kEkf, kState));
  EXPECT_EQ(c.stats().cut_short, 1u);
}

TEST(CatchUp, SyncDue_OnceAfterEachNewFrame) {
  CatchUp c = make(16);
  EXPECT_TRUE(c.sync_due(kEkf, 10)) << "frames went out, no Sync yet";
  EXPECT_FALSE(c.sync_due(kEkf, 11)) << "the Sync itself was the 11th";
  EXPECT_TRUE(c.sync_due(kEkf, 12)) << "a frame after the Sync";
  EXPECT_TRUE(c.sync_due(kController, 1)) << "per service";
  EXPECT_FALSE(c.sync_due(kController, 2)) << "the Sync still waiting, or sent since: not issued again";
}

TEST(CatchUp, AColdRestart_ForgetsEveryCut) {
  CatchUp c = make(16);
  c.cut(Generation{1});
  EXPECT_FALSE(c.keep(kGyro, sample(1), 100));
  ASSERT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::Replaying);
  c.forget();
  EXPECT_FALSE(c.replaying());
  EXPECT_EQ(c.begin(Generation{1}, Nanos{0}), CatchUp::Begin::NoLog);
}

}  // namespace
}  // namespace rejuv::kernel
