// The launch loader's parts (not installed): the checks of a parsed graph (validate.cpp) and the lexical
// rules they use (launch.cpp), between the files of kernel_sim/launch/src.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/launch/launch.hpp"

namespace rejuv::launch::detail {

// "0.1" rather than "0.100000": numbers in messages are echoed the way users write them.
[[nodiscard]] std::string num(double v);
// Names are shared with the policy and appear in boot info and audit output: keep them plain.
[[nodiscard]] bool is_plain_name(std::string_view s);
// UTF-8 as RFC 3629 defines it (no overlongs, no surrogates, at most U+10FFFF): names and texts of a graph
// reach logs, JSON summaries and the services' boot info.
[[nodiscard]] bool is_utf8(std::string_view s);
// "INVOKE_CHECKPOINT, ARM_TIMER" or "none".
[[nodiscard]] std::string kind_list(const std::vector<proto::AttackKind>& kinds);

// The graph's `hosts` and each service's `host` (hosts.cpp): names, addresses, every host named is declared.
[[nodiscard]] Result<void, LoadError> check_hosts(const proto::Launch& graph, const TextLocations& locs);
// A graph whose kernel closes a link in the secure interval (a host with `netns`, SR on): the DDS lease (the
// config's <Discovery><LeaseDuration>, else Cyclone's 10 s) outlasts the secure interval's T_est + t_min, so that
// the hosts' participants do not expire while it is closed. `path`: the launch file (a relative dds.config).
[[nodiscard]] Result<void, LoadError> check_link_lease(const proto::Launch& graph, const TextLocations& locs,
                                                       const std::filesystem::path& path);

// Checks a parsed graph (every rule of idl/launch.proto); the first problem found is returned, at its
// file:line:column. On success the graph with its policy file resolved against the launch file's folder.
[[nodiscard]] Result<LoadedLaunch, LoadError> validate(proto::Launch graph, TextLocations locs,
                                                       const std::filesystem::path& path);

}  // namespace rejuv::launch::detail
