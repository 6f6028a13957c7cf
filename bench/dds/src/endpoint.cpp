#include "endpoint.hpp"

#include <dds/dds.h>

#include <array>
#include <thread>
#include <utility>
#include <vector>

#include "rejuv/dds/dds.hpp"
#include "rejuv/sys/event.hpp"

namespace rejuv::bench::detail {

namespace {

constexpr std::int32_t kDepth = 16;  // the bridge's default keep-last depth (dds::EndpointQos)
constexpr std::size_t kBatch = 8;

std::string dds_text(std::string_view call, dds_return_t rc) {
  return std::string(call) + ": " + dds_strretcode(rc);
}

// ---- Cyclone's C API alone: the baseline ----
class RawEndpoint final : public PingEndpoint {
 public:
  static Result<std::unique_ptr<PingEndpoint>, std::string> open(dds::DomainId domain,
                                                                 const msgs::TopicType& type,
                                                                 std::string_view read_topic,
                                                                 std::string_view write_topic) {
    auto e = std::make_unique<RawEndpoint>(type);
    e->participant_ = dds_create_participant(domain.value(), nullptr, nullptr);
    if (e->participant_ < 0)
      return fail(dds_text("dds_create_participant", std::exchange(e->participant_, 0)));
    const std::string rt(read_topic);
    const std::string wt(write_topic);
    const dds_entity_t topic_r =
        dds_create_topic(e->participant_, type.descriptor, rt.c_str(), nullptr, nullptr);
    if (topic_r < 0) return fail(dds_text("dds_create_topic", topic_r));
    const dds_entity_t topic_w =
        dds_create_topic(e->participant_, type.descriptor, wt.c_str(), nullptr, nullptr);
    if (topic_w < 0) return fail(dds_text("dds_create_topic", topic_w));
    // The same QoS as the bridge: reliable, keep-last, volatile.
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, kDepth);
    dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
    e->reader_ = dds_create_reader(e->participant_, topic_r, qos, nullptr);
    e->writer_ = dds_create_writer(e->participant_, topic_w, qos, nullptr);
    dds_delete_qos(qos);
    if (e->reader_ < 0) return fail(dds_text("dds_create_reader", e->reader_));
    if (e->writer_ < 0) return fail(dds_text("dds_create_writer", e->writer_));
    e->condition_ = dds_create_readcondition(e->reader_, DDS_ANY_STATE);
    if (e->condition_ < 0) return fail(dds_text("dds_create_readcondition", e->condition_));
    e->waitset_ = dds_create_waitset(e->participant_);
    if (e->waitset_ < 0) return fail(dds_text("dds_create_waitset", e->waitset_));
    if (const dds_return_t rc = dds_waitset_attach(e->waitset_, e->condition_, e->condition_); rc < 0) {
      return fail(dds_text("dds_waitset_attach", rc));
    }
    return std::unique_ptr<PingEndpoint>(std::move(e));
  }

  explicit RawEndpoint(const msgs::TopicType& type) : type_(&type) {
    const std::size_t stride = (type.size + sizeof(std::max_align_t) - 1) / sizeof(std::max_align_t);
    storage_.resize(stride * kBatch);
    for (std::size_t i = 0; i < kBatch; ++i) samples_[i] = &storage_[i * stride];
  }
  RawEndpoint(const RawEndpoint&) = delete;
  RawEndpoint& operator=(const RawEndpoint&) = delete;
  ~RawEndpoint() override {
    if (participant_ > 0) (void)dds_delete(participant_);  // and every entity under it
  }

  Result<void, std::string> write(std::span<const std::byte> sample) override {
    if (const dds_return_t rc = dds_write(writer_, sample.data()); rc < 0)
      return fail(dds_text("dds_write", rc));
    return {};
  }

  Result<std::size_t, std::string> wait_take_erased(Nanos timeout, SampleFn fn, void* context) override {
    auto n = take(fn, context);
    if (!n || *n > 0) return n;
    const dds_return_t woke = dds_waitset_wait(waitset_, nullptr, 0, timeout.count());
    if (woke < 0) return fail(dds_text("dds_waitset_wait", woke));
    return take(fn, context);
  }

