// `rejuv run --ulog FILE` (and DIR/run.ulg with --out): the run as a PX4 ULog file (docs/ulog.md), which
// PlotJuggler, PX4 Flight Review and Foxglove open. Every topic the kernel routes is a subscription of its
// own (format named after the policy object, fields from the IDL: tools/ulog), every routed message a data
// message stamped with the kernel clock; the launch graph's parameters are ULog parameters; the kernel's and
// the services' log lines, the mode changes, checkpoints, rollbacks and cold restarts are logged strings, and
// the SR events also the topic `rejuv_sr_event`.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/rate_budget.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/ulog/writer.hpp"
#include "summary.pb.h"

namespace rejuv::cli {

// What the recorder writes of each topic (docs/ulog.md "Profiles and the size budget"), as PX4's logger
// profiles: Default writes each topic at most once per `interval` on average (a burst of kProfileBurst
// messages passes: events that come together, a mission's waypoints), Full every routed message. Either way
// no topic writes more than its share of `budget_bytes_per_s` (the budget over the graph's topics); beyond
// it its messages are not written, and a logged string says so when that begins and ends.
enum class UlogProfile : std::uint8_t { Default, Full };
[[nodiscard]] std::string_view to_string(UlogProfile profile);
struct UlogOptions {
  UlogProfile profile = UlogProfile::Default;
  std::chrono::milliseconds interval{20};             // Default: a topic's messages at most this often [ms]
  std::uint64_t budget_bytes_per_s = 2'000'000;       // the topics' data together [B/s of kernel time]
  static constexpr std::uint64_t kProfileBurst = 16;  // messages of a topic that pass the interval at once
  static constexpr std::chrono::seconds kBudgetBurst{5};  // a topic's share may run this far ahead
};

class UlogRecorder final : public kernel::Observer {
 public:
  struct RunInfo {
    std::uint64_t seed = 0;   // the seed in force
    bool sr = false;
    bool attack = false;
  };
  // Opens `path` and writes the definitions (info, parameters, a format and a subscription per topic of
  // the kernel's graph, rejuv_sr_event). The error is a message for the user.
  [[nodiscard]] static Result<std::unique_ptr<UlogRecorder>, std::string> create(
      const std::filesystem::path& path, const kernel::Kernel& kernel, const RunInfo& info,
      const UlogOptions& options = {});

  void on_publication(const kernel::Publication& p) override;
  void on_log(const kernel::LogLine& line) override;
  void on_sr_event(const SrEvent& e) override;

  // Writes what is buffered and closes the file: its size in bytes.
  [[nodiscard]] Result<std::uint64_t, std::string> close();

  // What was written, into the run summary (`bytes`: close()'s result).
  void fill(proto::UlogSummary& s, std::uint64_t bytes) const;

 private:
  UlogRecorder(ulog::FileWriter writer, const UlogOptions& options)
      : writer_(std::move(writer)), options_(options) {}
  void log(ulog::LogLevel level, Nanos t, std::string_view text);
  // What the profile and the budget let through of one routed message of topic `i` costing `bytes`.
  enum class Admit : std::uint8_t { Write, Sampled, OverBudget };
  Admit admit(std::size_t i, const kernel::Publication& p, std::uint64_t bytes);
  // One topic's profile and budget state (by ObjectId value).
  struct TopicLog {
    RateBudget profile{};  // messages (Default profile)
    RateBudget budget{};   // bytes: its share of the size budget
    bool over = false;     // in an episode over its share
    Nanos over_since{0};
    std::uint64_t over_messages = 0;  // not written in the current episode
    std::uint64_t over_bytes = 0;
    std::uint64_t over_total = 0;  // in the whole run
    std::uint64_t logged = 0;      // 'D' messages of the topic itself
    std::string publishers{};      // who published what was not written ("ext_link", "the kernel")
  };
  enum class Episode : std::uint8_t { Begins, Ends };
  void say_over_budget(std::size_t i, Nanos t, Episode episode);
  // PX4's vehicle_local_position and vehicle_attitude (or their _groundtruth) from one routed topic.
  struct Px4Topics {
    ObjectId source{};
    bool truth = false;  // ground_truth (else the estimate vehicle_state)
    ulog::MsgId local_position = 0;
    ulog::MsgId attitude = 0;
    std::uint64_t written = 0;  // messages of each of the two
    [[nodiscard]] std::string local_position_name() const { return truth ? "vehicle_local_position_groundtruth" : "vehicle_local_position"; }
    [[nodiscard]] std::string attitude_name() const { return truth ? "vehicle_attitude_groundtruth" : "vehicle_attitude"; }
  };
  void write_px4(Px4Topics& x, const kernel::Publication& p);
  // The formats of PX4's topics the graph's estimate and ground truth give (when no topic has their names).
  [[nodiscard]] Result<void, std::string> define_px4_formats(const std::vector<kernel::Kernel::TopicInfo>& topics);
  // A subscription to every topic, rejuv_sr_event and PX4's topics: their msg ids.
  [[nodiscard]] Result<void, std::string> subscribe(const std::vector<kernel::Kernel::TopicInfo>& topics);

  ulog::FileWriter writer_;
  std::vector<std::optional<ulog::MsgId>> by_object_;  // msg_id of each topic, by ObjectId
  std::vector<std::string> names_;                     // policy name of each topic, by ObjectId
  std::vector<std::uint64_t> routed_;                  // publications seen, by ObjectId
  UlogOptions options_;
  std::vector<TopicLog> topic_log_;         // by ObjectId
  std::vector<std::string> service_names_;  // by ServiceId value
  Nanos last_t_{0};
  ulog::MsgId sr_event_id_ = 0;
  std::vector<Px4Topics> px4_;
  std::vector<std::byte> scratch_;
  std::uint64_t data_messages_ = 0;
  std::uint64_t sr_events_ = 0;
  std::uint64_t logged_strings_ = 0;
  std::string error_;  // the first write error (reported by close)
};

// The ULog of one run, for `rejuv run --ulog FILE` and `--out DIR` (DIR/run.ulg): opens a recorder on `path`
// and adds it to `observers` (the fanout the kernel was created with; call after Kernel::create, before the
// run). After the run, finish_ulog closes the file and fills the summary's `ulog` section.
[[nodiscard]] Result<std::unique_ptr<UlogRecorder>, std::string> write_ulog_to(
    const std::filesystem::path& path, const kernel::Kernel& kernel, const UlogRecorder::RunInfo& info,
    const UlogOptions& options, kernel::ObserverFanout& observers);
// Closes the file, fills `summary.ulog` and says on stderr what was written. The error is a message.
[[nodiscard]] Result<void, std::string> finish_ulog(UlogRecorder& recorder, proto::RunSummary& summary);

}  // namespace rejuv::cli
