#include "rejuv/dds/bridge.hpp"

namespace rejuv::dds {

namespace {

std::unexpected<BridgeError> bridge_fail(BridgeError::Kind kind, std::string_view topic, const DdsError& cause) {
  return std::unexpected(BridgeError{.kind = kind, .topic = std::string(topic), .cause = cause});
}

}  // namespace

std::string_view to_string(BridgeError::Kind kind) {
  switch (kind) {
    case BridgeError::Kind::Participant: return "DDS participant on";
    case BridgeError::Kind::Reader: return "DDS reader";
    case BridgeError::Kind::Writer: return "DDS writer";
    case BridgeError::Kind::Write: return "DDS write";
    case BridgeError::Kind::NotMatched: return "no reader matched on";
  }
  return "?";
}

std::string BridgeError::to_string() const {
  return std::string(dds::to_string(kind)) + " " + topic + ": " + cause.to_string();
}

BridgeResult<Bridge> Bridge::open(DomainId domain, std::string partition, std::span<const BridgeEntry> table,
                                  std::size_t topic_count) {
  auto participant = Participant::create(domain);
  if (!participant) {
    return bridge_fail(BridgeError::Kind::Participant, "domain " + std::to_string(domain.value()), participant.error());
  }
  Bridge b(std::move(*participant), std::move(partition));
  const EndpointQos qos{.partition = b.partition_};
  b.output_of_topic_.assign(topic_count, -1);
  for (const BridgeEntry& e : table) {
    REJUV_ASSERT(e.type != nullptr && e.topic.value() < topic_count, "a bridge row names a typed kernel topic");
    switch (e.direction) {
      case Direction::In: {
        auto r = Reader::create(b.participant_, e.dds_name, *e.type, qos);
        if (!r) return bridge_fail(BridgeError::Kind::Reader, e.dds_name, r.error());
        b.inputs_.push_back(Input{.reader = std::move(*r), .topic = e.topic});
        break;
      }
      case Direction::Out: {
        auto w = Writer::create(b.participant_, e.dds_name, *e.type, qos);
        if (!w) return bridge_fail(BridgeError::Kind::Writer, e.dds_name, w.error());
        b.output_of_topic_[e.topic.value()] = static_cast<int>(b.outputs_.size());
        b.outputs_.push_back(Output{.writer = std::move(*w), .topic = e.topic});
        break;
      }
    }
  }
  return b;
}

BridgeResult<std::size_t> Bridge::add_input(std::string_view dds_name, const msgs::TopicType& type,
                                            const EndpointQos& qos) {
  EndpointQos in_partition = qos;
  in_partition.partition = partition_;
  auto r = Reader::create(participant_, dds_name, type, in_partition);
  if (!r) return bridge_fail(BridgeError::Kind::Reader, dds_name, r.error());
  inputs_.push_back(Input{.reader = std::move(*r), .topic = std::nullopt});
  return inputs_.size() - 1;
}

BridgeResult<Writer> Bridge::make_writer(std::string_view dds_name, const msgs::TopicType& type) const {
  auto w = Writer::create(participant_, dds_name, type, EndpointQos{.partition = partition_});
  if (!w) return bridge_fail(BridgeError::Kind::Writer, dds_name, w.error());
  return std::move(*w);
}

std::optional<std::size_t> Bridge::find_input(std::string_view dds_name, const msgs::TopicType& type) const {
  for (std::size_t i = 0; i < inputs_.size(); ++i) {
    const Reader& r = inputs_[i].reader;
    if (inputs_[i].topic && r.topic_name() == dds_name && r.type().name == type.name) return i;
  }
  return std::nullopt;
}

bool Bridge::bridges_in(std::string_view dds_name) const {
  for (const Input& in : inputs_) {
    if (in.topic && in.reader.topic_name() == dds_name) return true;
  }
  return false;
}

Bridge::Output* Bridge::output(ObjectId topic) {
  if (topic.value() >= output_of_topic_.size() || output_of_topic_[topic.value()] < 0) return nullptr;
  return &outputs_[static_cast<std::size_t>(output_of_topic_[topic.value()])];
}

std::optional<ObjectId> Bridge::find_output(std::string_view dds_name, const msgs::TopicType& type) const {
  for (const Output& o : outputs_) {
    if (o.writer.topic_name() == dds_name && o.writer.type().name == type.name) return o.topic;
  }
  return std::nullopt;
}

BridgeResult<bool> Bridge::write_out(ObjectId topic, std::span<const std::byte> payload) {
  Output* o = output(topic);
  if (o == nullptr) return false;
  if (auto ok = write(*o, payload); !ok) return fail(ok.error());
  return true;
}

BridgeResult<void> Bridge::write(Output& output, std::span<const std::byte> payload) {
  if (auto ok = output.writer.write(payload); !ok) {
    return bridge_fail(BridgeError::Kind::Write, output.writer.topic_name(), ok.error());
  }
  return {};
}

}  // namespace rejuv::dds
