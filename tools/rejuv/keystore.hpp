// The DDS Security keystore of a graph across hosts (docs/across_hosts.md): `rejuv keys init DIR` makes one
// certificate authority (EC prime256v1) that serves as the identity CA and the permissions CA, as SROS2 does;
// `rejuv keys hosts DIR --launch GRAPH` writes per host of the graph an enclave: an identity (CN = the host's
// name) signed by the CA, a permissions document that grants exactly the cross-host topics the host writes and
// reads (policy::host_topics, under the graph's DDS names; default DENY), and a governance document that encrypts everything and refuses
// unauthenticated participants, both signed S/MIME (PKCS#7 detached, text) by the CA. The layout is SROS2's,
// so a ROS 2 enclave can join the same keystore:
//   public/{ca,identity_ca,permissions_ca}.cert.pem   private/{ca,identity_ca,permissions_ca}.key.pem (0600)
//   enclaves/governance.{xml,p7s}
//   enclaves/<host>/{cert.pem,key.pem,identity_ca.cert.pem,permissions_ca.cert.pem,governance.p7s,
//                    permissions.xml,permissions.p7s}
// The cryptography is OpenSSL's libcrypto (no `openssl` program).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/cyclone_xml.hpp"
#include "rejuv/core/result.hpp"

namespace rejuv::keys {

// The files of a host's enclave (enclaves/<host>/) that a participant's DDS Security configuration names.
namespace enclave_file = cyclone::enclave_file;

// DIR/enclaves/<host>: the enclave of host `host` that write_enclaves makes.
[[nodiscard]] inline std::filesystem::path enclave_dir(const std::filesystem::path& dir, std::string_view host) {
  return dir / "enclaves" / std::string(host);
}

// What one host may publish and subscribe to (DDS topic names), as the policy's crossings say.
struct HostGrant {
  std::string host;  // CN of its identity and the name of its enclave
  std::vector<std::string> publish;
  std::vector<std::string> subscribe;
};

// The CA of DIR: public/ca.cert.pem and private/ca.key.pem (0600), with SROS2's identity_ca / permissions_ca
// names beside them. DIR may exist; an existing CA is never overwritten (the error says so).
[[nodiscard]] Result<void, std::string> init_keystore(const std::filesystem::path& dir);

// Every host's enclave in DIR (made by init_keystore): its identity is kept when it exists with the right CN
// (re-run after a policy change: new permissions, same keys), else made; permissions and governance are
// written again. `domain_id`: the DDS domain the permissions allow.
[[nodiscard]] Result<void, std::string> write_enclaves(const std::filesystem::path& dir,
                                                       const std::vector<HostGrant>& hosts, std::uint32_t domain_id);

// Whether DIR's enclaves match what the policy grants: per host, its identity (CN = the host, issued by the CA,
// its key secret and its own), permissions signed by the CA granting exactly `hosts`' topics in `domain_id`
// with default DENY, and a governance signed by the CA that refuses unauthenticated participants. One message
// per mismatch ("enclave vehicle: ..."); empty when the keystore matches. An error: DIR has no CA.
[[nodiscard]] Result<std::vector<std::string>, std::string> check_enclaves(const std::filesystem::path& dir,
                                                                          const std::vector<HostGrant>& hosts,
                                                                          std::uint32_t domain_id);

// The documents, as written (unsigned), for tests and `keys hosts --print`.
[[nodiscard]] std::string governance_xml(std::uint32_t domain_id);
[[nodiscard]] std::string permissions_xml(const HostGrant& host, std::uint32_t domain_id);

// Checks a signed document against the CA of DIR (PKCS7_verify with the CA as the only trust anchor); the
// signed content on success (line ends as written: LF).
[[nodiscard]] Result<std::string, std::string> verify_signed(const std::filesystem::path& dir,
                                                             const std::filesystem::path& p7s);

}  // namespace rejuv::keys
