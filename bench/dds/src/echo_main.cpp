// rejuv_dds_echo: the far end of the DDS ping-pong benchmark (dds_ping_pong.hpp). Takes every sample of
// rejuv_bench/ping and writes it back unchanged on rejuv_bench/pong, on the receive path it is told. Runs
// until its fd 0 (the driver's control socket) closes, so it never outlives the benchmark.
//   rejuv_dds_echo --domain N --type IDL_NAME --path raw_waitset|bridge_eventfd
#include <unistd.h>

#include <charconv>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "endpoint.hpp"
#include "rejuv/sys/event.hpp"

namespace {

using namespace rejuv;

constexpr auto kIdleCheck = std::chrono::milliseconds{100};  // how often an idle echo looks at fd 0
constexpr auto kConnectTimeout = std::chrono::seconds{30};

int usage_error(const std::string& why) {
  std::fprintf(stderr,
               "rejuv_dds_echo: %s\nusage: rejuv_dds_echo --domain N --type IDL_NAME --path "
               "raw_waitset|bridge_eventfd\n",
               why.c_str());
  return 2;
}

int run(std::span<const std::string_view> args) {
  std::uint32_t domain = 0;
  std::string_view type_name;
  std::optional<bench::DdsPath> path;
  if (args.size() != 6) return usage_error("expected 3 options");
  for (std::size_t i = 0; i < args.size(); i += 2) {
    const std::string_view flag = args[i];
    const std::string_view value = args[i + 1];
    if (flag == "--domain") {
      const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), domain);
      if (ec != std::errc{} || end != value.data() + value.size() || domain > dds::kMaxDomainId) {
        return usage_error("--domain: expected 0..232");
      }
    } else if (flag == "--type") {
      type_name = value;
    } else if (flag == "--path") {
      if (value == bench::to_string(bench::DdsPath::RawWaitset)) path = bench::DdsPath::RawWaitset;
      if (value == bench::to_string(bench::DdsPath::BridgeEventFd)) path = bench::DdsPath::BridgeEventFd;
      if (!path) return usage_error("--path: expected raw_waitset or bridge_eventfd");
    } else {
      return usage_error("unknown option " + std::string(flag));
    }
  }
  const msgs::TopicType* type = msgs::find_topic_type(type_name);
  if (type == nullptr || !path)
    return usage_error("--type and --path are required, --type a known topic type");

  auto endpoint =
      bench::detail::open_endpoint(*path, dds::DomainId{domain}, *type, bench::kPingTopic, bench::kPongTopic);
  if (!endpoint) {
    std::fprintf(stderr, "rejuv_dds_echo: %s\n", endpoint.error().c_str());
    return 1;
  }
  bench::detail::PingEndpoint& e = **endpoint;
  if (auto ok = e.wait_matched(kConnectTimeout); !ok) {
    std::fprintf(stderr, "rejuv_dds_echo: %s\n", ok.error().c_str());
    return 1;
  }
  std::string write_error;
  for (;;) {
    auto n = e.wait_take(kIdleCheck, [&](std::span<const std::byte> sample) {
      if (auto ok = e.write(sample); !ok && write_error.empty()) write_error = ok.error();
    });
    if (!n || !write_error.empty()) {
      std::fprintf(stderr, "rejuv_dds_echo: %s\n", n ? write_error.c_str() : n.error().c_str());
      return 1;
    }
    // Idle: has the driver closed the control socket (EOF makes fd 0 readable)?
    if (*n == 0 && sys::wait_fd(STDIN_FILENO, sys::WaitFor::Readable, Nanos{0}).value_or(true)) return 0;
  }
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string_view> args(argv + 1, argv + argc);
  return run(args);
}
