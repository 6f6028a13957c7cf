// The Cyclone DDS sizing every participant of Rejuv has is spelt twice, in code (rejuv/core/cyclone_xml.hpp, the
// cross-host participants) and in the config file the kernel, the plant and the tests use (config/cyclonedds.xml):
// both say the same.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "rejuv/core/cyclone_xml.hpp"

namespace {

std::string config_file() {
  std::ifstream in(std::string(REJUV_SOURCE_DIR) + "/config/cyclonedds.xml");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(CycloneXml, ReceiveBuffers_TheConfigFileSaysWhatTheCodeSays) {
  const std::string file = config_file();
  ASSERT_FALSE(file.empty()) << "config/cyclonedds.xml not read";
  const std::string size = "<ReceiveBufferSize>" + std::string(rejuv::cyclone::kReceiveBufferSize) + "</ReceiveBufferSize>";
  const std::string chunk =
      "<ReceiveBufferChunkSize>" + std::string(rejuv::cyclone::kReceiveBufferChunkSize) + "</ReceiveBufferChunkSize>";
  EXPECT_NE(file.find(size), std::string::npos) << file;
  EXPECT_NE(file.find(chunk), std::string::npos) << file;
  const std::string xml = rejuv::cyclone::config_xml({.address = "10.0.0.1", .peers = {"10.0.0.1"}});
  EXPECT_NE(xml.find(size), std::string::npos) << xml;
  EXPECT_NE(xml.find(chunk), std::string::npos) << xml;
}

}  // namespace
