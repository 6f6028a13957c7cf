// rejuv_host_link's logic apart from the SDK and Cyclone (host_link.hpp).
#include "rejuv/services/host_link/host_link.hpp"

namespace rejuv::services::host_link {

namespace {

// The enclave's files, named as `rejuv keys hosts` writes them (tools/rejuv keystore.hpp enclave_file).
constexpr const char* kIdentityCa = "identity_ca.cert.pem";
constexpr const char* kCert = "cert.pem";
constexpr const char* kKey = "key.pem";
constexpr const char* kPermissionsCa = "permissions_ca.cert.pem";
constexpr const char* kGovernance = "governance.p7s";
constexpr const char* kPermissions = "permissions.p7s";

std::string file_uri(const std::filesystem::path& enclave, const char* name) { return "file:" + (enclave / name).string(); }

}  // namespace

std::string cyclone_config(const CycloneSettings& s) {
  std::string peers;
  for (const std::string& p : s.peers) peers += "<Peer address=\"" + p + "\"/>";
  return "<CycloneDDS xmlns=\"https://cdds.io/config\"><Domain id=\"any\"><General><Interfaces>"
         "<NetworkInterface address=\"" + s.address + "\"/></Interfaces>"
         "<AllowMulticast>false</AllowMulticast></General><Discovery>"
         "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>20</MaxAutoParticipantIndex>"
         "<Peers>" + peers + "</Peers>"
         // Announced every second, not every 30 s: the vehicle's end opens only in MC (its host closes the link
         // below DDS in the secure interval), so discovery and the security handshake happen in MC windows.
         "<SPDPInterval>1s</SPDPInterval></Discovery>"
         "<Security><Authentication>"
         "<IdentityCA>" + file_uri(s.enclave, kIdentityCa) + "</IdentityCA>"
         "<IdentityCertificate>" + file_uri(s.enclave, kCert) + "</IdentityCertificate>"
         "<PrivateKey>" + (s.private_key_pem.empty() ? file_uri(s.enclave, kKey) : "data:," + s.private_key_pem) +
         "</PrivateKey>"
         "</Authentication><AccessControl>"
         "<PermissionsCA>" + file_uri(s.enclave, kPermissionsCa) + "</PermissionsCA>"
         "<Governance>" + file_uri(s.enclave, kGovernance) + "</Governance>"
         "<Permissions>" + file_uri(s.enclave, kPermissions) + "</Permissions>"
         "</AccessControl></Security></Domain></CycloneDDS>";
}

bool McWindow::observe(bool in_mc, std::int64_t now_ns) {
  const bool began = in_mc && !in_mc_;
  if (began) began_ns_ = now_ns;
  in_mc_ = in_mc;
  return began;
}

}  // namespace rejuv::services::host_link
