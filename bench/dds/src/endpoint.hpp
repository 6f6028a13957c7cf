// One side of the ping-pong (private to bench/dds): reads one topic, writes another, on either receive path
// of dds_ping_pong.hpp. Shared by the driver and rejuv_dds_echo so that both sides take the same path.
#pragma once

#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>

#include "rejuv/bench/dds_ping_pong.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::bench::detail {

class PingEndpoint {
 public:
  using SampleFn = void (*)(void* context, std::span<const std::byte> sample);

  virtual ~PingEndpoint() = default;
  [[nodiscard]] virtual Result<void, std::string> write(std::span<const std::byte> sample) = 0;
  // Waits up to `timeout` for data, then takes every available sample; how many (0 = timed out).
  [[nodiscard]] virtual Result<std::size_t, std::string> wait_take_erased(Nanos timeout, SampleFn fn,
                                                                          void* context) = 0;
  // Until the writer has a matched reader and the reader a matched writer.
  [[nodiscard]] virtual Result<void, std::string> wait_matched(Nanos timeout) = 0;

  template <class F>
  [[nodiscard]] Result<std::size_t, std::string> wait_take(Nanos timeout, F&& on_sample) {
    using Fn = std::remove_reference_t<F>;
    return wait_take_erased(
        timeout, [](void* c, std::span<const std::byte> s) { (*static_cast<Fn*>(c))(s); },
        const_cast<void*>(static_cast<const void*>(std::addressof(on_sample))));
  }
};

[[nodiscard]] Result<std::unique_ptr<PingEndpoint>, std::string> open_endpoint(DdsPath path,
                                                                               dds::DomainId domain,
                                                                               const msgs::TopicType& type,
                                                                               std::string_view read_topic,
                                                                               std::string_view write_topic);

}  // namespace rejuv::bench::detail
