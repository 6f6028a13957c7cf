// The Cyclone DDS configuration of a participant that speaks to other hosts (docs/across_hosts.md): its own
// address, the other hosts as unicast peers, no multicast, and, with an enclave, DDS Security from the files
// `rejuv keys hosts` writes (SROS2's names). One text for the link process (services/host_link), the
// benchmark between namespaces (`rejuv bench across-hosts`) and the tests' participants.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rejuv::cyclone {

// The files of a host's enclave (enclaves/<host>/) that a participant's DDS Security configuration names.
namespace enclave_file {
inline constexpr std::string_view kIdentityCa = "identity_ca.cert.pem";
inline constexpr std::string_view kCert = "cert.pem";
inline constexpr std::string_view kKey = "key.pem";
inline constexpr std::string_view kPermissionsCa = "permissions_ca.cert.pem";
inline constexpr std::string_view kGovernance = "governance.p7s";
inline constexpr std::string_view kPermissions = "permissions.p7s";
}  // namespace enclave_file

// Cyclone's receive buffer and its chunk (one datagram's room), for every participant of Rejuv: this config and
// config/cyclonedds.xml, which spells the same values (tests/unit/core/cyclone_xml_test.cpp checks it; why they
// are small is said there).
inline constexpr std::string_view kReceiveBufferSize = "128KiB";
inline constexpr std::string_view kReceiveBufferChunkSize = "32KiB";

struct ParticipantConfig {
  std::string address;                  // its own IPv4 address (the interface it uses)
  std::vector<std::string> peers;       // every host's address, its own included
  std::filesystem::path enclave{};      // empty: no security
  // The private key's PEM given inline ("data:,"); empty: the enclave's key.pem by its path.
  std::string private_key_pem{};
  std::optional<std::string> spdp_interval{};  // e.g. "1s"; unset: Cyclone's default (30 s)
};

inline std::string config_xml(const ParticipantConfig& c) {
  const auto file = [&](std::string_view name) { return "file:" + (c.enclave / name).string(); };
  std::string peers;
  for (const std::string& p : c.peers) peers += "<Peer address=\"" + p + "\"/>";
  std::string xml = "<CycloneDDS xmlns=\"https://cdds.io/config\"><Domain id=\"any\"><General><Interfaces>"
                    "<NetworkInterface address=\"" + c.address + "\"/></Interfaces>"
                    "<AllowMulticast>false</AllowMulticast></General><Discovery>"
                    "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>20</MaxAutoParticipantIndex>"
                    "<Peers>" + peers + "</Peers>";
  if (c.spdp_interval) xml += "<SPDPInterval>" + *c.spdp_interval + "</SPDPInterval>";
  xml += "</Discovery><Sizing><ReceiveBufferSize>" + std::string(kReceiveBufferSize) +
         "</ReceiveBufferSize><ReceiveBufferChunkSize>" + std::string(kReceiveBufferChunkSize) +
         "</ReceiveBufferChunkSize></Sizing>";
  if (!c.enclave.empty()) {
    namespace f = enclave_file;
    xml += "<Security><Authentication>"
           "<IdentityCA>" + file(f::kIdentityCa) + "</IdentityCA>"
           "<IdentityCertificate>" + file(f::kCert) + "</IdentityCertificate>"
           "<PrivateKey>" + (c.private_key_pem.empty() ? file(f::kKey) : "data:," + c.private_key_pem) + "</PrivateKey>"
           "</Authentication><AccessControl>"
           "<PermissionsCA>" + file(f::kPermissionsCa) + "</PermissionsCA>"
           "<Governance>" + file(f::kGovernance) + "</Governance>"
           "<Permissions>" + file(f::kPermissions) + "</Permissions>"
           "</AccessControl></Security>";
  }
  return xml + "</Domain></CycloneDDS>";
}

}  // namespace rejuv::cyclone
