// One DDS participant of the across-hosts test (across_hosts_test.cpp), run in a network namespace with
// `ip netns exec`: Cyclone DDS's C API on its own, configured by the Cyclone XML the test wrote (its interface,
// its peer and, for a secure participant, the enclave `rejuv keys hosts` made). Writes or reads one topic of a
// project type (rejuv::msg::VehicleStateEstimate; with --names ros2 under its ROS 2 type name
// rejuv_msgs::msg::dds_::VehicleStateEstimate_, msgs::dds_topic_type) and reports on stdout, one line each:
//   publish TOPIC:   "writing" once its writer exists, or "refused: <call>: <Cyclone's return code>"
//   subscribe TOPIC: "reading TOPIC as TYPE" once its reader exists, then "received N" when it ends (its first
//                    sample with --first, else at --seconds or SIGTERM)
// Usage: rejuv_dds_peer publish|subscribe TOPIC --domain N --config FILE [--seconds S] [--first] [--names rejuv|ros2]
#include <dds/dds.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "rejuv/msgs/dds_naming.hpp"
#include "rejuv/msgs/topic_types.hpp"

namespace {

std::atomic<bool> g_stop{false};  // set by SIGTERM: the one way a signal handler may speak to the loop

void on_term(int /*sig*/) { g_stop.store(true); }

int refused(const char* call, dds_return_t rc) {
  std::printf("refused: %s: %s\n", call, dds_strretcode(rc));
  std::fflush(stdout);
  return 3;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: rejuv_dds_peer publish|subscribe TOPIC --domain N --config FILE [--seconds S] [--first] "
                         "[--names rejuv|ros2]\n");
    return 2;
  }
  const std::string role = argv[1], topic_name = argv[2];
  unsigned domain = 0;
  double seconds = 20.0;
  bool first = false;
  rejuv::DdsNaming naming = rejuv::DdsNaming::Rejuv;
  std::string config_file;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--domain" && i + 1 < argc) domain = static_cast<unsigned>(std::strtoul(argv[++i], nullptr, 10));
    else if (a == "--config" && i + 1 < argc) config_file = argv[++i];
    else if (a == "--seconds" && i + 1 < argc) seconds = std::strtod(argv[++i], nullptr);
    else if (a == "--first") first = true;
    else if (a == "--names" && i + 1 < argc && rejuv::parse_dds_naming(argv[i + 1])) naming = *rejuv::parse_dds_naming(argv[++i]);
    else {
      std::fprintf(stderr, "rejuv_dds_peer: unknown argument '%s'\n", a.c_str());
      return 2;
    }
  }
  if ((role != "publish" && role != "subscribe") || config_file.empty()) {
    std::fprintf(stderr, "rejuv_dds_peer: expected publish or subscribe and --config FILE\n");
    return 2;
  }
  std::ifstream in(config_file);
  std::stringstream config;
  config << in.rdbuf();
  if (!in) {
    std::fprintf(stderr, "rejuv_dds_peer: cannot read %s\n", config_file.c_str());
    return 2;
  }
  std::signal(SIGTERM, on_term);
  const rejuv::msgs::TopicType* idl_type = rejuv::msgs::find_topic_type("rejuv::msg::VehicleStateEstimate");
  if (idl_type == nullptr) return 2;
  const rejuv::msgs::TopicType* type = &rejuv::msgs::dds_topic_type(*idl_type, naming);

  const dds_entity_t dom = dds_create_domain(domain, config.str().c_str());
  if (dom < 0) return refused("dds_create_domain", dom);
  const dds_entity_t participant = dds_create_participant(domain, nullptr, nullptr);
  if (participant < 0) return refused("dds_create_participant", participant);
  const dds_entity_t topic = dds_create_topic(participant, type->descriptor, topic_name.c_str(), nullptr, nullptr);
  if (topic < 0) return refused("dds_create_topic", topic);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 4);
  // A payload of the type's size, aligned for any field; its first bytes carry a marker.
  std::vector<std::max_align_t> buffer(type->size / sizeof(std::max_align_t) + 1);
  void* sample = buffer.data();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  const bool publish = role == "publish";
  const dds_entity_t endpoint = publish ? dds_create_writer(participant, topic, qos, nullptr)
                                        : dds_create_reader(participant, topic, qos, nullptr);
  dds_delete_qos(qos);
  if (endpoint < 0) return refused(publish ? "dds_create_writer" : "dds_create_reader", endpoint);
  if (publish) {
    std::printf("writing\n");
  } else {
    std::printf("reading %s as %s\n", topic_name.c_str(), type->descriptor->m_typename);
  }
  std::fflush(stdout);
  if (publish) {
    std::uint64_t n = 0;
    while (!g_stop.load() && std::chrono::steady_clock::now() < deadline) {
      ++n;
      std::memcpy(sample, &n, sizeof n);
      if (const dds_return_t w = dds_write(endpoint, sample); w < 0) std::fprintf(stderr, "dds_write: %s\n", dds_strretcode(w));
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  } else {
    std::uint64_t received = 0;
    while (!g_stop.load() && std::chrono::steady_clock::now() < deadline && !(first && received > 0)) {
      void* samples[1] = {sample};
      dds_sample_info_t info{};
      const dds_return_t got = dds_take(endpoint, samples, &info, 1, 1);
      if (got > 0 && info.valid_data) ++received;
      if (got <= 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    std::printf("received %llu\n", static_cast<unsigned long long>(received));
    std::fflush(stdout);
  }
  dds_delete(dom);
  return 0;
}
