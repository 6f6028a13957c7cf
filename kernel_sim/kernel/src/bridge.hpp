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

  // `plant_lockstep`: also the SimStep reader, the SimStepAck writer and the count-only readers.
  [[nodiscard]] static Result<DdsBridge, std::string> open(std::uint32_t domain, std::span<const BridgeSpec> specs,
                                                           bool plant_lockstep, std::size_t object_count);

  [[nodiscard]] std::vector<In>& readers() { return in_; }
  // Writes `payload` if `topic` is bridged out; counts actuator_outputs samples.
  [[nodiscard]] Result<bool, std::string> write_out(ObjectId topic, std::span<const std::byte> payload);
  [[nodiscard]] Result<void, std::string> write_ack(const rejuv_msg_SimStepAck& ack);
  [[nodiscard]] std::uint64_t outputs_published() const { return outputs_published_; }
  [[nodiscard]] bool has_step_reader() const { return ack_.has_value(); }

 private:
  explicit DdsBridge(dds::Participant participant) : participant_(std::move(participant)) {}
  dds::Participant participant_;  // first: destroyed last
  std::vector<In> in_;
  std::vector<Out> out_;
  std::vector<int> out_of_topic_;  // by ObjectId value: index into out_, or -1
  std::optional<dds::Writer> ack_;
  bool ack_matched_ = false;
  bool plant_lockstep_ = false;
  bool outputs_matched_ = false;
  std::uint64_t outputs_published_ = 0;
};

}  // namespace rejuv::kernel
