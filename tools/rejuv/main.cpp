// `rejuv`: the command-line program (docs/design.md §10). Dispatches to one subcommand.
#include <cstdio>
#include <span>
#include <string_view>
#include <vector>

#include "args.hpp"
#include "commands.hpp"

namespace {

struct Command {
  std::string_view name;
  std::string_view summary;
  int (*run)(std::span<const std::string_view>);
};

constexpr Command kCommands[] = {
    {"audit", "check a capability policy against the SR invariants and print its matrix",
     rejuv::cli::run_audit},
    {"run", "run a launch graph on the multi-process runtime (kernel, services, plant)", rejuv::cli::run_run},
    {"gcs", "ground station: upload a mission over the network gate and show telemetry", rejuv::cli::run_gcs},
    {"bench", "benchmarks side by side: `bench images` (checkpoint/rollback vs cold restart)", rejuv::cli::run_bench},
    {"sim", "model-level simulation of the SR scheme in one process (no runtime)", rejuv::cli::run_sim},
    {"report", "`report table`: Table I, runtime beside model; `report figures DIR`: a --out run's Figs. 7-10 again",
     rejuv::cli::run_report},
    {"faults", "fault campaign: kill or stop any process at any SR phase; recovery, safety, leaks (docs/design.md §11)",
     rejuv::cli::run_faults},
    {"soak", "fly a graph with SR and attacks for N cycles; fail if memory, fds or processes grow",
     rejuv::cli::run_soak},
    {"sweep", "a grid of launch parameters on the model and/or the runtime: Fig. 11's T_MC x T_est maps (§VI-D)",
     rejuv::cli::run_sweep},
    {"new", "`new service NAME`: a buildable out-of-tree service with its graph fragments and a test",
     rejuv::cli::run_new},
    {"keys", "DDS Security for a graph across hosts: `keys init DIR` (a CA), `keys hosts DIR --launch GRAPH`",
     rejuv::cli::run_keys},
    {"ros2", "ROS 2 interop: `ros2 msgs DIR` writes the interface package rejuv_msgs generated from idl/*.idl",
     rejuv::cli::run_ros2},
};

void print_usage(std::FILE* to) {
  std::fprintf(to, "usage: rejuv <command> [options]\n\ncommands:\n");
  for (const Command& c : kCommands) {
    std::fprintf(to, "  %-10.*s %.*s\n", static_cast<int>(c.name.size()), c.name.data(),
                 static_cast<int>(c.summary.size()), c.summary.data());
  }
  std::fprintf(to, "\n'rejuv <command> --help' shows the options of a command.\n");
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string_view> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    print_usage(args.empty() ? stderr : stdout);
    return static_cast<int>(args.empty() ? rejuv::cli::Exit::BadInput : rejuv::cli::Exit::Ok);
  }
  for (const Command& c : kCommands) {
    if (c.name == args[0]) {
      return c.run(std::span(args).subspan(1));
    }
  }
  std::fprintf(stderr, "rejuv: unknown command '%.*s'\n\n", static_cast<int>(args[0].size()), args[0].data());
  print_usage(stderr);
  return static_cast<int>(rejuv::cli::Exit::BadInput);
}
