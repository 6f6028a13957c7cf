// ROS 2 can read what Rejuv writes (docs/across_hosts.md "ROS 2 names"), checked with parts Rejuv did not write:
//  - Debian's rosidl parser (python3-rosidl, the parser rosidl_generate_interfaces runs) accepts every .msg of
//    the generated package rejuv_msgs (<build>/ros2/rejuv_msgs);
//  - a sample written with Cyclone DDS under the ROS 2 names (the project's dds::Writer, as the bridge writes:
//    "rt/<topic>", type rejuv_msgs::msg::dds_::<Struct>_, the default partition) is taken back as serialized
//    CDR by a plain Cyclone reader and decoded by @foxglove/rosmsg2-serialization against those .msg files
//    (tests/ros2_msgs/decode_cdr.js, installed by ./rejuv's set-up): every field value is the one written;
//  - what discovery announces of that writer is what a ROS 2 node looks for.
#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <csignal>
#include <chrono>

#include <array>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "../node_script.hpp"
#include "../rejuv_cli.hpp"
#include "../test_domain.hpp"
#include "rejuv/dds/dds.hpp"
#include "rejuv/msgs/dds_naming.hpp"

namespace rejuv {
namespace {

namespace fs = std::filesystem;
using google::protobuf::Struct;
using google::protobuf::Value;
using test_support::json_at;

const fs::path kPackage = fs::path(REJUV_BINARY_DIR) / "ros2" / "rejuv_msgs";
const fs::path kReaderDir = fs::path(REJUV_BINARY_DIR) / "ros2_msgs";
const std::string kCycloneUri = "file://" REJUV_SOURCE_DIR "/config/cyclonedds.xml";
// Debian's interpreter: python3-rosidl installs into its dist-packages (another python3 on PATH may not see it).
const fs::path kDebianPython = "/usr/bin/python3";

// A bound that keeps a broken build from hanging the test; never a timing under test.
constexpr dds_duration_t kLiveness = DDS_SECS(20);

class Ros2Names : public test_support::ScratchDirTest {
 protected:
  Ros2Names() : ScratchDirTest("rejuv_ros2_names_") {}
  static void SetUpTestSuite() { ::setenv("CYCLONEDDS_URI", kCycloneUri.c_str(), 1); }
};

// ---- (a) rosidl ----

// For each .msg: rosidl's parse_message_file, then one line "Name fields constants" (or the exception).
constexpr const char* kRosidlScript = R"(
import glob, os, sys
from rosidl_adapter.parser import parse_message_file
for path in sorted(glob.glob(os.path.join(sys.argv[1], 'msg', '*.msg'))):
    spec = parse_message_file('rejuv_msgs', path)
    print(spec.base_type.type, len(spec.fields), len(spec.constants))
)";

TEST_F(Ros2Names, RosidlParser_AcceptsEveryGeneratedMessage) {
  ASSERT_TRUE(fs::exists(kDebianPython)) << "Debian's python3 (./rejuv installs python3-rosidl)";
  const auto r = test_support::run_program(dir_, kDebianPython, {"-c", kRosidlScript, kPackage.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // One line per topic type (and Waypoint, nested in MissionWaypoints), each with the struct's field count.
  std::size_t lines = 0;
  for (const msgs::TopicType& t : msgs::all_topic_types()) {
    const std::string name(msgs::ros2_message_name(t.name));
    EXPECT_NE(r.out.find(name + " "), std::string::npos) << name << " not parsed:\n" << r.out;
    ++lines;
  }
  EXPECT_NE(r.out.find("Waypoint 2 0\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("VehicleStateEstimate 10 0\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("SrMode 4 5\n"), std::string::npos) << "SrModeKind's five enumerators as constants:\n" << r.out;
  EXPECT_EQ(test_support::count_of(r.out, "\n"), lines + 1) << r.out;
}

TEST_F(Ros2Names, Package_Format3InterfacePackage) {
  const std::string xml = test_support::slurp(kPackage / "package.xml");
  EXPECT_NE(xml.find("<package format=\"3\">"), std::string::npos) << xml;
  EXPECT_NE(xml.find("<member_of_group>rosidl_interface_packages</member_of_group>"), std::string::npos) << xml;
  const std::string cmake = test_support::slurp(kPackage / "CMakeLists.txt");
  for (const msgs::TopicType& t : msgs::all_topic_types()) {
    const std::string name(msgs::ros2_message_name(t.name));
    EXPECT_TRUE(fs::exists(kPackage / "msg" / (name + ".msg"))) << name;
    EXPECT_NE(cmake.find("\"msg/" + name + ".msg\""), std::string::npos) << name;
  }
}

// `rejuv ros2 msgs DIR` writes what the build generated: the same files, the same text.
TEST_F(Ros2Names, CliMsgs_WritesTheBuildsPackage) {
  const fs::path out = dir_ / "rejuv_msgs";
  const auto r = test_support::run_rejuv(dir_, {"ros2", "msgs", out.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("19 messages"), std::string::npos) << r.out;
  std::size_t files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(kPackage)) {
    if (!entry.is_regular_file()) continue;
    const fs::path rel = fs::relative(entry.path(), kPackage);
    EXPECT_EQ(test_support::slurp(out / rel), test_support::slurp(entry.path())) << rel;
    ++files;
  }
  EXPECT_EQ(files, msgs::all_topic_types().size() + 3) << "a .msg per topic type, Waypoint, package.xml, CMakeLists.txt";
}

// IDL the generator does not read: exit 2, the construct at its file:line:column, nothing written.
TEST_F(Ros2Names, CliMsgs_UnsupportedIdl_RefusedAtItsPlace) {
  std::ofstream(dir_ / "bad.idl") << "module m {\n  @final struct S { string name; };\n};\n";
  const fs::path out = dir_ / "out";
  const auto r = test_support::run_rejuv(dir_, {"ros2", "msgs", out.string(), "--idl", (dir_ / "bad.idl").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("bad.idl:2:21: error: string (a variable-length member) is not supported"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// ---- (b) a Cyclone sample decoded by a ROS 2 reader ----

// What a plain Cyclone reader of the ROS 2 topic received: the serialized sample and the writer as discovery
// announced it.
struct Received {
  std::vector<unsigned char> cdr;  // with its 4-byte encapsulation header
  std::string topic_name;
  std::string type_name;
  std::vector<std::string> partitions;
};

// Writes `sample` on `topic` under ROS 2 names with the project's dds::Writer and takes it back as CDR.
template <class T>
Received write_and_take(const std::string& topic, const T& sample) {
  Received got;
  const msgs::TopicType* idl = msgs::find_topic_type(msgs::TopicTraits<T>::name);
  EXPECT_NE(idl, nullptr);
  if (idl == nullptr) return got;
  const msgs::DdsTopic ros = msgs::dds_topic(topic, *idl, DdsNaming::Ros2);
  const dds::DomainId domain{test_support::kOwnDdsDomain};
  auto writer_participant = dds::Participant::create(domain);
  EXPECT_TRUE(writer_participant.has_value());
  if (!writer_participant) return got;
  auto writer = dds::Writer::create(*writer_participant, ros.name, *ros.type, dds::EndpointQos{});
  EXPECT_TRUE(writer.has_value()) << writer.error().to_string();
  if (!writer) return got;

  // The reader: plain Cyclone on a participant of its own, the topic by its DDS name and type name.
  const dds_entity_t participant = dds_create_participant(domain.value(), nullptr, nullptr);
  EXPECT_GT(participant, 0) << dds_strretcode(participant);
  const dds_entity_t t = dds_create_topic(participant, ros.type->descriptor, ros.name.c_str(), nullptr, nullptr);
  EXPECT_GT(t, 0) << dds_strretcode(t);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  const dds_entity_t reader = dds_create_reader(participant, t, qos, nullptr);
  dds_delete_qos(qos);
  EXPECT_GT(reader, 0) << dds_strretcode(reader);

  if (auto matched = writer->wait_for_readers(1, std::chrono::seconds{20}); !matched) {
    ADD_FAILURE() << "the reader did not match: " << matched.error().to_string();
  } else if (auto wrote = writer->write_value(sample); !wrote) {
    ADD_FAILURE() << wrote.error().to_string();
  } else {
    const dds_entity_t ws = dds_create_waitset(participant);
    const dds_entity_t rc = dds_create_readcondition(reader, DDS_ANY_STATE);
    EXPECT_EQ(dds_waitset_attach(ws, rc, 0), 0);
    EXPECT_EQ(dds_waitset_wait(ws, nullptr, 0, kLiveness), 1) << "no sample within the liveness bound";
    ddsi_serdata* serdata = nullptr;
    dds_sample_info_t info{};
    const dds_return_t n = dds_takecdr(reader, &serdata, 1, &info, DDS_ANY_STATE);
    EXPECT_EQ(n, 1) << dds_strretcode(n);
    if (n == 1) {
      got.cdr.resize(ddsi_serdata_size(serdata));
      ddsi_serdata_to_ser(serdata, 0, got.cdr.size(), got.cdr.data());
      ddsi_serdata_unref(serdata);
    }
    // What discovery announced of the writer: what `ros2 topic list -t` would show.
    std::array<dds_instance_handle_t, 4> handles{};
    const dds_return_t pubs = dds_get_matched_publications(reader, handles.data(), handles.size());
    EXPECT_EQ(pubs, 1);
    if (pubs >= 1) {
      dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, handles[0]);
      EXPECT_NE(ep, nullptr);
      if (ep != nullptr) {
        got.topic_name = ep->topic_name;
        got.type_name = ep->type_name;
        uint32_t np = 0;
        char** ps = nullptr;
        if (dds_qget_partition(ep->qos, &np, &ps)) {
          for (uint32_t i = 0; i < np; ++i) {
            got.partitions.emplace_back(ps[i]);
            dds_free(ps[i]);
          }
          dds_free(ps);
        }
        dds_builtintopic_free_endpoint(ep);
      }
    }
  }
  dds_delete(participant);
  return got;
}

// Runs decode_cdr.js over `samples` (message name -> CDR file); its JSON output, or a failure.
Struct decode(const fs::path& dir, const std::vector<std::pair<std::string, fs::path>>& samples) {
  Struct out;
  std::vector<std::string> args{(kPackage / "msg").string()};
  for (const auto& [type, file] : samples) args.push_back(type + "=" + file.string());
  const fs::path json = dir / "decoded.json";
  const pid_t pid = test_support::start_node_script(fs::path(REJUV_SOURCE_DIR) / "tests/ros2_msgs/decode_cdr.js",
                                                    kReaderDir / "node_modules", args, json);
  int status = 0;
  EXPECT_TRUE(pid > 0 && ::waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << "decode_cdr.js failed (status " << status << ")";
  const std::string text = test_support::slurp(json);
  EXPECT_TRUE(google::protobuf::util::JsonStringToMessage(text, &out).ok()) << text;
  return out;
}

fs::path save(const fs::path& dir, const std::string& name, const std::vector<unsigned char>& bytes) {
  const fs::path p = dir / (name + ".cdr");
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return p;
}

void expect_doubles(const Value& v, const double* expected, std::size_t n, const std::string& what) {
  ASSERT_EQ(v.list_value().values_size(), static_cast<int>(n)) << what;
  for (std::size_t i = 0; i < n; ++i) EXPECT_DOUBLE_EQ(v.list_value().values(static_cast<int>(i)).number_value(), expected[i]) << what << "[" << i << "]";
}

// The decoded uint64/int64: a decimal string (exact beyond 2^53).
std::string u64(const Value& v) { return v.string_value(); }

TEST_F(Ros2Names, CycloneSample_DecodedByRosmsg2Serialization_SameValues) {
  ASSERT_TRUE(fs::exists(kReaderDir / "node_modules/@foxglove/rosmsg2-serialization/package.json"))
      << "run ./rejuv once: it installs tests/ros2_msgs' npm packages into " << kReaderDir;

  rejuv_msg_VehicleStateEstimate state{};
  state.timestamp_ns = 0x123456789abcdef1ULL;  // above 2^53: decoded exactly or not at all
  for (int i = 0; i < 3; ++i) {
    state.p_N_m[i] = 1.25 + i;
    state.v_N_m_s[i] = -0.5 * (i + 1);
    state.omega_B_rad_s[i] = 0.001 * (i + 7);
    state.gyro_bias_rad_s[i] = 1e-5 * (i + 1);
    state.accel_bias_m_s2[i] = -2e-3 * (i + 1);
    state.variance_p_m2[i] = 0.04 + i;
    state.variance_v_m2_s2[i] = 0.09 + i;
  }
  const double q[4] = {0.9238795325112867, 0.0, 0.0, 0.3826834323650898};
  std::memcpy(state.q_NB, q, sizeof q);
  state.flags = 0b1011;

  rejuv_msg_MissionWaypoints mission{};  // nested structs in a fixed array
  mission.timestamp_ns = 42;
  mission.count = 3;
  for (int i = 0; i < 16; ++i) {
    mission.waypoints[i].p_N_m[0] = 10.0 * i;
    mission.waypoints[i].p_N_m[1] = -1.0 * i;
    mission.waypoints[i].p_N_m[2] = -3.0;
    mission.waypoints[i].yaw_rad = 0.1 * i;
  }
  mission.acceptance_radius_m = 0.35;

  rejuv_msg_SecurityEvent event{};  // bytes, then enums: CDR's alignment after uint8
  event.timestamp_ns = 7;
  event.service_id = 5;
  event.slot = 231;
  event.operation = 3;
  event.error = 250;
  event.mode = rejuv_msg_SR_MODE_CP;
  event.kind = rejuv_msg_SECURITY_PUBLICATION_BUDGET;

  rejuv_msg_SensorGps gps{};  // trailing uint8 members
  gps.timestamp_ns = 99;
  for (int i = 0; i < 3; ++i) {
    gps.p_N_m[i] = 100.5 + i;
    gps.v_N_m_s[i] = 0.25 * i;
  }
  gps.eph_m = 1.5;
  gps.epv_m = 2.5;
  gps.fix_type = 3;
  gps.satellites_used = 11;

  const Received rs = write_and_take("vehicle_state", state);
  const Received rm = write_and_take("mission", mission);
  const Received re = write_and_take("security_event", event);
  const Received rg = write_and_take("sensor_gps", gps);
  for (const Received* r : {&rs, &rm, &re, &rg}) {
    ASSERT_GE(r->cdr.size(), 4u);
    EXPECT_EQ(r->cdr[0], 0x00);
    EXPECT_EQ(r->cdr[1], 0x01) << "CDR little-endian (XCDR1), as ROS 2 writes";
    EXPECT_TRUE(r->partitions.empty() || (r->partitions.size() == 1 && r->partitions[0].empty()))
        << "the default partition";
  }
  EXPECT_EQ(rs.topic_name, "rt/vehicle_state");
  EXPECT_EQ(rs.type_name, "rejuv_msgs::msg::dds_::VehicleStateEstimate_");
  EXPECT_EQ(rm.type_name, "rejuv_msgs::msg::dds_::MissionWaypoints_");

  const Struct out = decode(dir_, {{"VehicleStateEstimate", save(dir_, "state", rs.cdr)},
                                    {"MissionWaypoints", save(dir_, "mission", rm.cdr)},
                                    {"SecurityEvent", save(dir_, "event", re.cdr)},
                                    {"SensorGps", save(dir_, "gps", rg.cdr)}});

  const Struct& s = json_at(out, "VehicleStateEstimate").struct_value();
  EXPECT_EQ(u64(json_at(s, "timestamp_ns")), "1311768467463790321");
  expect_doubles(json_at(s, "p_n_m"), state.p_N_m, 3, "p_n_m");
  expect_doubles(json_at(s, "v_n_m_s"), state.v_N_m_s, 3, "v_n_m_s");
  expect_doubles(json_at(s, "q_nb"), state.q_NB, 4, "q_nb");
  expect_doubles(json_at(s, "omega_b_rad_s"), state.omega_B_rad_s, 3, "omega_b_rad_s");
  expect_doubles(json_at(s, "gyro_bias_rad_s"), state.gyro_bias_rad_s, 3, "gyro_bias_rad_s");
  expect_doubles(json_at(s, "accel_bias_m_s2"), state.accel_bias_m_s2, 3, "accel_bias_m_s2");
  expect_doubles(json_at(s, "variance_p_m2"), state.variance_p_m2, 3, "variance_p_m2");
  expect_doubles(json_at(s, "variance_v_m2_s2"), state.variance_v_m2_s2, 3, "variance_v_m2_s2");
  EXPECT_EQ(json_at(s, "flags").number_value(), 11);

  const Struct& m = json_at(out, "MissionWaypoints").struct_value();
  EXPECT_EQ(u64(json_at(m, "timestamp_ns")), "42");
  EXPECT_EQ(json_at(m, "count").number_value(), 3);
  EXPECT_DOUBLE_EQ(json_at(m, "acceptance_radius_m").number_value(), 0.35);
  const auto& wps = json_at(m, "waypoints").list_value();
  ASSERT_EQ(wps.values_size(), 16);
  for (int i = 0; i < 16; ++i) {
    const Struct& w = wps.values(i).struct_value();
    expect_doubles(json_at(w, "p_n_m"), mission.waypoints[i].p_N_m, 3, "waypoints[" + std::to_string(i) + "].p_n_m");
    EXPECT_DOUBLE_EQ(json_at(w, "yaw_rad").number_value(), mission.waypoints[i].yaw_rad) << i;
  }

  const Struct& e = json_at(out, "SecurityEvent").struct_value();
  EXPECT_EQ(u64(json_at(e, "timestamp_ns")), "7");
  EXPECT_EQ(json_at(e, "service_id").number_value(), 5);
  EXPECT_EQ(json_at(e, "slot").number_value(), 231);
  EXPECT_EQ(json_at(e, "operation").number_value(), 3);
  EXPECT_EQ(json_at(e, "error").number_value(), 250);
  EXPECT_EQ(json_at(e, "mode").number_value(), rejuv_msg_SR_MODE_CP);
  EXPECT_EQ(json_at(e, "kind").number_value(), rejuv_msg_SECURITY_PUBLICATION_BUDGET);

  const Struct& g = json_at(out, "SensorGps").struct_value();
  EXPECT_EQ(u64(json_at(g, "timestamp_ns")), "99");
  expect_doubles(json_at(g, "p_n_m"), gps.p_N_m, 3, "gps p_n_m");
  expect_doubles(json_at(g, "v_n_m_s"), gps.v_N_m_s, 3, "gps v_n_m_s");
  EXPECT_DOUBLE_EQ(json_at(g, "eph_m").number_value(), 1.5);
  EXPECT_DOUBLE_EQ(json_at(g, "epv_m").number_value(), 2.5);
  EXPECT_EQ(json_at(g, "fix_type").number_value(), 3);
  EXPECT_EQ(json_at(g, "satellites_used").number_value(), 11);
}

// A flight with dds.ros2_names: a ROS 2 reader (a plain Cyclone reader of rt/vehicle_state and rt/sr_mode with
// the ROS 2 type names, in the default partition, decoding with the npm reader) sees the estimate of a
// vehicle hovering at its start, 3 m up, and the SR mode; the run, whose plant follows the same names,
// completes.
TEST_F(Ros2Names, FlightWithRos2Names_Ros2ReaderSeesTheVehicle) {
  ASSERT_TRUE(fs::exists(kReaderDir / "node_modules/@foxglove/rosmsg2-serialization/package.json"))
      << "run ./rejuv once: it installs tests/ros2_msgs' npm packages into " << kReaderDir;
  std::ofstream(dir_ / "ros2.launch.pbtxt") << "dds { ros2_names: true }\n";
  const std::uint32_t domain = test_support::kOwnDdsDomain;

  const dds_entity_t participant = dds_create_participant(domain, nullptr, nullptr);
  ASSERT_GT(participant, 0) << dds_strretcode(participant);
  struct Topic {
    const char* topic;
    const char* type;
    dds_entity_t reader = 0;
    std::vector<unsigned char> cdr{};  // the newest sample taken
    std::string type_name{};           // as discovery announced the kernel's writer
  };
  std::array<Topic, 2> topics{Topic{.topic = "vehicle_state", .type = "rejuv::msg::VehicleStateEstimate"},
                              Topic{.topic = "sr_mode", .type = "rejuv::msg::SrMode"}};
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  for (Topic& t : topics) {
    const msgs::DdsTopic ros = msgs::dds_topic(t.topic, *msgs::find_topic_type(t.type), DdsNaming::Ros2);
    const dds_entity_t topic = dds_create_topic(participant, ros.type->descriptor, ros.name.c_str(), nullptr, nullptr);
    ASSERT_GT(topic, 0) << dds_strretcode(topic);
    t.reader = dds_create_reader(participant, topic, qos, nullptr);
    ASSERT_GT(t.reader, 0) << dds_strretcode(t.reader);
  }
  dds_delete_qos(qos);

  const pid_t run = test_support::start_program(
      dir_, test_support::kRejuv,
      {"run", (test_support::kRepo / "launch/quad_square.launch.pbtxt").string(), (dir_ / "ros2.launch.pbtxt").string(),
       "--duration", "2", "--no-attack", "--domain", std::to_string(domain)});
  ASSERT_GT(run, 0);
  // Take what arrives until the run ends (its exit ends the wait; the bound only keeps a broken build from hanging).
  const dds_entity_t ws = dds_create_waitset(participant);
  for (Topic& t : topics) EXPECT_EQ(dds_waitset_attach(ws, dds_create_readcondition(t.reader, DDS_ANY_STATE), 0), 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes{5};
  int status = 0;
  bool ended = false;
  while (!ended && std::chrono::steady_clock::now() < deadline) {
    (void)dds_waitset_wait(ws, nullptr, 0, DDS_MSECS(100));
    for (Topic& t : topics) {
      ddsi_serdata* serdata = nullptr;
      dds_sample_info_t info{};
      while (dds_takecdr(t.reader, &serdata, 1, &info, DDS_ANY_STATE) == 1) {
        if (!info.valid_data) {  // the writer's unregistration when the run ends: no sample
          ddsi_serdata_unref(serdata);
          continue;
        }
        t.cdr.resize(ddsi_serdata_size(serdata));
        ddsi_serdata_to_ser(serdata, 0, t.cdr.size(), t.cdr.data());
        ddsi_serdata_unref(serdata);
        if (!t.type_name.empty()) continue;
        if (dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(t.reader, info.publication_handle)) {
          t.type_name = ep->type_name;
          dds_builtintopic_free_endpoint(ep);
        }
      }
    }
    ended = ::waitpid(run, &status, WNOHANG) == run;
  }
  if (!ended) {
    ::kill(run, SIGKILL);
    ::waitpid(run, &status, 0);
  }
  dds_delete(participant);
  ASSERT_TRUE(ended) << "the run did not end within the liveness bound";
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << test_support::slurp(dir_ / "stderr");
  ASSERT_FALSE(topics[0].cdr.empty()) << "no vehicle_state on rt/vehicle_state";
  ASSERT_FALSE(topics[1].cdr.empty()) << "no sr_mode on rt/sr_mode";
  EXPECT_EQ(topics[0].type_name, "rejuv_msgs::msg::dds_::VehicleStateEstimate_");
  EXPECT_EQ(topics[1].type_name, "rejuv_msgs::msg::dds_::SrMode_");

  const Struct out = decode(dir_, {{"VehicleStateEstimate", save(dir_, "state", topics[0].cdr)},
                                   {"SrMode", save(dir_, "mode", topics[1].cdr)}});
  const Struct& s = json_at(out, "VehicleStateEstimate").struct_value();
  const auto& p = json_at(s, "p_n_m").list_value();
  ASSERT_EQ(p.values_size(), 3);
  EXPECT_NEAR(p.values(0).number_value(), 0.0, 0.5);
  EXPECT_NEAR(p.values(1).number_value(), 0.0, 0.5);
  EXPECT_NEAR(p.values(2).number_value(), -3.0, 0.5) << "3 m up (NED)";
  const auto& q = json_at(s, "q_nb").list_value();
  ASSERT_EQ(q.values_size(), 4);
  double norm2 = 0;
  for (int i = 0; i < 4; ++i) norm2 += q.values(i).number_value() * q.values(i).number_value();
  EXPECT_NEAR(norm2, 1.0, 1e-6) << "a unit quaternion";
  const Struct& m = json_at(out, "SrMode").struct_value();
  EXPECT_LE(json_at(m, "mode").number_value(), rejuv_msg_SR_MODE_CP) << "one of the five SR modes";
  EXPECT_GE(std::stoull(u64(json_at(m, "timestamp_ns"))), 1u);
}

}  // namespace
}  // namespace rejuv
