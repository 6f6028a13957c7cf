#include "bridge.hpp"

#include <chrono>

#include "rejuv/dds/plant_topics.hpp"

namespace rejuv::kernel {

namespace topics = dds::plant_topics;

Result<DdsBridge, std::string> DdsBridge::open(std::uint32_t domain, std::span<const BridgeSpec> specs,
                                               bool plant_lockstep, std::size_t object_count) {
  auto participant = dds::Participant::create(dds::DomainId{domain});
  if (!participant) return fail("DDS participant on domain " + std::to_string(domain) + ": " + participant.error().to_string());
  DdsBridge b(std::move(*participant));
  b.out_of_topic_.assign(object_count, -1);
  b.plant_lockstep_ = plant_lockstep;
  for (const BridgeSpec& s : specs) {
    if (s.inbound) {
      auto r = dds::Reader::create(b.participant_, s.dds_name, *s.type);
      if (!r) return fail("DDS reader " + s.dds_name + ": " + r.error().to_string());
      b.in_.push_back(In{.reader = std::move(*r), .role = Role::Sample, .topic = s.topic});
    } else {
      auto w = dds::Writer::create(b.participant_, s.dds_name, *s.type);
      if (!w) return fail("DDS writer " + s.dds_name + ": " + w.error().to_string());
      b.out_of_topic_[s.topic.value()] = static_cast<int>(b.out_.size());
      b.out_.push_back(Out{.writer = std::move(*w), .topic = s.topic,
                           .actuator_outputs = s.dds_name == topics::kActuatorOutputs.name});
    }
  }
  if (plant_lockstep) {
    // Every sample topic of the plant counts toward SimStep.samples_published, bridged or not.
    const auto ensure = [&](auto topic) -> Result<void, std::string> {
      for (const BridgeSpec& s : specs) {
        if (s.inbound && s.dds_name == topic.name) return {};
      }
      auto r = dds::Reader::create(b.participant_, topic.name, topics::type_of(topic));
      if (!r) return fail("DDS reader " + std::string(topic.name) + ": " + r.error().to_string());
      b.in_.push_back(In{.reader = std::move(*r), .role = Role::CountOnly, .topic = std::nullopt});
      return {};
    };
    for (auto ok : {ensure(topics::kSensorGyro), ensure(topics::kSensorAccel), ensure(topics::kSensorMag),
                    ensure(topics::kSensorBaro), ensure(topics::kSensorGps), ensure(topics::kGroundTruth)}) {
      if (!ok) return fail(ok.error());
    }
    // The plant's outputs reader must exist even when the graph forgot to bridge actuator_outputs out.
    auto step = dds::Reader::create(b.participant_, topics::kSimStep.name, topics::type_of(topics::kSimStep),
                                    dds::EndpointQos{.history_depth = 64, .ignore_local = dds::IgnoreLocal::Participant});
    if (!step) return fail("DDS reader " + std::string(topics::kSimStep.name) + ": " + step.error().to_string());
    b.in_.push_back(In{.reader = std::move(*step), .role = Role::Step, .topic = std::nullopt});
    auto ack = dds::Writer::create(b.participant_, topics::kSimStepAck.name, topics::type_of(topics::kSimStepAck));
    if (!ack) return fail("DDS writer " + std::string(topics::kSimStepAck.name) + ": " + ack.error().to_string());
    b.ack_ = std::move(*ack);
  }
  return b;
}

Result<bool, std::string> DdsBridge::write_out(ObjectId topic, std::span<const std::byte> payload) {
  if (topic.value() >= out_of_topic_.size() || out_of_topic_[topic.value()] < 0) return false;
  Out& o = out_[static_cast<std::size_t>(out_of_topic_[topic.value()])];
  if (o.actuator_outputs && plant_lockstep_ && !outputs_matched_) {
    // Volatile samples written before the plant's reader matched are lost, and the plant waits for the
    // count of outputs in the ack: make sure the first one arrives.
    if (auto ok = o.writer.wait_for_readers(1, std::chrono::seconds{5}); !ok) {
      return fail("the plant's actuator_outputs reader is not matched: " + ok.error().to_string());
    }
    outputs_matched_ = true;
  }
  if (auto ok = o.writer.write(payload); !ok) return fail("DDS write " + o.writer.topic_name() + ": " + ok.error().to_string());
  if (o.actuator_outputs) ++outputs_published_;
  return true;
}

Result<void, std::string> DdsBridge::write_ack(const rejuv_msg_SimStepAck& ack) {
  if (!ack_) return fail(std::string("no ack writer"));
  if (!ack_matched_) {
    // The plant matched our writer before it sent its first step; make sure our side sees it too, or the
    // first ack could go nowhere (volatile).
    if (auto ok = ack_->wait_for_readers(1, std::chrono::seconds{5}); !ok) {
      return fail("the plant's ack reader is not matched: " + ok.error().to_string());
    }
    ack_matched_ = true;
  }
  if (auto ok = ack_->write_value(ack); !ok) return fail("DDS write sim_step_ack: " + ok.error().to_string());
  return {};
}

}  // namespace rejuv::kernel
