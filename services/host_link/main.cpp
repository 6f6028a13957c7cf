// rejuv_host_link: a host's end of its link to one peer host (include/rejuv/services/host_link/host_link.hpp,
// docs/across_hosts.md "The link"). No command line: started by its host's kernel as link_<peer>, with the params
// `rejuv run --host` set (host_link.params.pbtxt).
#include <dds/dds.h>
#include <unistd.h>

#include <cstddef>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rejuv/core/host_link_params.hpp"
#include "rejuv/channel/wire.hpp"
#include "rejuv/core/dds_name.hpp"
#include "rejuv/msgs/dds_naming.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/sdk/service.hpp"
#include "rejuv/services/host_link/host_link.hpp"
#include "rejuv/services/service_main.hpp"

namespace {

using namespace rejuv;
namespace hl = services::host_link;

// How often the link looks at the mode and takes what its DDS readers hold [kernel time].
constexpr Nanos kPollPeriod{std::chrono::milliseconds(5)};
constexpr std::int32_t kDepth = 8;  // DDS history per topic: what waits while the link is closed

// A payload buffer aligned for any field of an IDL C struct (the kernel's bytes need not be).
struct AlignedPayload {
  explicit AlignedPayload(std::size_t size) : storage(size / sizeof(std::max_align_t) + 1) {}
  void* data() { return storage.data(); }
  std::vector<std::max_align_t> storage;
};

// One topic the link carries, in one direction.
struct Carried {
  std::string object;              // the kernel topic
  const msgs::TopicType* type;     // its compiled IDL type
  dds_entity_t endpoint = 0;       // a DDS writer (kernel → peer) or reader (peer → kernel)
  bool subscribed = false;         // kernel → peer: subscribed to the kernel topic (needs Read in the mode)
  std::uint64_t carried = 0, dropped_closed = 0;
  std::unique_ptr<AlignedPayload> buffer;
};

class Link {
 public:
  explicit Link(sdk::Service& svc) : svc_(svc) {}
  ~Link() {
    if (domain_ > 0) dds_delete(domain_);
  }
  Link(const Link&) = delete;
  Link& operator=(const Link&) = delete;

  // The participant and one endpoint per topic of its caps; false (logged) when something is missing.
  bool open() {
    const std::string enclave(svc_.text_param(host_link_param::kEnclave, ""));
    const std::string address(svc_.text_param(host_link_param::kAddress, ""));
    const std::string peer_address(svc_.text_param(host_link_param::kPeerAddress, ""));
    if (enclave.empty() || address.empty() || peer_address.empty() || !svc_.has_param(host_link_param::kDomain)) {
      svc_.log(sdk::LogLevel::Error, "needs the params enclave, address, peer_address and domain (set by `rejuv run --host`)");
      return false;
    }
    const auto domain = static_cast<dds_domainid_t>(svc_.param(host_link_param::kDomain, 0));
    const std::string names(svc_.text_param(host_link_param::kDdsNames, to_string(DdsNaming::Rejuv)));
    const std::optional<DdsNaming> naming = parse_dds_naming(names);
    if (!naming) {
      svc_.log(sdk::LogLevel::Error, "dds_names: expected rejuv or ros2, got '" + names + "'");
      return false;
    }
    std::string key;  // handed over by the kernel on wire::kHostLinkKeyFd, read once
    char chunk[1024];
    for (ssize_t n = 0; (n = ::read(wire::kHostLinkKeyFd, chunk, sizeof chunk)) > 0;) key.append(chunk, static_cast<std::size_t>(n));
    ::close(wire::kHostLinkKeyFd);
    if (key.empty()) {
      svc_.log(sdk::LogLevel::Error, "no DDS Security private key on fd " + std::to_string(wire::kHostLinkKeyFd) +
                                         " (the kernel hands it over)");
      return false;
    }
    const std::string xml = hl::cyclone_config(
        {.address = address, .peers = {address, peer_address}, .enclave = enclave, .private_key_pem = key});
    domain_ = dds_create_domain(domain, xml.c_str());
    if (domain_ < 0) return refused("dds_create_domain", domain_);
    participant_ = dds_create_participant(domain, nullptr, nullptr);
    if (participant_ < 0) return refused("dds_create_participant (DDS Security: the enclave " + enclave + ")", participant_);
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, kDepth);
    bool ok = true;
    for (const sdk::CapInfo& cap : svc_.caps()) {
      if (cap.kind != ObjectKind::Topic) continue;
      const msgs::TopicType* type = msgs::find_topic_type(cap.type);
      if (type == nullptr || type->descriptor == nullptr) {
        svc_.log(sdk::LogLevel::Error, "topic " + cap.object + ": type " + cap.type + " has no compiled IDL descriptor");
        ok = false;
        continue;
      }
      // The DDS name and the type whose descriptor carries the DDS type name, as the graph's naming says; the
      // struct, its size and its CDR are the IDL type's either way.
      const msgs::DdsTopic on_dds = msgs::dds_topic(cap.object, *type, *naming);
      const std::string& dds_name = on_dds.name;
      const dds_entity_t topic = dds_create_topic(participant_, on_dds.type->descriptor, dds_name.c_str(), nullptr, nullptr);
      if (topic < 0) {
        ok = refused("dds_create_topic " + dds_name, topic) && ok;
        continue;
      }
      Carried c{.object = cap.object, .type = type, .endpoint = 0, .subscribed = false, .carried = 0,
                .dropped_closed = 0, .buffer = std::make_unique<AlignedPayload>(type->size)};
      if (cap.ever(Right::Write)) {  // the peer writes it: a DDS reader, into the kernel
        c.endpoint = dds_create_reader(participant_, topic, qos, nullptr);
        if (c.endpoint < 0) {
          ok = refused("dds_create_reader " + dds_name, c.endpoint) && ok;
          continue;
        }
        inbound_.push_back(std::move(c));
      } else if (cap.ever(Right::Read)) {  // this host writes it: a DDS writer, out of the kernel
        c.endpoint = dds_create_writer(participant_, topic, qos, nullptr);
        if (c.endpoint < 0) {
          ok = refused("dds_create_writer " + dds_name, c.endpoint) && ok;
          continue;
        }
        outbound_.push_back(std::move(c));
      }
    }
    dds_delete_qos(qos);
    svc_.logf(sdk::LogLevel::Info, "link to %s: %zu topic(s) in, %zu out, DDS domain %u, %s names, DDS Security from %s",
              std::string(svc_.text_param(host_link_param::kPeer, "?")).c_str(), inbound_.size(), outbound_.size(),
              static_cast<unsigned>(domain), std::string(to_string(*naming)).c_str(), enclave.c_str());
    return ok;
  }