  Result<void, std::string> wait_matched(Nanos timeout) override {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      dds_publication_matched_status_t pub{};
      dds_subscription_matched_status_t sub{};
      if (dds_get_publication_matched_status(writer_, &pub) < 0 ||
          dds_get_subscription_matched_status(reader_, &sub) < 0) {
        return fail(std::string("matched status"));
      }
      if (pub.current_count > 0 && sub.current_count > 0) return {};
      if (std::chrono::steady_clock::now() >= deadline)
        return fail(std::string("peer did not match in time"));
      std::this_thread::sleep_for(std::chrono::milliseconds{1});
    }
  }

 private:
  Result<std::size_t, std::string> take(SampleFn fn, void* context) {
    const dds_return_t n = dds_take(condition_, samples_.data(), infos_.data(), kBatch, kBatch);
    if (n < 0) return fail(dds_text("dds_take", n));
    std::size_t valid = 0;
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) {
      if (!infos_[i].valid_data) continue;
      fn(context, std::span<const std::byte>(static_cast<const std::byte*>(samples_[i]), type_->size));
      ++valid;
    }
    return valid;
  }

  const msgs::TopicType* type_;
  dds_entity_t participant_ = 0;
  dds_entity_t reader_ = 0;
  dds_entity_t writer_ = 0;
  dds_entity_t condition_ = 0;
  dds_entity_t waitset_ = 0;
  std::vector<std::max_align_t> storage_;
  std::array<void*, kBatch> samples_{};
  std::array<dds_sample_info_t, kBatch> infos_{};
};

// ---- rejuv::dds, the kernel's bridge: listener → eventfd → wait → take ----
class BridgeEndpoint final : public PingEndpoint {
 public:
  static Result<std::unique_ptr<PingEndpoint>, std::string> open(dds::DomainId domain,
                                                                 const msgs::TopicType& type,
                                                                 std::string_view read_topic,
                                                                 std::string_view write_topic) {
    auto p = dds::Participant::create(domain);
    if (!p) return fail(p.error().to_string());
    auto r = dds::Reader::create(*p, read_topic, type);
    if (!r) return fail(r.error().to_string());
    auto w = dds::Writer::create(*p, write_topic, type);
    if (!w) return fail(w.error().to_string());
    return std::unique_ptr<PingEndpoint>(
        std::make_unique<BridgeEndpoint>(std::move(*p), std::move(*r), std::move(*w)));
  }

  BridgeEndpoint(dds::Participant p, dds::Reader r, dds::Writer w)
      : participant_(std::move(p)), reader_(std::move(r)), writer_(std::move(w)) {}

  Result<void, std::string> write(std::span<const std::byte> sample) override {
    if (auto ok = writer_.write(sample); !ok) return fail(ok.error().to_string());
    return {};
  }

  Result<std::size_t, std::string> wait_take_erased(Nanos timeout, SampleFn fn, void* context) override {
    auto n = take(fn, context);
    if (!n || *n > 0) return n;
    // The event loop's view of DDS: the reader's eventfd (docs/design.md §5).
    if (auto ready = sys::wait_fd(reader_.ready_fd(), sys::WaitFor::Readable, timeout); !ready) {
      return fail(ready.error().to_string());
    }
    return take(fn, context);
  }

  Result<void, std::string> wait_matched(Nanos timeout) override {
    if (auto ok = writer_.wait_for_readers(1, timeout); !ok) return fail(ok.error().to_string());
    if (auto ok = reader_.wait_for_writers(1, timeout); !ok) return fail(ok.error().to_string());
    return {};
  }

 private:
  Result<std::size_t, std::string> take(SampleFn fn, void* context) {
    auto n = reader_.take([&](std::span<const std::byte> s) { fn(context, s); });
    if (!n) return fail(n.error().to_string());
    return *n;
  }

  dds::Participant participant_;  // declared first: destroyed last
  dds::Reader reader_;
  dds::Writer writer_;
};

}  // namespace

Result<std::unique_ptr<PingEndpoint>, std::string> open_endpoint(DdsPath path, dds::DomainId domain,
                                                                 const msgs::TopicType& type,
                                                                 std::string_view read_topic,
                                                                 std::string_view write_topic) {
  switch (path) {
    case DdsPath::RawWaitset: return RawEndpoint::open(domain, type, read_topic, write_topic);
    case DdsPath::BridgeEventFd: return BridgeEndpoint::open(domain, type, read_topic, write_topic);
  }
  return fail(std::string("unknown path"));
}

}  // namespace rejuv::bench::detail
