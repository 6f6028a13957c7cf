// The generic DDS bridge (docs/design.md §5): one participant, and one endpoint per row of a table — a kernel topic,
// its DDS name, its compiled-in type (idl/, msgs::TopicType) and a direction. In: a reader whose samples the
// kernel routes to the topic. Out: a writer the kernel's publications on the topic go to. The launch graph's
// `dds.bridges` is the table (idl/launch.proto, Bridge); nothing here knows a particular topic.
//
// Protocols that ride on the bridge (the plant's lockstep: plant_lockstep.hpp) add inputs of their own on its
// participant (add_input): read by the bridge's owner, not routed to a topic.
//
// Every endpoint the bridge creates, the table's and the protocols', is in one DDS partition, given at open:
// the run's (run_partition.hpp), so that two runs on one domain do not hear each other.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/dds/dds.hpp"

namespace rejuv::dds {

enum class Direction : std::uint8_t { In, Out };

// One row of the bridge table.
struct BridgeEntry {
  ObjectId topic{};                       // the kernel topic (policy object)
  std::string dds_name{};                 // e.g. "rejuv/sensor_gyro"
  const msgs::TopicType* type = nullptr;  // the topic's IDL struct
  Direction direction = Direction::In;
};

// Why the bridge (or a protocol on it) failed: what it was doing, on which DDS topic, and the DDS failure.
struct BridgeError {
  enum class Kind : std::uint8_t {
    Participant,  // the domain participant could not be created (`topic` names the domain)
    Reader,       // a reader could not be created
    Writer,       // a writer could not be created
    Write,        // a write failed
    NotMatched,   // the peer's reader of a protocol topic did not appear in time (the plant is not there)
  };
  Kind kind = Kind::Write;
  std::string topic{};  // the DDS topic name ("domain N" for Participant)
  DdsError cause{};
  // "DDS reader rejuv/sensor_gyro: dds_create_reader: Bad Parameter (-3)".
  [[nodiscard]] std::string to_string() const;
};
[[nodiscard]] std::string_view to_string(BridgeError::Kind kind);

template <class T>
using BridgeResult = Result<T, BridgeError>;

class Bridge {
 public:
  // A reader: routed to `topic` (a row of the table), or read by the bridge's owner (a protocol's input).
  struct Input {
    Reader reader;
    std::optional<ObjectId> topic{};
  };
  struct Output {
    Writer writer;
    ObjectId topic{};
  };

  // Creates the participant and an endpoint per row, in table order (inputs() keeps that order), each in
  // `partition` (empty: the default partition). `topic_count`: kernel topics are ObjectIds below it.
  [[nodiscard]] static BridgeResult<Bridge> open(DomainId domain, std::string partition,
                                                 std::span<const BridgeEntry> table, std::size_t topic_count);

  [[nodiscard]] const std::string& partition() const { return partition_; }

  // Adds a reader on the bridge's participant that no topic routes (returns its index in inputs()); in the
  // bridge's partition, whatever qos.partition says.
  [[nodiscard]] BridgeResult<std::size_t> add_input(std::string_view dds_name, const msgs::TopicType& type,
                                                    const EndpointQos& qos = {});
  // A writer on the bridge's participant, owned by the caller (a protocol's output), in the bridge's partition.
  [[nodiscard]] BridgeResult<Writer> make_writer(std::string_view dds_name, const msgs::TopicType& type) const;

  [[nodiscard]] std::vector<Input>& inputs() { return inputs_; }
  [[nodiscard]] const std::vector<Input>& inputs() const { return inputs_; }
  // The input a row of the table bridges in as `dds_name` with `type`, if any.
  [[nodiscard]] std::optional<std::size_t> find_input(std::string_view dds_name, const msgs::TopicType& type) const;
  // Whether a row of the table bridges `dds_name` in (whatever its type).
  [[nodiscard]] bool bridges_in(std::string_view dds_name) const;
  // The output `topic` is bridged out to, or nullptr.
  [[nodiscard]] Output* output(ObjectId topic);
  // The kernel topic a row bridges out as `dds_name` with `type`, if any.
  [[nodiscard]] std::optional<ObjectId> find_output(std::string_view dds_name, const msgs::TopicType& type) const;

  // Writes `payload` on the output of `topic`: false if the topic is not bridged out.
  [[nodiscard]] BridgeResult<bool> write_out(ObjectId topic, std::span<const std::byte> payload);
  [[nodiscard]] static BridgeResult<void> write(Output& output, std::span<const std::byte> payload);

 private:
  Bridge(Participant participant, std::string partition)
      : participant_(std::move(participant)), partition_(std::move(partition)) {}
  Participant participant_;  // first: destroyed last
  std::string partition_;
  std::vector<Input> inputs_;
  std::vector<Output> outputs_;
  std::vector<int> output_of_topic_;  // by ObjectId value: index into outputs_, or -1
};

}  // namespace rejuv::dds
