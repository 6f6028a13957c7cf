// The graph-wide keys of rejuv/core/graph_values.hpp end to end: the kernel's encoding through the boot script's
// codec (kernel_sim/channel boot.hpp) to a service's typed read (flight_io::read), the range each key refuses
// with its name, the default a missing key gives, and that every key's name is spelt once in the tree.
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "rejuv/channel/boot.hpp"
#include "rejuv/core/graph_values.hpp"
#include "rejuv/flight_io/params.hpp"

namespace rejuv::flight_io {
namespace {

namespace gv = graph_values;
using namespace std::chrono_literals;

// What a service receives for `value` of `key`: the kernel's encoding, the BootParam frame's bytes, the SDK's
// decoding, and the Params a service reads from.
template <class T>
Params received(const gv::Key<T>& key, T value) {
  const wire::BootParam frame = channel::encode_boot_param(channel::boot_param_of(key.name, gv::encode(key, value)));
  const channel::BootParamEntry entry = channel::decode_boot_param(frame);
  EXPECT_EQ(entry.name, key.name);
  const std::optional<gv::Value> v = channel::value_of(entry);
  EXPECT_TRUE(v.has_value());
  std::map<std::string, gv::Value, std::less<>> table;
  if (v) table.emplace(std::string(entry.name), *v);
  return Params::from_table(std::move(table));
}

// A value of each key inside its range and other than its default.
template <class T>
void expect_round_trip(const gv::Key<T>& key, T value) {
  ASSERT_NE(value, key.fallback) << key.name;
  const auto back = read(received(key, value), key);
  ASSERT_TRUE(back) << back.error().to_string();
  EXPECT_EQ(*back, value) << key.name;
}

TEST(GraphValues, EveryKey_KernelToService_RoundTrips) {
  expect_round_trip(gv::kEnabled, false);
  expect_round_trip(gv::kTmc, Nanos{123'456'789});
  expect_round_trip(gv::kTest, Nanos{2'500'000'001});
  expect_round_trip(gv::kRhoM, 0.25);
  expect_round_trip(gv::kRhoS, 0.125);
  expect_round_trip(gv::kTmin, Nanos{0});
  expect_round_trip(gv::kCheckPeriod, Nanos{1'000});
  expect_round_trip(gv::kKeepGenerations, std::uint32_t{16});
  expect_round_trip(gv::kRestrictedLimitFraction, 1.0);
  expect_round_trip(gv::kBoxPosition, 0.75);
  expect_round_trip(gv::kBoxVelocity, 2.5);
  expect_round_trip(gv::kBoxAngle, 0.35);
  expect_round_trip(gv::kBoxRate, 3.0);
  expect_round_trip(gv::kRearmEnabled, false);
  for (const gv::Key<double>* key : gv::kRearmStds) expect_round_trip(*key, key->fallback * 3.0);
  expect_round_trip(gv::kFlightStart, Nanos{4'000'000'003});
}

TEST(GraphValues, Duration_CrossesAsWholeNanoseconds) {
  const wire::BootParam frame =
      channel::encode_boot_param(channel::boot_param_of(gv::kTmc.name, gv::encode(gv::kTmc, Nanos{300'000'000})));
  EXPECT_EQ(frame.is_integer, 1);
  EXPECT_EQ(frame.integer, 300'000'000);
  // The launch file's seconds become the nearest ns, and a service's Seconds are the file's again.
  EXPECT_EQ(gv::nanos_of_seconds(0.3), Nanos{300'000'000});
  EXPECT_EQ(to_seconds(gv::nanos_of_seconds(0.3)).count(), 0.3);
  EXPECT_EQ(to_seconds(gv::nanos_of_seconds(0.002)).count(), 0.002);
}

TEST(GraphValues, Duration_AsDouble_RefusedNamingTheKey) {
  const auto t = read(Params::from_table({{std::string(gv::kTmc.name), 0.3}}), gv::kTmc);
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().where, gv::kTmc.name);
  EXPECT_NE(t.error().message.find("nanoseconds"), std::string::npos) << t.error().to_string();
}

TEST(GraphValues, DurationOutOfRange_RefusedNamingKeyValueAndRange) {
  for (const gv::Key<Nanos>* key : {&gv::kTmc, &gv::kTest, &gv::kTmin, &gv::kCheckPeriod, &gv::kFlightStart}) {
    const Nanos too_long = key->range.max + 1ns;
    const auto v = read(received(*key, too_long), *key);
    ASSERT_FALSE(v) << key->name;
    EXPECT_EQ(v.error().kind, InputError::OutOfRange);
    EXPECT_EQ(v.error().where, key->name);
    const std::string text = v.error().to_string();
    EXPECT_NE(text.find(gv::range_text(*key)), std::string::npos) << text;
  }
  const auto zero = read(received(gv::kTmc, Nanos{0}), gv::kTmc);
  ASSERT_FALSE(zero);
  EXPECT_EQ(zero.error().to_string(), "sr.t_mc_s: out of range: expected 0 < T_MC ≤ 10 s, got 0 s");
}

TEST(GraphValues, NumberOutOfRange_RefusedNamingTheKey) {
  for (const gv::Key<double>* key : {&gv::kRhoM, &gv::kRhoS, &gv::kRestrictedLimitFraction, &gv::kBoxPosition,
                                     &gv::kBoxVelocity, &gv::kBoxAngle, &gv::kBoxRate}) {
    const auto v = read(received(*key, 0.0), *key);
    ASSERT_FALSE(v) << key->name;
    EXPECT_EQ(v.error().kind, InputError::OutOfRange);
    EXPECT_EQ(v.error().where, key->name);
  }
  const auto fraction = read(received(gv::kRestrictedLimitFraction, 1.5), gv::kRestrictedLimitFraction);
  ASSERT_FALSE(fraction);
  EXPECT_EQ(fraction.error().message, "expected 0 < Ū ≤ 1, got 1.5");
  const auto nan = read(Params::from_table({{std::string(gv::kBoxAngle.name), std::nan("")}}), gv::kBoxAngle);
  ASSERT_FALSE(nan);
  EXPECT_EQ(nan.error().kind, InputError::NotFinite);
}

TEST(GraphValues, CountAndSwitchOutOfRange_Refused) {
  const auto k = read(received(gv::kKeepGenerations, std::uint32_t{17}), gv::kKeepGenerations);
  ASSERT_FALSE(k);
  EXPECT_EQ(k.error().where, gv::kKeepGenerations.name);
  EXPECT_FALSE(read(received(gv::kKeepGenerations, std::uint32_t{0}), gv::kKeepGenerations));
  EXPECT_FALSE(read(Params::from_table({{std::string(gv::kKeepGenerations.name), 2.5}}), gv::kKeepGenerations));
  const auto on = read(Params::from_table({{std::string(gv::kEnabled.name), std::int64_t{2}}}), gv::kEnabled);
  ASSERT_FALSE(on);
  EXPECT_EQ(on.error().where, gv::kEnabled.name);
}

TEST(GraphValues, MissingKey_GivesTheTablesDefault) {
  const Params none = Params::from_table({});
  EXPECT_EQ(*read(none, gv::kEnabled), gv::kEnabled.fallback);
  EXPECT_EQ(*read(none, gv::kTmc), 300ms);
  EXPECT_EQ(*read(none, gv::kTest), 3s);
  EXPECT_EQ(*read(none, gv::kTmin), 20ms);
  EXPECT_EQ(*read(none, gv::kCheckPeriod), 2ms);
  EXPECT_EQ(*read(none, gv::kKeepGenerations), 2U);
  EXPECT_EQ(*read(none, gv::kFlightStart), Nanos{0});
  for (const gv::Key<double>* key : {&gv::kRhoM, &gv::kRhoS, &gv::kRestrictedLimitFraction, &gv::kBoxPosition,
                                     &gv::kBoxVelocity, &gv::kBoxAngle, &gv::kBoxRate}) {
    EXPECT_EQ(*read(none, *key), key->fallback) << key->name;
  }
  // The flight services read the same defaults.
  const auto cycle = sr_cycle_params(none);
  ASSERT_TRUE(cycle);
  EXPECT_EQ(cycle->t_mc, to_seconds(gv::kTmc.fallback));
  EXPECT_EQ(cycle->tracking.check_period, to_seconds(gv::kCheckPeriod.fallback));
  const auto rearm = ekf_rearm(none);
  ASSERT_TRUE(rearm);
  EXPECT_EQ(rearm->position_std_m, gv::kRearmPositionStd.fallback);
}

TEST(GraphValues, EveryDefault_IsInsideItsRange) {
  for (const gv::Key<Nanos>* key : {&gv::kTmc, &gv::kTest, &gv::kTmin, &gv::kCheckPeriod}) {
    EXPECT_TRUE(gv::in_range(*key, key->fallback)) << key->name;
  }
  EXPECT_TRUE(gv::in_range(gv::kKeepGenerations, gv::kKeepGenerations.fallback));
  for (const gv::Key<double>* key : {&gv::kRhoM, &gv::kRhoS, &gv::kRestrictedLimitFraction, &gv::kBoxPosition,
                                     &gv::kBoxVelocity, &gv::kBoxAngle, &gv::kBoxRate}) {
    EXPECT_TRUE(gv::in_range(*key, key->fallback)) << key->name;
  }
  for (const gv::Key<double>* key : gv::kRearmStds) EXPECT_TRUE(gv::in_range(*key, key->fallback)) << key->name;
}

TEST(GraphValues, Table_HasNoDuplicateName) {
  const std::set<std::string_view> names(gv::kAllNames.begin(), gv::kAllNames.end());
  EXPECT_EQ(names.size(), gv::kAllNames.size());
  for (std::string_view name : gv::kAllNames) {
    EXPECT_TRUE(name.starts_with("sr.") || name.starts_with("flight.")) << name;
  }
}

TEST(GraphValues, RearmStd_FindsEachFieldByName) {
  for (const gv::Key<double>* key : gv::kRearmStds) EXPECT_EQ(gv::rearm_std(gv::field_of(key->name)), key);
  EXPECT_EQ(gv::rearm_std("no_such_std"), nullptr);
}

// The lines of C++ code (comments dropped) under `dir` where a string literal starts with `name`
// ("sr.t_mc_s", "sr.t_mc_s (T_MC) must ..."), as "file:line".
std::vector<std::string> literals_of(const std::filesystem::path& dir, std::string_view name) {
  std::vector<std::string> out;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    const std::string ext = entry.path().extension().string();
    if (!entry.is_regular_file() || (ext != ".cpp" && ext != ".hpp")) continue;
    std::ifstream in(entry.path());
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) {
      const std::size_t comment = line.find("//");
      const std::string code = line.substr(0, comment);
      const std::string quoted = "\"" + std::string(name);
      for (std::size_t at = code.find(quoted); at != std::string::npos; at = code.find(quoted, at + 1)) {
        const char next = at + quoted.size() < code.size() ? code[at + quoted.size()] : '\0';
        if (std::isalnum(static_cast<unsigned char>(next)) || next == '_' || next == '.') continue;
        out.push_back(entry.path().string() + ":" + std::to_string(n));
      }
    }
  }
  return out;
}

TEST(GraphValues, EveryName_IsSpeltOnceInTheCode) {
  const std::filesystem::path root = REJUV_SOURCE_DIR;
  for (std::string_view name : gv::kAllNames) {
    std::vector<std::string> found;
    for (const char* dir : {"kernel_sim", "services", "tools", "plant"}) {
      for (std::string& at : literals_of(root / dir, name)) found.push_back(std::move(at));
    }
    ASSERT_EQ(found.size(), 1U) << name << " is spelt in: " << ::testing::PrintToString(found);
    EXPECT_NE(found.front().find("rejuv/core/graph_values.hpp"), std::string::npos) << found.front();
  }
}

}  // namespace
}  // namespace rejuv::flight_io
