// `rejuv ros2 msgs DIR [--idl FILE]...` (docs/across_hosts.md "ROS 2 names"): writes the ROS 2 interface package
// rejuv_msgs generated from the project's IDL (tools/ros2_msgs) into DIR, for a ROS 2 workspace (colcon build)
// whose nodes read the topics a graph with dds.ros2_names writes. Exit 0 written, 2 bad input (an IDL construct
// the generator does not read, at its file:line:column; an unwritable DIR).
#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "rejuv/ros2_msgs/idl.hpp"
#include "rejuv/ros2_msgs/package.hpp"

namespace rejuv::cli {

namespace {

// Every .idl of the repository's idl/ folder, sorted: the topic types.
std::vector<std::filesystem::path> project_idl() {
  std::vector<std::filesystem::path> files;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(REJUV_SOURCE_DIR) / "idl", ec)) {
    if (entry.path().extension() == ".idl") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

int ros2_msgs(std::span<const std::string_view> args) {
  std::string dir;
  std::vector<std::string> idl;
  Options opts("ros2 msgs",
               "Writes the ROS 2 interface package rejuv_msgs into DIR: a .msg per IDL struct (the CDR Rejuv writes\n"
               "under ROS 2 names, launch dds.ros2_names), package.xml and CMakeLists.txt; build it in a ROS 2\n"
               "workspace with colcon. Files whose text is unchanged are left alone.");
  opts.positional("DIR", dir, "the package folder (made if missing), e.g. ~/ros2_ws/src/rejuv_msgs")
      .repeated("--idl", "FILE", idl, "an IDL file to read instead of the repository's idl/*.idl (repeatable)");
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  std::vector<std::filesystem::path> files(idl.begin(), idl.end());
  if (files.empty()) files = project_idl();
  if (files.empty()) return refuse("ros2 msgs", std::string(REJUV_SOURCE_DIR) + "/idl: no .idl file (use --idl FILE)");
  auto defs = ros2_msgs::load_idl(files);
  if (!defs) return refuse(defs.error().to_string());
  auto package = ros2_msgs::make_package(*defs, std::string(ros2_msgs::project_version()));
  if (!package) return refuse(package.error().to_string());
  if (auto ok = ros2_msgs::write_package(*package, dir); !ok) return refuse("ros2 msgs", ok.error());
  print(stdout, "ros2 msgs: " + std::to_string(package->size() - 2) + " messages, package.xml and CMakeLists.txt in " +
                    dir + "\n");
  return static_cast<int>(Exit::Ok);
}

}  // namespace

int run_ros2(std::span<const std::string_view> args) {
  if (args.empty() || args[0] == "--help" || args[0] == "-h") {
    print(args.empty() ? stderr : stdout,
          "usage: rejuv ros2 msgs DIR [--idl FILE]...\n\n"
          "ROS 2 interop (docs/across_hosts.md \"ROS 2 names\"):\n"
          "  rejuv ros2 msgs DIR    the interface package rejuv_msgs generated from idl/*.idl, into DIR\n\n"
          "'rejuv ros2 msgs --help' shows its options.\n");
    return static_cast<int>(args.empty() ? Exit::BadInput : Exit::Ok);
  }
  if (args[0] == "msgs") return ros2_msgs(args.subspan(1));
  return refuse("ros2", "unknown subcommand '" + std::string(args[0]) + "': expected msgs (rejuv ros2 --help)");
}

}  // namespace rejuv::cli
