// `rejuv new service NAME [--topic TYPE] [--out DIR]` (docs/writing_a_service.md): writes a buildable
// out-of-tree service — its source (run_service), an IDL for its topic, CMake with configure dependencies,
// a policy fragment, a launch fragment, a graph that includes the project's hover with the fragments, and a
// multi-process test — that builds against the installed SDK (find_package(Rejuv)) and flies as written.
#include <array>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "args.hpp"
#include "commands.hpp"

namespace rejuv::cli {

namespace {

// Services of the project's graphs: a new one of the same name would collide with them in a composed graph.
constexpr std::array<std::string_view, 10> kProjectServices = {
    "sensors", "ekf2", "lqr_control", "safety_control", "gen_set_point", "commander", "checkpoint_p",
    "output_driver", "ext_link", "plant"};
// Words the name becomes in C, C++, IDL and CMake, where a keyword would not compile.
constexpr std::array<std::string_view, 40> kReserved = {
    "module", "struct", "union", "enum", "typedef", "const", "long", "short", "double", "float", "char",
    "boolean", "octet", "string", "sequence", "any", "int", "unsigned", "void", "class", "namespace",
    "template", "public", "private", "return", "if", "else", "for", "while", "do", "switch", "case",
    "default", "new", "delete", "auto", "static", "main", "test", "all"};

bool is_identifier(std::string_view s, bool lower_only) {
  if (s.empty() || s.size() > 40 || !std::isalpha(static_cast<unsigned char>(s[0]))) return false;
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (!(std::isalnum(u) || c == '_')) return false;
    if (lower_only && std::isupper(u)) return false;
  }
  return true;
}

template <std::size_t N>
bool one_of(const std::array<std::string_view, N>& list, std::string_view s) {
  for (const std::string_view w : list) {
    if (w == s) return true;
  }
  return false;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// What the templates are filled with.
struct Names {
  std::string name;       // the service: geofence
  std::string module;     // its topic type's IDL module: geofence
  std::string type;       // the struct: Status
  std::string scoped;     // geofence::Status
  std::string c_struct;   // geofence_Status (idlc's C name)
  std::string topic;      // the topic it publishes: geofence_status
};

std::string fill(std::string_view text, const Names& n) {
  const std::pair<std::string_view, const std::string*> keys[] = {
      {"@NAME@", &n.name}, {"@MODULE@", &n.module}, {"@TYPE@", &n.type},
      {"@SCOPED@", &n.scoped}, {"@C_STRUCT@", &n.c_struct}, {"@TOPIC@", &n.topic}};
  std::string out;
  std::size_t i = 0;
  while (i < text.size()) {
    bool replaced = false;
    if (text[i] == '@') {
      for (const auto& [key, value] : keys) {
        if (text.substr(i, key.size()) == key) {
          out += *value;
          i += key.size();
          replaced = true;
          break;
        }
      }
    }
    if (!replaced) out += text[i++];
  }
  return out;
}

// ---- the files (kept short: each says what to change and where the guide explains it) ----

constexpr std::string_view kSource = R"txt(// @NAME@: a rejuvenated service (docs/writing_a_service.md). It reads the vehicle's state estimate and
// publishes a summary of its own type @SCOPED@ (@NAME@.idl) on `@TOPIC@` every `period_s` seconds. The kernel
// checkpoints it with the graph and rolls it back on the rejuvenation timer: everything here is restored to
// the last checkpoint at every rollback, so keep no state that must outlive one (use a Persistent object).
#include <algorithm>
#include <cstdint>

#include "@NAME@.h"  // idlc's C struct @C_STRUCT@
#include "rejuv/sdk/run.hpp"
#include "rejuv/sdk/service.hpp"

REJUV_TOPIC_TYPE(@C_STRUCT@, "@SCOPED@");

int main() {
  return rejuv::sdk::run_service([](rejuv::sdk::Service& svc) {
    using rejuv::sdk::LogLevel;
    // Its parameters are declared in @NAME@.params.pbtxt: the launch loader refuses a misspelt name or a value
    // out of range at file:line, so the value here is within the declared range.
    const double period_s = svc.param("period_s", 0.5);

    // The topics it was granted (@NAME@.policy.pbtxt): a missing grant or a wrong type is an error here, at boot.
    auto out = svc.advertise<@C_STRUCT@>("@TOPIC@");
    if (!svc.require(out, "@TOPIC@")) return 1;
    double altitude_m = 0.0;
    auto state = svc.subscribe<rejuv_msg_VehicleStateEstimate>(
        "vehicle_state", [&](const rejuv_msg_VehicleStateEstimate& m) { altitude_m = -m.p_N_m[2]; });  // NED
    if (!svc.require(state, "vehicle_state")) return 1;
    // After a rollback this process is a restored image (docs/design.md §7): said once per rollback, before any handler.
    svc.on_restored([&](rejuv::Epoch epoch) { svc.logf(LogLevel::Info, "@NAME@: restored into epoch %u", epoch.value()); });

    std::uint64_t published = 0;
    auto tick = svc.every(rejuv::to_nanos(rejuv::Seconds{period_s}), [&] {
      if (!state->valid()) return;  // nothing received yet
      ++published;
      const @C_STRUCT@ s{.received = state->received(), .published = published, .altitude_m = altitude_m};
      if (auto ok = out->publish(s); !ok) {
        svc.log(LogLevel::Warn, "publishing @TOPIC@: " + ok.error().to_string());
        return;
      }
      if (published == 1 || published % 10 == 0) {
        svc.logf(LogLevel::Info, "@NAME@: %llu states received, %llu published, altitude %.2f m",
                 static_cast<unsigned long long>(state->received()), static_cast<unsigned long long>(published),
                 altitude_m);
      }
    });
    if (!svc.require(tick, "timer")) return 1;
    return svc.run();  // Ready, then deliveries and timer ticks until the kernel shuts the graph down
  });
}
)txt";

constexpr std::string_view kIdl = R"txt(// @NAME@'s topic type (docs/writing_a_service.md "A new topic type"): rejuv_add_topics() in CMakeLists.txt
// builds the C struct @C_STRUCT@ and declares it to the policy with the size the compiler gave it.
module @MODULE@ {
  @final struct @TYPE@ {
    unsigned long long received;   // vehicle_state messages received
    unsigned long long published;  // @TOPIC@ messages published
    double altitude_m;             // the latest altitude estimate [m]
  };
};
)txt";

