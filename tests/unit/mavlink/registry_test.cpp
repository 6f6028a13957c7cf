// The codec's field lists against the protocol's own definitions: every message kernel_sim/mavlink encodes or
// decodes (the Message variant) written out — id, name, fields in wire order with type and array length, which
// are extensions, payload size, CRC_EXTRA — and compared by tests/mavlink_client/registry_check.js with
// node-mavlink's registry (generated from the MAVLink XML, not from this codec).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <variant>

#include "../../node_script.hpp"
#include "rejuv/mavlink/messages.hpp"

namespace rejuv::mavlink {
namespace {

template <class T>
struct ArrayLength {
  static constexpr std::size_t kValue = 0;
};
template <class T, std::size_t N>
struct ArrayLength<std::array<T, N>> {
  static constexpr std::size_t kValue = N;
};

template <class M>
std::string definition_of() {
  std::ostringstream out;
  out << R"({"id":)" << M::kId << R"(,"name":")" << M::kName << R"(","crc_extra":)" << int{crc_extra<M>()}
      << R"(,"payload_bytes":)" << payload_bytes<M>() << R"(,"fields":[)";
  std::size_t i = 0;
  M m{};
  M::each(m, [&](std::string_view name, const auto& v) {
    using T = std::remove_cvref_t<decltype(v)>;
    out << (i == 0 ? "" : ",") << R"({"name":")" << name << R"(","type":")" << detail::FieldType<T>::kName
        << R"(","length":)" << ArrayLength<T>::kValue << R"(,"extension":)" << (i >= M::kBaseFields ? "true" : "false")
        << "}";
    ++i;
  });
  out << "]}";
  return out.str();
}

template <class... M>
std::string codec_json(std::variant<M...>*) {
  std::string messages;
  ((messages += (messages.empty() ? "" : ",") + definition_of<M>()), ...);
  return R"({"messages":[)" + messages + "]}";
}

TEST(Registry, EveryMessageOfTheCodec_AgreesWithNodeMavlink) {
  const std::filesystem::path modules = std::filesystem::path(REJUV_BINARY_DIR) / "mavlink_client/node_modules";
  ASSERT_TRUE(std::filesystem::exists(modules / "node-mavlink/package.json"))
      << "node-mavlink is not installed: ./rejuv build installs it (npm ci in " << modules.parent_path().string() << ")";
  const auto dir = std::filesystem::temp_directory_path() / ("rejuv_registry_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto codec = dir / "codec.json";
  std::ofstream(codec) << codec_json(static_cast<Message*>(nullptr));
  const auto out = dir / "check.txt";
  const pid_t pid = test_support::start_node_script(std::filesystem::path(REJUV_SOURCE_DIR) / "tests/mavlink_client/registry_check.js",
                                                    modules, {codec.string()}, out);
  ASSERT_GT(pid, 0) << "cannot start node";
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  std::ostringstream read;
  read << std::ifstream(out).rdbuf();
  const std::string printed = read.str();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << printed;
  // Every message was compared (the summary line counts them).
  EXPECT_NE(printed.find("\"messages\":" + std::to_string(std::variant_size_v<Message>)), std::string::npos) << printed;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rejuv::mavlink
