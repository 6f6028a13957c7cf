#include "bridge.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <iterator>
#include <type_traits>

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
                           .actuator_outputs = s.dds_name == topics::kActuatorOutputs.name &&
                                               s.type->name == msgs::TopicTraits<rejuv_msg_ActuatorOutputs>::name});
    }
  }
  if (plant_lockstep) {
    const auto step_reader = [&](auto topic) {
      using T = typename decltype(topic)::type;
      for (std::size_t i = 0; i < b.in_.size(); ++i) {
        const dds::Reader& r = b.in_[i].reader;
        if (r.topic_name() == topic.name && r.type().name == msgs::TopicTraits<T>::name) return static_cast<int>(i);
      }
      return -1;
    };
    b.step_readers_ = StepReaders{.gyro = step_reader(topics::kSensorGyro),
                                  .accel = step_reader(topics::kSensorAccel),
                                  .mag = step_reader(topics::kSensorMag),
                                  .baro = step_reader(topics::kSensorBaro),
                                  .gps = step_reader(topics::kSensorGps),
                                  .ground_truth = step_reader(topics::kGroundTruth)};
    // Samples that do not fit their SimStep come on the plant's sample topics, bridged or not, and count
    // toward SimStep.samples_published.
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

Result<void, std::string> DdsBridge::write_on_topic(Out& o, std::span<const std::byte> payload) {
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
  return {};
}

Result<bool, std::string> DdsBridge::write_out(ObjectId topic, std::span<const std::byte> payload) {
  if (topic.value() >= out_of_topic_.size() || out_of_topic_[topic.value()] < 0) return false;
  Out& o = out_[static_cast<std::size_t>(out_of_topic_[topic.value()])];
  if (!(o.actuator_outputs && plant_lockstep_)) {
    if (auto ok = write_on_topic(o, payload); !ok) return fail(ok.error());
    return true;
  }
  // Held for the ack, newest last; when the ack is full its oldest output goes out on the topic first (the
  // plant applies those before the ack's own).
  REJUV_ASSERT(payload.size() == sizeof(rejuv_msg_ActuatorOutputs), "the broker checked the payload size");
  constexpr std::size_t kHeld = std::extent_v<decltype(rejuv_msg_SimStepAck::outputs)>;
  if (held_.outputs_count == kHeld) {
    if (auto ok = write_on_topic(o, std::as_bytes(std::span(&held_.outputs[0], 1))); !ok) return fail(ok.error());
    std::copy(std::begin(held_.outputs) + 1, std::end(held_.outputs), std::begin(held_.outputs));
    --held_.outputs_count;
  }
  std::memcpy(&held_.outputs[held_.outputs_count++], payload.data(), payload.size());
  return true;
}

Result<void, std::string> DdsBridge::write_ack(std::uint64_t step, std::uint64_t time_ns, std::uint64_t charged_ns) {
  rejuv_msg_SimStepAck ack = held_;
  ack.step = step;
  ack.time_ns = time_ns;
  ack.charged_ns = charged_ns;
  ack.outputs_published = outputs_published_;
  held_.outputs_count = 0;
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
