// The ROS 2 interface package rejuv_msgs generated from the project's IDL (idl.hpp): one message per IDL struct
// (every one is a topic type or nested in one), whose CDR is the struct's, so that a ROS 2 node reads what
// Cyclone wrote under the ROS 2 names (rejuv/msgs/dds_naming.hpp; docs/across_hosts.md "ROS 2 names").
//
// The mapping: boolean → bool, char → char, octet → uint8, IDL 4's (u)int8…(u)int64 and short, long, long long
// and their unsigned forms → the (u)intN of their width, float → float32, double → float64; `T x[N]` →
// `T[N] x`; a struct member → the message of that struct (same package: its bare name); an enum member →
// uint32 (CDR writes an enum as 32 bits) with the enumerators as constants of the message. A ROS 2 field name
// is lower case: a member name with capitals is written in lower case (the IDL name in the field's comment),
// refused where two members would collide or the name is not a ROS 2 field name; a struct name must be a ROS 2
// message name (CamelCase). Comments travel: a struct's as the message's, a member's after its field.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "rejuv/core/dds_name.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/ros2_msgs/idl.hpp"

namespace rejuv::ros2_msgs {

inline constexpr std::string_view kPackageName = rejuv::kRos2Package;  // rejuv/core/dds_name.hpp

// One file of the package, relative to its folder ("msg/SensorGyro.msg", "package.xml").
struct PackageFile {
  std::filesystem::path path;
  std::string text;
};

// The package's files: msg/<Struct>.msg per struct (by name, whatever the order of the IDL), package.xml (format 3, member of
// rosidl_interface_packages), CMakeLists.txt (rosidl_generate_interfaces over the messages). `version` is the
// package's (the project's). An error names the IDL member or struct that has no faithful ROS 2 form.
[[nodiscard]] Result<std::vector<PackageFile>, IdlError> make_package(const Definitions& defs, const std::string& version);

// The project's version (CMake's PROJECT_VERSION): the package's.
[[nodiscard]] std::string_view project_version();

// The .msg text of one struct (make_package writes it as msg/<name>.msg).
[[nodiscard]] Result<std::string, IdlError> make_message(const Definitions& defs, const Struct& s);

// Writes the files under `dir` (made if missing; files replaced only where their text changed, so a build that
// regenerates them rebuilds nothing downstream). The error is one line.
[[nodiscard]] Result<void, std::string> write_package(const std::vector<PackageFile>& files,
                                                      const std::filesystem::path& dir);

}  // namespace rejuv::ros2_msgs
