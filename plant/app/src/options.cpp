#include "rejuv/plant_app/options.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <system_error>
#include <utility>

namespace rejuv::plant_app {

namespace {

// The help text before and after the lockstep timeouts' lines: usage() states their defaults from PlantOptions{},
// so that each is spelt once (options.hpp).
constexpr std::string_view kUsageHead =
    "usage: rejuv_plant [options]\n"
    "The plant process of Rejuv: a quadrotor (6-DOF, RK4 at 1 kHz), its sensors and optional wind, talking\n"
    "DDS to the kernel like jMAVSim over sockets (paper §VI-A). Publishes "
    "rejuv/sensor_{gyro,accel,mag,baro,gps},\n"
    "rejuv/ground_truth and (lockstep) rejuv/sim_step; subscribes rejuv/actuator_outputs and "
    "rejuv/sim_step_ack.\n"
    "Reads its Cyclone DDS configuration from CYCLONEDDS_URI.\n"
    "\n"
    "  --domain N               DDS domain id, 0..232 (default 0)\n"
    "  --run-id HEX             the run's id, 16 hex digits: every endpoint in the DDS partition rejuv.HEX,\n"
    "                           the kernel's bridge's (default: the default partition)\n"
    "  --dds-names rejuv|ros2   the topics' DDS names: rejuv/<topic> (default) or ROS 2's rt/<topic> with the\n"
    "                           rejuv_msgs types (docs/across_hosts.md \"ROS 2 names\")\n"
    "  --seed N                 seed of sensor noise and wind, unsigned 64-bit (default 1)\n"
    "  --clock lockstep|realtime  time master (default lockstep: the plant steps, the kernel acknowledges)\n"
    "  --start-north M          start position, NED metres (default 0)\n"
    "  --start-east M           (default 0)\n"
    "  --start-down M           (default -3, i.e. 3 m above home); the vehicle starts in a trimmed hover\n"
    "  --duration S             stop after S seconds (simulated in lockstep, real in realtime); 0 = until a "
    "signal\n"
    "  --align-s S              pre-flight alignment: rest at the start pose for S seconds with the sensors\n"
    "                           publishing and actuator outputs not applied (default 20, as rejuv sim)\n"
    "  --step-ms MS             lockstep step, 1..1000 (default 4); the ground-truth period in realtime\n";
constexpr std::string_view kUsageTail =
    "  --wind-mean M/S          mean wind speed (default 0)\n"
    "  --wind-toward DEG        where the mean wind blows toward, degrees clockwise from north, [0, 360)\n"
    "                           (default 0: toward north; 90: toward east)\n"
    "  --wind-gust M/S          gust intensity, 1 sigma per axis (default 0)\n"
    "  --help                   this text\n"
    "\n"
    "Exit status: 0 done (duration, SIGINT, SIGTERM), 1 DDS/system failure, 2 bad command line,\n"
    "3 kernel lost (lockstep).\n";

template <class Int>
Result<Int, std::string> parse_int(std::string_view flag, std::string_view text, Int lo, Int hi) {
  Int value{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size() || value < lo || value > hi) {
    return fail(std::string(flag) + ": expected an integer in [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "], got '" + std::string(text) + "'");
  }
  return value;
}

Result<double, std::string> parse_double(std::string_view flag, std::string_view text, double lo, double hi) {
  double value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size() || !std::isfinite(value) || value < lo ||
      value > hi) {
    return fail(std::string(flag) + ": expected a number in [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "], got '" + std::string(text) + "'");
  }
  return value;
}

Nanos millis(std::int64_t ms) {
  return std::chrono::milliseconds{ms};
}

constexpr std::array<std::string_view, 16> kFlags{
    "--domain",   "--run-id",  "--dds-names",  "--seed",    "--clock",          "--start-north",        "--start-east", "--start-down",
    "--duration", "--step-ms", "--ack-timeout-ms", "--connect-timeout-ms", "--wind-mean",  "--wind-gust",
    "--align-s",  "--wind-toward"};

constexpr double kMaxPosition_m = 1e4;
constexpr double kMaxDuration_s = 1e7;  // ~115 days
constexpr double kMaxWind_m_s = 50;
constexpr double kMaxAlignment_s = 3600;

// A flag that takes one of two names: sets `field` to the value named `value`, else the error naming both.
template <class E>
Result<void, std::string> choose(E& field, std::string_view flag, std::string_view value,
                                 std::pair<std::string_view, E> first, std::pair<std::string_view, E> second) {
  for (const auto& [name, e] : {first, second}) {
    if (value == name) {
      field = e;
      return {};
    }
  }
  return fail(std::string(flag) + ": expected " + std::string(first.first) + " or " + std::string(second.first) +
              ", got '" + std::string(value) + "'");
}

// Applies one flag's value to the options.
Result<void, std::string> apply(PlantOptions& o, std::string_view flag, std::string_view value) {
  auto assign = [](auto& field, auto parsed) -> Result<void, std::string> {
    if (!parsed) {
      return fail(parsed.error());
    }
    field = *parsed;
    return {};
  };
  if (flag == "--domain") return assign(o.domain, parse_int<std::uint32_t>(flag, value, 0, 232));
  if (flag == "--run-id") return assign(o.run_id, dds::parse_run_id(flag, value));
  if (flag == "--dds-names") {
    return choose(o.naming, flag, value, {to_string(DdsNaming::Rejuv), DdsNaming::Rejuv},
                  {to_string(DdsNaming::Ros2), DdsNaming::Ros2});
  }
  if (flag == "--seed") {
    return assign(o.seed,
                  parse_int<std::uint64_t>(flag, value, 0, std::numeric_limits<std::uint64_t>::max()));
  }
  if (flag == "--clock") {
    return choose(o.clock, flag, value, {"lockstep", ClockMode::Lockstep}, {"realtime", ClockMode::Realtime});
  }
  if (flag == "--start-north")
    return assign(o.start_N_m.x(), parse_double(flag, value, -kMaxPosition_m, kMaxPosition_m));
  if (flag == "--start-east")
    return assign(o.start_N_m.y(), parse_double(flag, value, -kMaxPosition_m, kMaxPosition_m));
  // Down ≤ 0: the ground is z = 0 (plant/quadrotor.hpp), the vehicle cannot start below it.
  if (flag == "--start-down") return assign(o.start_N_m.z(), parse_double(flag, value, -kMaxPosition_m, 0));
  if (flag == "--duration") {
    auto s = parse_double(flag, value, 0, kMaxDuration_s);
    if (!s) {
      return fail(s.error());
    }
    o.duration = to_nanos(Seconds{*s});
    return {};
  }
  if (flag == "--align-s") {
    auto s = parse_double(flag, value, 0, kMaxAlignment_s);
    if (!s) return fail(s.error());
    o.alignment = std::chrono::round<Nanos>(Seconds{*s});
    return {};
  }
  if (flag == "--step-ms") {
    auto ms = parse_int<std::int64_t>(flag, value, 1, 1000);
    if (!ms) return fail(ms.error());
    o.step = millis(*ms);
    return {};
  }
  if (flag == "--ack-timeout-ms" || flag == "--connect-timeout-ms") {
    auto ms = parse_int<std::int64_t>(flag, value, 1, 3'600'000);
    if (!ms) return fail(ms.error());
    (flag == "--ack-timeout-ms" ? o.ack_timeout : o.connect_timeout) = millis(*ms);
    return {};
  }
  if (flag == "--wind-mean")
    return assign(o.wind_mean_m_s, parse_double(flag, value, -kMaxWind_m_s, kMaxWind_m_s));
  if (flag == "--wind-toward") {
    auto deg = parse_double(flag, value, 0, 360);
    if (deg && *deg == 360.0) return fail("--wind-toward: expected degrees in [0, 360), got '" + std::string(value) + "'");
    return assign(o.wind_toward_deg, std::move(deg));
  }
  if (flag == "--wind-gust") return assign(o.wind_gust_m_s, parse_double(flag, value, 0, kMaxWind_m_s));
  return fail("unknown option '" + std::string(flag) + "' (see --help)");
}

}  // namespace

