#include "rejuv/dds/plant_lockstep.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <iterator>
#include <type_traits>

namespace rejuv::dds {

namespace topics = plant_topics;

namespace {

// Volatile samples written before the peer's reader matched are lost: a protocol writer whose first sample
// the plant waits for waits for the match first (once).
BridgeResult<void> ensure_matched(const Writer& writer, bool& matched) {
  if (matched) return {};
  if (auto ok = writer.wait_for_readers(1, std::chrono::seconds{5}); !ok) {
    return fail(BridgeError{.kind = BridgeError::Kind::NotMatched, .topic = writer.topic_name(), .cause = ok.error()});
  }
  matched = true;
  return {};
}

}  // namespace

BridgeResult<PlantLockstep> PlantLockstep::open(Bridge& bridge, DdsNaming naming) {
  std::array<std::optional<std::size_t>, topics::kStepSampleKinds> carried{};
  BridgeResult<void> ok;
  topics::for_each_step_kind([&](std::size_t row, const auto& kind) {
    const msgs::DdsTopic t = topics::dds_topic(kind.topic, naming);
    carried[row] = bridge.find_input(t.name, *t.type);
    // Samples that do not fit their SimStep come on the plant's sample topics, bridged or not, and count
    // toward SimStep.samples_published.
    if (!ok || bridge.bridges_in(t.name)) return;
    if (auto added = bridge.add_input(t.name, *t.type); !added) ok = fail(added.error());
  });
  if (!ok) return fail(ok.error());
  const msgs::DdsTopic step_topic = topics::dds_topic(topics::kSimStep, naming);
  auto step = bridge.add_input(step_topic.name, *step_topic.type,
                               EndpointQos{.history_depth = 64, .ignore_local = IgnoreLocal::Participant});
  if (!step) return fail(step.error());
  const msgs::DdsTopic ack_topic = topics::dds_topic(topics::kSimStepAck, naming);
  auto ack = bridge.make_writer(ack_topic.name, *ack_topic.type);
  if (!ack) return fail(ack.error());
  PlantLockstep p(std::move(*ack));
  p.step_input_ = *step;
  p.carried_input_ = carried;
  // The plant's outputs reader exists even when the graph forgot to bridge actuator_outputs out.
  const msgs::DdsTopic outputs = topics::dds_topic(topics::kActuatorOutputs, naming);
  p.outputs_topic_ = bridge.find_output(outputs.name, *outputs.type);
  return p;
}

BridgeResult<void> PlantLockstep::write_outputs(Bridge::Output& output, std::span<const std::byte> payload) {
  // The plant waits for the count of outputs in the ack: make sure the first one arrives.
  if (auto ok = ensure_matched(output.writer, outputs_matched_); !ok) return ok;
  if (auto ok = Bridge::write(output, payload); !ok) return ok;
  ++outputs_published_;
  return {};
}

BridgeResult<bool> PlantLockstep::write_out(Bridge& bridge, ObjectId topic, std::span<const std::byte> payload) {
  if (topic != outputs_topic_) return bridge.write_out(topic, payload);
  Bridge::Output* output = bridge.output(topic);
  REJUV_ASSERT(output != nullptr, "outputs_topic_ is bridged out");
  // Held for the ack, newest last; when the ack is full its oldest output goes out on the topic first (the
  // plant applies those before the ack's own).
  REJUV_ASSERT(payload.size() == sizeof(rejuv_msg_ActuatorOutputs), "the broker checked the payload size");
  constexpr std::size_t kHeld = std::extent_v<decltype(rejuv_msg_SimStepAck::outputs)>;
  if (held_.outputs_count == kHeld) {
    if (auto ok = write_outputs(*output, std::as_bytes(std::span(&held_.outputs[0], 1))); !ok) return fail(ok.error());
    std::copy(std::begin(held_.outputs) + 1, std::end(held_.outputs), std::begin(held_.outputs));
    --held_.outputs_count;
  }
  std::memcpy(&held_.outputs[held_.outputs_count++], payload.data(), payload.size());
  return true;
}

BridgeResult<void> PlantLockstep::write_ack(std::uint64_t step, Nanos t, Nanos charged) {
  rejuv_msg_SimStepAck ack = held_;
  ack.step = step;
  ack.time_ns = static_cast<std::uint64_t>(t.count());
  ack.charged_ns = static_cast<std::uint64_t>(charged.count());  // docs/design.md §6
  ack.outputs_published = outputs_published_;
  held_.outputs_count = 0;
  // The plant matched our writer before it sent its first step; make sure our side sees it too, or the first
  // ack could go nowhere (volatile).
  if (auto ok = ensure_matched(ack_, ack_matched_); !ok) return ok;
  if (auto ok = ack_.write_value(ack); !ok) {
    return fail(BridgeError{.kind = BridgeError::Kind::Write, .topic = ack_.topic_name(), .cause = ok.error()});
  }
  return {};
}

}  // namespace rejuv::dds