  // Every poll: the mode, then (in MC) the kernel subscriptions not made yet and what the DDS readers hold.
  void poll() {
    const bool mc = svc_.mode() == SrMode::MC;
    if (window_.observe(mc, dds_time())) drop_written_while_closed();
    if (!mc) return;
    for (Carried& c : outbound_) subscribe(c);
    for (Carried& c : inbound_) take(c);
  }

 private:
  bool refused(const std::string& call, dds_return_t rc) {
    svc_.log(sdk::LogLevel::Error, call + ": " + dds_strretcode(rc));
    return false;
  }

  // Subscribed once the mode grants Read (the kernel answers a Subscribe by the caps of the mode in force); from
  // then on the kernel delivers only while the mode grants it.
  void subscribe(Carried& c) {
    if (c.subscribed) return;
    Carried* at = &c;
    auto ok = svc_.subscribe_untyped(c.object, [this, at](std::span<const std::byte> payload) { forward(*at, payload); });
    if (ok) {
      c.subscribed = true;
    } else if (ok.error().code != sdk::SdkError::Denied) {
      svc_.log(sdk::LogLevel::Warn, "subscribing to " + c.object + ": " + ok.error().to_string());
    }
  }

  // Kernel → peer.
  void forward(Carried& c, std::span<const std::byte> payload) {
    if (!window_.open() || payload.size() != c.type->size) return;
    std::memcpy(c.buffer->data(), payload.data(), payload.size());
    if (const dds_return_t w = dds_write(c.endpoint, c.buffer->data()); w < 0) {
      svc_.log(sdk::LogLevel::Warn, "dds_write " + c.object + ": " + dds_strretcode(w));
      return;
    }
    ++c.carried;
  }

  // Peer → kernel: each sample Cyclone deserialized against the IDL type, as the C struct's bytes.
  void take(Carried& c) {
    for (;;) {
      void* samples[1] = {c.buffer->data()};
      dds_sample_info_t info{};
      const dds_return_t got = dds_take(c.endpoint, samples, &info, 1, 1);
      if (got <= 0) return;
      if (!info.valid_data) continue;
      if (!window_.admits(info.source_timestamp)) {
        ++c.dropped_closed;
        continue;
      }
      auto ok = svc_.publish_untyped(c.object, std::span(static_cast<const std::byte*>(c.buffer->data()), c.type->size));
      if (ok) {
        ++c.carried;
      } else if (ok.error().code != sdk::SdkError::NotHeldInMode) {
        svc_.log(sdk::LogLevel::Warn, "publishing " + c.object + ": " + ok.error().to_string());
      }
    }
  }

  // MC has begun: what the readers hold from before it was written while the link was closed.
  void drop_written_while_closed() {
    std::uint64_t dropped = 0;
    for (Carried& c : inbound_) {
      for (;;) {
        void* samples[1] = {c.buffer->data()};
        dds_sample_info_t info{};
        // Read without taking first: a sample written after MC began stays for take().
        const dds_return_t got = dds_read(c.endpoint, samples, &info, 1, 1);
        if (got <= 0 || info.source_timestamp >= window_.began_ns()) break;
        (void)dds_take(c.endpoint, samples, &info, 1, 1);
        ++dropped;
        ++c.dropped_closed;
      }
    }
    if (dropped > 0) {
      svc_.logf(sdk::LogLevel::Info, "MC began: %llu sample(s) written while the link was closed dropped",
                static_cast<unsigned long long>(dropped));
    }
  }

  sdk::Service& svc_;
  dds_entity_t domain_ = 0, participant_ = 0;
  hl::McWindow window_;
  std::vector<Carried> inbound_, outbound_;
};

}  // namespace

int main() {
  return services::run_service([](sdk::Service& svc) {
    Link link(svc);
    if (!link.open()) return 1;
    auto timer = svc.every(kPollPeriod, [&link] { link.poll(); });
    if (!svc.require(timer, "poll timer")) return 1;
    return svc.run();
  });
}
