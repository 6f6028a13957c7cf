// rejuv_host_link's logic (services/host_link host_link.hpp): the Cyclone configuration it generates (its
// interface, both ends as unicast peers, DDS Security from its enclave with the key inline) and the MC window
// that drops what the peer wrote while the link was closed.
#include <gtest/gtest.h>

#include <string>

#include "rejuv/services/host_link/host_link.hpp"

namespace rejuv::services::host_link {
namespace {

TEST(HostLinkConfig, InterfacePeersAndSecurityFromTheEnclave) {
  const std::string xml = cyclone_config({.address = "10.77.0.1",
                                          .peers = {"10.77.0.1", "10.77.0.2"},
                                          .enclave = "/keys/enclaves/vehicle",
                                          .private_key_pem = "-----BEGIN PRIVATE KEY-----\nAB\n-----END PRIVATE KEY-----\n"});
  EXPECT_NE(xml.find("<NetworkInterface address=\"10.77.0.1\"/>"), std::string::npos) << xml;
  EXPECT_NE(xml.find("<AllowMulticast>false</AllowMulticast>"), std::string::npos) << xml;
  EXPECT_NE(xml.find("<SPDPInterval>1s</SPDPInterval>"), std::string::npos) << "announced every second: " << xml;
  EXPECT_NE(xml.find("<Peer address=\"10.77.0.1\"/><Peer address=\"10.77.0.2\"/>"), std::string::npos) << xml;
  EXPECT_NE(xml.find("<IdentityCA>file:/keys/enclaves/vehicle/identity_ca.cert.pem</IdentityCA>"), std::string::npos);
  EXPECT_NE(xml.find("<IdentityCertificate>file:/keys/enclaves/vehicle/cert.pem</IdentityCertificate>"), std::string::npos);
  EXPECT_NE(xml.find("<PrivateKey>data:,-----BEGIN PRIVATE KEY-----"), std::string::npos) << xml;
  EXPECT_EQ(xml.find("key.pem"), std::string::npos) << "the key comes inline, not by its path";
  EXPECT_NE(xml.find("<Governance>file:/keys/enclaves/vehicle/governance.p7s</Governance>"), std::string::npos);
  EXPECT_NE(xml.find("<Permissions>file:/keys/enclaves/vehicle/permissions.p7s</Permissions>"), std::string::npos);
  EXPECT_NE(xml.find("<PermissionsCA>file:/keys/enclaves/vehicle/permissions_ca.cert.pem</PermissionsCA>"), std::string::npos);
}

TEST(HostLinkConfig, WithoutAKeyGiven_TheEnclavesKeyFile) {
  const std::string xml = cyclone_config({.address = "10.0.0.1", .peers = {"10.0.0.2"}, .enclave = "/e", .private_key_pem = ""});
  EXPECT_NE(xml.find("<PrivateKey>file:/e/key.pem</PrivateKey>"), std::string::npos) << xml;
}

TEST(HostLinkWindow, ClosedUntilMc_ThenOnlyWhatWasWrittenSince) {
  McWindow w;
  EXPECT_FALSE(w.open());
  EXPECT_FALSE(w.admits(100));
  EXPECT_FALSE(w.observe(false, 1000));  // SC: still closed
  EXPECT_TRUE(w.observe(true, 2000));    // MC begins at 2000
  EXPECT_TRUE(w.open());
  EXPECT_FALSE(w.admits(1999));  // written while closed
  EXPECT_TRUE(w.admits(2000));
  EXPECT_TRUE(w.admits(2500));
  EXPECT_FALSE(w.observe(true, 2600));  // still the same window
  EXPECT_EQ(w.began_ns(), 2000);
  EXPECT_FALSE(w.observe(false, 3000));  // RB: closed again
  EXPECT_FALSE(w.admits(3500));
  EXPECT_TRUE(w.observe(true, 4000));  // the next window
  EXPECT_FALSE(w.admits(3500));        // written in the secure interval: dropped
  EXPECT_TRUE(w.admits(4001));
}

}  // namespace
}  // namespace rejuv::services::host_link