std::string_view usage() {
  static const std::string text = [] {
    const PlantOptions defaults{};
    const auto ms = [](Nanos t) {
      return std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(t).count());
    };
    return std::string(kUsageHead) +
           "  --ack-timeout-ms MS      lockstep: exit 3 when no ack arrives for this long (default " +
           ms(defaults.ack_timeout) + ")\n" +
           "  --connect-timeout-ms MS  lockstep: exit 3 when the kernel's endpoints do not appear (default " +
           ms(defaults.connect_timeout) + ")\n" + std::string(kUsageTail);
  }();
  return text;
}

std::string_view to_string(ClockMode mode) {
  switch (mode) {
    case ClockMode::Lockstep: return "lockstep";
    case ClockMode::Realtime: return "realtime";
  }
  return "?";
}

Result<PlantCommand, std::string> parse_options(std::span<const std::string_view> args) {
  PlantOptions options;
  std::set<std::string_view, std::less<>> seen;
  for (std::size_t i = 0; i < args.size(); ++i) {
    std::string_view flag = args[i];
    if (flag == "--help" || flag == "-h") {
      return PlantCommand{ShowHelp{}};
    }
    if (!flag.starts_with("--")) {
      return fail("unexpected argument '" + std::string(flag) + "' (see --help)");
    }
    std::optional<std::string_view> value;
    if (const auto eq = flag.find('='); eq != std::string_view::npos) {  // --flag=value
      value = flag.substr(eq + 1);
      flag = flag.substr(0, eq);
    } else if (i + 1 < args.size()) {  // --flag value
      value = args[++i];
    }
    if (std::find(kFlags.begin(), kFlags.end(), flag) == kFlags.end()) {
      return fail("unknown option '" + std::string(flag) + "' (see --help)");
    }
    if (!value) {
      return fail(std::string(flag) + ": missing value (see --help)");
    }
    if (!seen.insert(flag).second) {
      return fail(std::string(flag) + ": given twice");
    }
    if (auto ok = apply(options, flag, *value); !ok) {
      return fail(ok.error());
    }
  }
  return PlantCommand{options};
}

}  // namespace rejuv::plant_app