constexpr std::string_view kParams = R"txt(# @NAME@'s parameters (docs/writing_a_service.md "Declaring parameters"): the launch loader refuses an
# undeclared name or a value outside its range at the launch file's line; `rejuv run --help-service @NAME@ GRAPH`
# lists them. rejuv_add_service(... PARAMS) installs this file beside the executable.
service: "@NAME@"
params {
  name: "period_s"
  type: NUMBER
  min: 0.01
  max: 10
  default_number: 0.5
  unit: "s"
  help: "how often @TOPIC@ is published"
}
)txt";

constexpr std::string_view kPolicy = R"txt(# @NAME@'s policy fragment (docs/writing_a_service.md "Graph fragments"): its service entry, its topic and its
# grants, merged into the graph's policy by the launch fragment's `policy_include`. A topic type of its own is
# declared by the build (rejuv_add_topics writes <build>/@NAME@_topics.types.pbtxt, included by the graph).
services { name: "@NAME@" }

# What it publishes; the kernel records it (KERNEL_SUBSCRIBES), so it needs no reader in the graph.
objects {
  name: "@TOPIC@" kind: TOPIC type: "@SCOPED@"
  kernel: KERNEL_SUBSCRIBES
}

# Read the state estimate and write its own topic in every mode. A grant it lacks is refused at boot with the
# line to add; `rejuv audit` prints the whole matrix.
grants { service: "@NAME@" object: "vehicle_state" rights: "R" modes: [MC, RB, SC, UPDATE, CP] }
grants { service: "@NAME@" object: "@TOPIC@" rights: "W" modes: [MC, RB, SC, UPDATE, CP] }
)txt";

constexpr std::string_view kLaunch = R"txt(# @NAME@'s launch fragment (docs/writing_a_service.md "Graph fragments"): its entry in a graph and the policy
# fragment that grants it. A graph includes it (`include: "@NAME@.launch.pbtxt"`); paths are relative to this file.
policy_include: "@NAME@.policy.pbtxt"

services {
  name: "@NAME@"
  executable: "@NAME@"          # found in the graph's `service_path` (its build folder)
  uses { object: "vehicle_state" rights: "R" }
  uses { object: "@TOPIC@" rights: "W" }
  params { name: "period_s" number: 0.5 }   # declared in @NAME@.params.pbtxt
}
)txt";

