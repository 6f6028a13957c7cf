// The kernel's DDS bridge (DESIGN §5): one participant; a reader per BRIDGE_IN topic, a writer per
// BRIDGE_OUT topic, and in lockstep with a plant the step reader and the ack writer (plant_topics.hpp).
// Plant sample topics the graph does not bridge are still read (and dropped) so that the sample count of
// SimStep can be met.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/dds/dds.hpp"

namespace rejuv::kernel {

struct BridgeSpec {
  ObjectId topic{};
  std::string dds_name{};
  const msgs::TopicType* type = nullptr;
  bool inbound = false;
};

class DdsBridge {
 public:
  enum class Role : std::uint8_t { Sample, CountOnly, Step };
  struct In {
    dds::Reader reader;
    Role role = Role::Sample;
    std::optional<ObjectId> topic{};
  };
  struct Out {
    dds::Writer writer;
    ObjectId topic{};
    bool actuator_outputs = false;
  };

  // Lockstep with a plant: for each kind of sample a SimStep carries, the index in readers() of the reader
  // that bridges its topic in (the step's samples are routed as if that reader had taken them), or -1 when
  // the graph does not bridge it (or bridges it as another type).
  struct StepReaders {
    int gyro = -1, accel = -1, mag = -1, baro = -1, gps = -1, ground_truth = -1;
  };

  // `plant_lockstep`: also the SimStep reader, the SimStepAck writer and the count-only readers.
  [[nodiscard]] static Result<DdsBridge, std::string> open(std::uint32_t domain, std::span<const BridgeSpec> specs,
                                                           bool plant_lockstep, std::size_t object_count);

  [[nodiscard]] std::vector<In>& readers() { return in_; }
  [[nodiscard]] const StepReaders& step_readers() const { return step_readers_; }
  // Writes `payload` if `topic` is bridged out. In lockstep with a plant, actuator_outputs are held for the
  // step's ack instead (the newest ones it holds; an older one that no longer fits goes out on its topic now,
  // counted in outputs_published).
  [[nodiscard]] Result<bool, std::string> write_out(ObjectId topic, std::span<const std::byte> payload);
  // Acknowledges a step (SimStepAck) with the held actuator outputs in it, and forgets them.
  [[nodiscard]] Result<void, std::string> write_ack(std::uint64_t step, std::uint64_t time_ns, std::uint64_t charged_ns);
  [[nodiscard]] std::uint64_t outputs_published() const { return outputs_published_; }
  [[nodiscard]] bool has_step_reader() const { return ack_.has_value(); }

 private:
  explicit DdsBridge(dds::Participant participant) : participant_(std::move(participant)) {}
  [[nodiscard]] Result<void, std::string> write_on_topic(Out& o, std::span<const std::byte> payload);
  dds::Participant participant_;  // first: destroyed last
  std::vector<In> in_;
  std::vector<Out> out_;
  std::vector<int> out_of_topic_;  // by ObjectId value: index into out_, or -1
  std::optional<dds::Writer> ack_;
  bool ack_matched_ = false;
  bool plant_lockstep_ = false;
  bool outputs_matched_ = false;
  std::uint64_t outputs_published_ = 0;
  StepReaders step_readers_{};
  rejuv_msg_SimStepAck held_{};  // outputs / outputs_count: the actuator outputs of the step in progress
};

}  // namespace rejuv::kernel
