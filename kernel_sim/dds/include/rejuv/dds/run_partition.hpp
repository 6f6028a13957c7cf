// The DDS partition of one run (docs/protocol.md "One run, one partition"): the kernel picks a RunId when it
// starts (64 random bits) and puts every endpoint of its bridge — the graph's `dds.bridges` and the lockstep
// protocol's own topics — in the partition `rejuv.<id as 16 hex digits>`; the plant it spawns is told the id
// (`rejuv_plant --run-id`) and puts its endpoints in the same partition. Two runs on one DDS domain then match
// none of each other's endpoints: a kernel flies its own plant only, from the first step.
//
// Cross-host topics (`rejuv/<topic>` between the link processes of two hosts, docs/across_hosts.md) are not in a
// run's partition: each host's kernel has its own run id, and the permissions `rejuv keys hosts` writes grant
// their topics in the default partition only (no <partitions> element). A link process leaves its endpoints'
// partition empty (EndpointQos::partition); a process that should join a run's partition calls run_partition().
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"

namespace rejuv::dds {

using RunId = StrongId<struct RunIdTag, std::uint64_t>;

// A fresh run id: 64 bits from the operating system's random source (std::random_device: getrandom), so that
// another run on the domain cannot guess it.
[[nodiscard]] RunId random_run_id();

// The id as 16 lowercase hex digits ("00ab…"), as `--run-id` takes it.
[[nodiscard]] std::string to_string(RunId id);
// Exactly 16 hex digits (either case); nullopt otherwise.
[[nodiscard]] std::optional<RunId> parse_run_id(std::string_view text);
// The same for a flag's value: the error names the flag ("--run-id: expected 16 hex digits, got 'x'").
[[nodiscard]] Result<RunId, std::string> parse_run_id(std::string_view flag, std::string_view text);

// "rejuv.<16 hex digits>": the partition of every endpoint of the run's kernel bridge and of its plant.
[[nodiscard]] std::string run_partition(RunId id);

}  // namespace rejuv::dds
