// `rejuv_ros2_msgs_gen OUT_DIR FILE.idl...`: writes the ROS 2 interface package rejuv_msgs generated from the
// IDL files into OUT_DIR (package.hpp). The build runs it over idl/*.idl (tools/ros2_msgs/CMakeLists.txt);
// `rejuv ros2 msgs DIR` is the same for a user. Exit 0 written, 2 bad input (the IDL error at file:line:column).
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "rejuv/ros2_msgs/idl.hpp"
#include "rejuv/ros2_msgs/package.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: rejuv_ros2_msgs_gen OUT_DIR FILE.idl...\n");
    return 2;
  }
  const std::vector<std::filesystem::path> files(argv + 2, argv + argc);
  auto defs = rejuv::ros2_msgs::load_idl(files);
  if (!defs) {
    std::fprintf(stderr, "%s\n", defs.error().to_string().c_str());
    return 2;
  }
  auto package = rejuv::ros2_msgs::make_package(*defs, std::string(rejuv::ros2_msgs::project_version()));
  if (!package) {
    std::fprintf(stderr, "%s\n", package.error().to_string().c_str());
    return 2;
  }
  if (auto ok = rejuv::ros2_msgs::write_package(*package, argv[1]); !ok) {
    std::fprintf(stderr, "rejuv_ros2_msgs_gen: %s\n", ok.error().c_str());
    return 2;
  }
  return 0;
}
