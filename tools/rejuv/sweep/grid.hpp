// The bookkeeping of `rejuv sweep` (docs/sweep.md): the cells of a plan (the product of its axes), the tasks
// (cell × seed × runner, all of them or one shard's), the record of each task kept in DIR/cells (written
// atomically, so an interrupted sweep resumes from what it finished), the aggregate over the seeds and its CSV.
// No flying here: runners.hpp flies, figures.hpp draws.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "launch.pb.h"
#include "rejuv/core/result.hpp"
#include "sweep.pb.h"

namespace rejuv::cli::sweep {

enum class Runner : std::uint8_t { Sim, Run };
[[nodiscard]] std::string_view to_string(Runner r);

// SweepPlan.charges (idl/sweep.proto): both runners charge the paper's T_CP/T_RB, or both the launch file's
// lockstep charges; "" each its own.
inline constexpr std::string_view kChargesPaper = "paper";
inline constexpr std::string_view kChargesRuntime = "runtime";
[[nodiscard]] std::optional<Runner> runner_from(std::string_view name);

// `--shard i/n`: the cells whose index is i modulo n (1 ≤ i ≤ n, written 1-based).
struct Shard {
  std::uint32_t index = 0;  // 0-based
  std::uint32_t count = 1;
};
[[nodiscard]] Result<Shard, std::string> parse_shard(std::string_view text);
// `--seeds 1-5` or `1,3,7` or `4`.
[[nodiscard]] Result<std::vector<std::uint64_t>, std::string> parse_seeds(std::string_view text);

[[nodiscard]] std::uint32_t cell_count(const proto::SweepPlan& plan);
// The parameter values of a cell (axis 0 outermost).
[[nodiscard]] std::vector<proto::SweepParamValue> cell_params(const proto::SweepPlan& plan, std::uint32_t cell);

struct Task {
  std::uint32_t cell = 0;
  std::uint64_t seed = 0;
  Runner runner = Runner::Sim;
  bool operator==(const Task&) const = default;
};
// Every task of the plan in `shard`, runner by runner (the model first: it is fast), then cell, then seed.
[[nodiscard]] std::vector<Task> tasks_of(const proto::SweepPlan& plan, Shard shard);

// The launch of a cell: `base` with the cell's values, the plan's stop_after_attacks, and its policy and DDS
// config paths made absolute (`base_dir`: the original launch file's folder), so that it can live anywhere.
[[nodiscard]] Result<proto::Launch, std::string> cell_launch(const proto::Launch& base,
                                                             const std::filesystem::path& base_dir,
                                                             const proto::SweepPlan& plan, std::uint32_t cell);

// DIR/cells/cell-0007_seed-3_run.json
[[nodiscard]] std::filesystem::path record_path(const std::filesystem::path& dir, const Task& task);
// The record of `task` kept in `dir`, if there is one for this very plan (same values, seed, runner, attacks).
[[nodiscard]] std::optional<proto::SweepRecord> kept_record(const std::filesystem::path& dir,
                                                            const proto::SweepPlan& plan, const Task& task);
// Every record of `dir`/cells that belongs to `plan`.
[[nodiscard]] std::vector<proto::SweepRecord> kept_records(const std::filesystem::path& dir,
                                                           const proto::SweepPlan& plan);

// Writes `text` to `path` through a temporary file and a rename: a reader sees the old file or the new one.
[[nodiscard]] Result<void, std::string> write_atomically(const std::filesystem::path& path, const std::string& text);
[[nodiscard]] Result<void, std::string> write_record(const std::filesystem::path& dir, const proto::SweepRecord& r);

// DIR/plan.json.
[[nodiscard]] Result<void, std::string> write_plan(const std::filesystem::path& dir, const proto::SweepPlan& plan);
[[nodiscard]] Result<proto::SweepPlan, std::string> read_plan(const std::filesystem::path& dir);
[[nodiscard]] bool same_plan(const proto::SweepPlan& a, const proto::SweepPlan& b);

// Per cell and runner: max and mean over the seeds of each metric; `missing` counts the planned records absent.
[[nodiscard]] proto::SweepReport aggregate(const proto::SweepPlan& plan, const std::vector<proto::SweepRecord>& records);
[[nodiscard]] std::string to_csv(const proto::SweepReport& report);
// What each runner charged a checkpoint and a rollback, from its first flown record: "sim 20/15 ms, run
// 0.3/0.3 ms" ("" before any flew). The model and the runtime differ unless the plan's `charges` is set.
[[nodiscard]] std::string charges_text(const proto::SweepReport& report);
[[nodiscard]] std::string to_json_text(const google::protobuf::Message& m);

}  // namespace rejuv::cli::sweep