constexpr std::string_view kGraph = R"txt(# @NAME@ flown in the project's hover graph with rejuvenation on: CMake writes this file into the build folder
# as @NAME@_flight.launch.pbtxt (the project's graphs are where the installed package puts them), then
#     rejuv run <build>/@NAME@_flight.launch.pbtxt --duration 10
include: "@REJUV_LAUNCH_DIR@/hover.launch.pbtxt"
include: "@CMAKE_CURRENT_SOURCE_DIR@/@NAME@.launch.pbtxt"
policy_include: "@NAME@_topics.types.pbtxt"   # @SCOPED@ as built (this build folder)
service_path: "."                         # @NAME@'s executable: this build folder
name: "@NAME@"
sr { enabled: true }                      # the hover's SR parameters, rejuvenation on
)txt";

constexpr std::string_view kCMake = R"txt(# @NAME@: a Rejuv service built against the installed SDK (docs/writing_a_service.md):
#   cmake -S . -B build -G Ninja -DCMAKE_PREFIX_PATH=<the SDK's prefix>
#   cmake --build build && ctest --test-dir build --output-on-failure
#   rejuv run build/@NAME@_flight.launch.pbtxt --duration 10
cmake_minimum_required(VERSION 3.22)
project(@NAME@ LANGUAGES C CXX)

find_package(Rejuv 0.1 REQUIRED)

# Its topic type @SCOPED@ (@NAME@.idl): the C struct, and the policy's `types` entry with the size as built
# (<build>/@NAME@_topics.types.pbtxt, which the flight graph includes).
rejuv_add_topics(@NAME@_topics FILES @NAME@.idl TYPES @SCOPED@)
# The service, linked the way the kernel expects, with its declared parameters beside the executable.
rejuv_add_service(@NAME@ SOURCES @NAME@.cpp LIBRARIES @NAME@_topics PARAMS @NAME@.params.pbtxt)

# The graph to fly: the project's hover with this service's fragments (configure_file: an edit configures again).
configure_file(@NAME@_flight.launch.pbtxt.in @NAME@_flight.launch.pbtxt @ONLY)

# A multi-process test: the real kernel flies the graph for 5 s with rejuvenation, and the service's own log
# line must show that it received and published. It runs the `rejuv` program built with the installed SDK (the
# package names it); -DREJUV_PROGRAM= chooses another. Without one the test is still there, and fails saying so.
set(REJUV_PROGRAM "${REJUV_PACKAGE_PROGRAM}" CACHE FILEPATH "the rejuv program, for the test")
set(REJUV_DDS_DOMAIN 0 CACHE STRING "the DDS domain of the test's flight (apart from other runs on the machine)")
enable_testing()
if(EXISTS "${REJUV_PROGRAM}")
  add_test(NAME @NAME@_flies
           COMMAND ${REJUV_PROGRAM} run ${CMAKE_CURRENT_BINARY_DIR}/@NAME@_flight.launch.pbtxt --duration 5
                   --net-port 0 --domain ${REJUV_DDS_DOMAIN})
  set_tests_properties(@NAME@_flies PROPERTIES
                       PASS_REGULAR_EXPRESSION "@NAME@: [1-9][0-9]* states received, [1-9][0-9]* published"
                       FAIL_REGULAR_EXPRESSION "publishing @TOPIC@|error:")
else()
  add_test(NAME @NAME@_flies
           COMMAND ${CMAKE_COMMAND} -E echo "error: no rejuv program at '${REJUV_PROGRAM}' (the SDK's build tree \
was removed or moved?): build the Rejuv tree the SDK was installed from, or configure with \
-DREJUV_PROGRAM=/path/to/rejuv")
  set_tests_properties(@NAME@_flies PROPERTIES FAIL_REGULAR_EXPRESSION "error:")
endif()
)txt";

// The CMake template keeps @REJUV_LAUNCH_DIR@ and @CMAKE_CURRENT_SOURCE_DIR@ for configure_file.
std::string fill_graph(const Names& n) { return fill(kGraph, n); }

struct File {
  std::string name;
  std::string text;
};

std::vector<File> files_of(const Names& n) {
  return {{n.name + ".cpp", fill(kSource, n)},
          {n.name + ".idl", fill(kIdl, n)},
          {n.name + ".params.pbtxt", fill(kParams, n)},
          {n.name + ".policy.pbtxt", fill(kPolicy, n)},
          {n.name + ".launch.pbtxt", fill(kLaunch, n)},
          {n.name + "_flight.launch.pbtxt.in", fill_graph(n)},
          {"CMakeLists.txt", fill(kCMake, n)}};
}

