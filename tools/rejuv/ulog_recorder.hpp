// `rejuv run --ulog FILE` (and DIR/run.ulg with --out): the run as a PX4 ULog file (docs/ulog.md), which
// PlotJuggler, PX4 Flight Review and Foxglove open. Every topic the kernel routes is a subscription of its
// own (format named after the policy object, fields from the IDL: tools/ulog), every routed message a data
// message stamped with the kernel clock; the launch graph's parameters are ULog parameters; the kernel's and
// the services' log lines, the mode changes, checkpoints, rollbacks and cold restarts are logged strings, and
// the SR events also the topic `rejuv_sr_event`.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/ulog/writer.hpp"
#include "summary.pb.h"

namespace rejuv::cli {

class UlogRecorder final : public kernel::Observer {
 public:
  struct RunInfo {
    std::uint64_t seed = 0;   // the seed in force
    bool sr = false;
    bool attack = false;
  };
  // Opens `path` and writes the definitions (info, parameters, a format and a subscription per topic of
  // the kernel's graph, rejuv_sr_event). The error is a message for the user.
  [[nodiscard]] static Result<std::unique_ptr<UlogRecorder>, std::string> create(const std::filesystem::path& path,
                                                                                 const kernel::Kernel& kernel,
                                                                                 const RunInfo& info);

  void on_publication(const kernel::Publication& p) override;
  void on_log(const kernel::LogLine& line) override;
  void on_sr_event(const SrEvent& e) override;

  // Writes what is buffered and closes the file: its size in bytes.
  [[nodiscard]] Result<std::uint64_t, std::string> close();

  // What was written, into the run summary (`bytes`: close()'s result).
  void fill(proto::UlogSummary& s, std::uint64_t bytes) const;

 private:
  explicit UlogRecorder(ulog::FileWriter writer) : writer_(std::move(writer)) {}
  void log(ulog::LogLevel level, Nanos t, std::string_view text);
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
[[nodiscard]] Result<std::unique_ptr<UlogRecorder>, std::string> write_ulog_to(const std::filesystem::path& path,
                                                                               const kernel::Kernel& kernel,
                                                                               const UlogRecorder::RunInfo& info,
                                                                               kernel::ObserverFanout& observers);
// Closes the file, fills `summary.ulog` and says on stderr what was written. The error is a message.
[[nodiscard]] Result<void, std::string> finish_ulog(UlogRecorder& recorder, proto::RunSummary& summary);

}  // namespace rejuv::cli