std::optional<std::string> names_of(const std::string& name, const std::optional<std::string>& topic, Names& n) {
  if (!is_identifier(name, true)) {
    return "NAME \"" + name + "\": expected a lower-case identifier of at most 40 characters ([a-z][a-z0-9_]*)";
  }
  if (one_of(kProjectServices, name)) {
    return "NAME \"" + name + "\" is a service of the project's graphs: choose another name";
  }
  if (one_of(kReserved, name)) {
    return "NAME \"" + name + "\" is a keyword of C, C++, IDL or CMake: choose another name";
  }
  n.name = name;
  n.module = name;
  n.type = "Status";
  if (topic) {
    const std::size_t sep = topic->find("::");
    const std::string module = sep == std::string::npos ? "" : topic->substr(0, sep);
    const std::string type = sep == std::string::npos ? "" : topic->substr(sep + 2);
    if (!is_identifier(module, false) || !is_identifier(type, false) || one_of(kReserved, module) ||
        one_of(kReserved, type) || module == "rejuv") {
      return "--topic \"" + *topic + "\": expected an IDL type module::Struct of two identifiers, outside rejuv::";
    }
    n.module = module;
    n.type = type;
  }
  n.scoped = n.module + "::" + n.type;
  n.c_struct = n.module + "_" + n.type;
  n.topic = name + "_" + lower(n.type);
  return std::nullopt;
}

}  // namespace

int run_new(std::span<const std::string_view> args) {
  std::string what, name;
  std::optional<std::string> topic;
  std::optional<std::filesystem::path> out;
  Options opts("new",
               "Writes a new piece for a graph.\n"
               "  service NAME  an out-of-tree service: NAME.cpp (run_service), NAME.idl (its topic type),\n"
               "                NAME.params.pbtxt (declared parameters), NAME.policy.pbtxt and NAME.launch.pbtxt\n"
               "                (its graph fragments), NAME_flight.launch.pbtxt.in (the project's hover with them)\n"
               "                and CMakeLists.txt (built against the installed SDK, with a multi-process test).\n"
               "                docs/writing_a_service.md walks through it.\n"
               "Exit 0 when written, 2 on bad input or when DIR exists and is not empty (nothing is overwritten).");
  opts.positional("WHAT", what, "what to write: service")
      .positional("NAME", name, "the service's name (a lower-case identifier)")
      .text("--topic", "TYPE", topic, "the IDL type of the topic it publishes (module::Struct)", "NAME::Status")
      .path("--out", "DIR", out, "where the files go", "./NAME");
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (what != "service") return refuse("new", "unknown piece '" + what + "' (expected: service)");
  Names n;
  if (const auto error = names_of(name, topic, n)) return refuse("new", *error);

  const std::filesystem::path dir = out ? *out : std::filesystem::path(name);
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) &&
      (!std::filesystem::is_directory(dir, ec) || !std::filesystem::is_empty(dir, ec))) {
    return refuse("new", dir.string() + " exists and is not an empty folder: nothing written (choose --out DIR)");
  }
  std::filesystem::create_directories(dir, ec);
  if (ec) return refuse("new", "cannot create " + dir.string() + ": " + ec.message());
  for (const File& f : files_of(n)) {
    const std::filesystem::path path = dir / f.name;
    std::ofstream file(path, std::ios::binary);
    file << f.text;
    file.close();
    if (!file) return refuse("new", "cannot write " + path.string());
  }
  print(stdout, "rejuv new: service \"" + n.name + "\" written to " + dir.string() + "/ (topic `" + n.topic +
                    "` of type " + n.scoped + ")\n"
                    "next:\n"
                    "  cmake -S " + dir.string() + " -B " + (dir / "build").string() +
                    " -G Ninja -DCMAKE_PREFIX_PATH=<the SDK's prefix>\n"
                    "  cmake --build " + (dir / "build").string() + "\n"
                    "  rejuv run " + (dir / "build" / (n.name + "_flight.launch.pbtxt")).string() +
                    " --duration 10\n"
                    "docs/writing_a_service.md explains each file.\n");
  return static_cast<int>(Exit::Ok);
}

}  // namespace rejuv::cli
