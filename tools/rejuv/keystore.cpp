// The DDS Security keystore (keystore.hpp): a CA, the hosts' identities and their signed documents, made
// with OpenSSL's libcrypto. One file, one concern: the documents and the cryptography that signs them.
#include "keystore.hpp"

#include <fcntl.h>
#include <openssl/bio.h>
#include <openssl/bn.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <fstream>
#include <memory>
#include <sstream>
#include <string_view>
#include <system_error>
#include <set>

namespace rejuv::keys {

namespace {

namespace fs = std::filesystem;

// Owning handles of libcrypto's objects (CONVENTIONS "Ownership is visible").
struct Free {
  void operator()(EVP_PKEY* p) const { EVP_PKEY_free(p); }
  void operator()(X509* p) const { X509_free(p); }
  void operator()(BIO* p) const { BIO_free_all(p); }
  void operator()(PKCS7* p) const { PKCS7_free(p); }
  void operator()(X509_STORE* p) const { X509_STORE_free(p); }
  void operator()(BIGNUM* p) const { BN_free(p); }
  void operator()(X509_EXTENSION* p) const { X509_EXTENSION_free(p); }
};
using Key = std::unique_ptr<EVP_PKEY, Free>;
using Cert = std::unique_ptr<X509, Free>;
using Bio = std::unique_ptr<BIO, Free>;
using Pkcs7 = std::unique_ptr<PKCS7, Free>;
using Store = std::unique_ptr<X509_STORE, Free>;
using Bignum = std::unique_ptr<BIGNUM, Free>;
using Extension = std::unique_ptr<X509_EXTENSION, Free>;

constexpr long kValidityS = 10L * 365 * 24 * 3600;  // ten years, as SROS2's certificates
constexpr long kBackdateS = 3600;                    // valid from an hour ago: a host's clock may lag a little

// libcrypto's error queue as text, after what failed.
std::string ssl_error(std::string_view what) {
  std::string out(what);
  unsigned long e = 0;
  while ((e = ERR_get_error()) != 0) {
    char buf[256];
    ERR_error_string_n(e, buf, sizeof buf);
    out += std::string(": ") + buf;
  }
  return out;
}

Result<std::string, std::string> read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return fail(p.string() + ": cannot be read");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Writes `content` to `p` with `mode`. Exclusive: refuses an existing file (a CA is never overwritten);
// otherwise replaces it atomically (a temporary beside it, renamed).
enum class Overwrite : std::uint8_t { Refuse, Replace };
Result<void, std::string> write_file(const fs::path& p, std::string_view content, mode_t mode, Overwrite how) {
  const fs::path target = how == Overwrite::Refuse ? p : fs::path(p.string() + ".tmp");
  const int flags = O_WRONLY | O_CREAT | O_CLOEXEC | (how == Overwrite::Refuse ? O_EXCL : O_TRUNC);
  const int fd = ::open(target.c_str(), flags, mode);
  if (fd < 0) {
    return fail(p.string() + ": " + (errno == EEXIST ? "exists already; refusing to overwrite it" : std::strerror(errno)));
  }
  bool ok = ::fchmod(fd, mode) == 0;  // the umask may have narrowed it; never widened beyond `mode`
  std::size_t off = 0;
  while (ok && off < content.size()) {
    const ssize_t n = ::write(fd, content.data() + off, content.size() - off);
    if (n < 0 && errno == EINTR) continue;
    ok = n > 0;
    if (ok) off += static_cast<std::size_t>(n);
  }
  ok = ::close(fd) == 0 && ok;
  if (!ok) return fail(p.string() + ": cannot be written: " + std::strerror(errno));
  if (how == Overwrite::Replace) {
    std::error_code ec;
    fs::rename(target, p, ec);
    if (ec) return fail(p.string() + ": " + ec.message());
  }
  return {};
}

Result<void, std::string> make_dir(const fs::path& p, fs::perms perms) {
  std::error_code ec;
  fs::create_directories(p, ec);
  if (ec) return fail(p.string() + ": cannot be made: " + ec.message());
  if (!fs::is_directory(p)) return fail(p.string() + ": not a directory");
  fs::permissions(p, perms, ec);
  if (ec) return fail(p.string() + ": " + ec.message());
  return {};
}

Result<Key, std::string> new_key() {
  Key key(EVP_PKEY_Q_keygen(nullptr, nullptr, "EC", "P-256"));  // prime256v1
  if (!key) return fail(ssl_error("EC key generation"));
  return key;
}

Result<void, std::string> add_ext(X509* cert, X509* issuer, int nid, const char* value) {
  X509V3_CTX ctx;
  X509V3_set_ctx_nodb(&ctx);
  X509V3_set_ctx(&ctx, issuer, cert, nullptr, nullptr, 0);
  Extension ext(X509V3_EXT_conf_nid(nullptr, &ctx, nid, value));
  if (!ext || X509_add_ext(cert, ext.get(), -1) != 1) return fail(ssl_error(std::string("extension ") + value));
  return {};
}

// A certificate for `cn` holding `key`'s public key, signed by `issuer_key` (issuer null: self-signed CA).
Result<Cert, std::string> new_cert(const std::string& cn, EVP_PKEY* key, X509* issuer, EVP_PKEY* issuer_key) {
  Cert cert(X509_new());
  if (!cert) return fail(ssl_error("X509_new"));
  X509_set_version(cert.get(), 2);  // v3
  Bignum serial(BN_new());
  if (!serial || BN_rand(serial.get(), 159, BN_RAND_TOP_ANY, BN_RAND_BOTTOM_ANY) != 1 ||
      BN_to_ASN1_INTEGER(serial.get(), X509_get_serialNumber(cert.get())) == nullptr) {
    return fail(ssl_error("serial number"));
  }
  X509_gmtime_adj(X509_getm_notBefore(cert.get()), -kBackdateS);
  X509_gmtime_adj(X509_getm_notAfter(cert.get()), kValidityS);
  X509_NAME* name = X509_get_subject_name(cert.get());
  if (X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_UTF8, reinterpret_cast<const unsigned char*>(cn.c_str()), -1,
                                 -1, 0) != 1) {
    return fail(ssl_error("subject CN=" + cn));
  }
  X509* signer = issuer != nullptr ? issuer : cert.get();
  X509_set_issuer_name(cert.get(), X509_get_subject_name(signer));
  X509_set_pubkey(cert.get(), key);
  const bool ca = issuer == nullptr;
  for (auto [nid, value] : {std::pair{NID_basic_constraints, ca ? "critical,CA:TRUE" : "critical,CA:FALSE"},
                            std::pair{NID_subject_key_identifier, "hash"}}) {
    if (auto r = add_ext(cert.get(), signer, nid, value); !r) return fail(r.error());
  }
  if (X509_sign(cert.get(), issuer_key, EVP_sha256()) == 0) return fail(ssl_error("signing the certificate of " + cn));
  return cert;
}

Result<std::string, std::string> bio_text(BIO* bio) {
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio, &data);
  if (n < 0) return fail(std::string("BIO_get_mem_data"));
  return std::string(data, static_cast<std::size_t>(n));
}

Result<std::string, std::string> pem_of(X509* cert) {
  Bio bio(BIO_new(BIO_s_mem()));
  if (!bio || PEM_write_bio_X509(bio.get(), cert) != 1) return fail(ssl_error("PEM of a certificate"));
  return bio_text(bio.get());
}

Result<std::string, std::string> pem_of(EVP_PKEY* key) {
  Bio bio(BIO_new(BIO_s_mem()));
  if (!bio || PEM_write_bio_PrivateKey(bio.get(), key, nullptr, nullptr, 0, nullptr, nullptr) != 1) {
    return fail(ssl_error("PEM of a private key"));
  }
  return bio_text(bio.get());
}

// The PEM object in file p, read by `read` (PEM_read_bio_X509, PEM_read_bio_PrivateKey); `what` names it in errors.
template <typename Owned, typename Raw>
Result<Owned, std::string> load_pem(const fs::path& p, Raw* (*read)(BIO*, Raw**, pem_password_cb*, void*),
                                    std::string_view what) {
  auto text = read_file(p);
  if (!text) return fail(text.error());
  Bio bio(BIO_new_mem_buf(text->data(), static_cast<int>(text->size())));
  Owned object(read(bio.get(), nullptr, nullptr, nullptr));
  if (!object) return fail(ssl_error(p.string() + ": not a PEM " + std::string(what)));
  return object;
}

Result<Cert, std::string> load_cert(const fs::path& p) { return load_pem<Cert>(p, PEM_read_bio_X509, "certificate"); }

Result<Key, std::string> load_key(const fs::path& p) {
  return load_pem<Key>(p, PEM_read_bio_PrivateKey, "private key");
}

// S/MIME, PKCS#7 detached and text (multipart/signed, the content as text/plain), the signer's certificate
// inside: the format DDS Security's builtin access control reads (OMG DDS Security 9.4.1.3), as SROS2 signs.
Result<std::string, std::string> smime_sign(std::string_view content, X509* cert, EVP_PKEY* key) {
  constexpr int kFlags = PKCS7_DETACHED | PKCS7_TEXT;
  Bio in(BIO_new_mem_buf(content.data(), static_cast<int>(content.size())));
  Pkcs7 p7(PKCS7_sign(cert, key, nullptr, in.get(), kFlags));
  if (!p7) return fail(ssl_error("PKCS7_sign"));
  Bio again(BIO_new_mem_buf(content.data(), static_cast<int>(content.size())));
  Bio out(BIO_new(BIO_s_mem()));
  if (!out || SMIME_write_PKCS7(out.get(), p7.get(), again.get(), kFlags) != 1) return fail(ssl_error("SMIME_write_PKCS7"));
  return bio_text(out.get());
}

std::string utc(std::time_t t) {
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

// XML text of a name from the graph (host names are [A-Za-z0-9_-], topic names the policy's plain names; the
// escape keeps the documents well-formed whatever they hold).
std::string xml(std::string_view s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

struct Ca {
  Cert cert;
  Key key;
};

Result<Ca, std::string> load_ca(const fs::path& dir) {
  if (!fs::exists(dir / "public" / "ca.cert.pem") || !fs::exists(dir / "private" / "ca.key.pem")) {
    return fail(dir.string() + ": no keystore CA (public/ca.cert.pem and private/ca.key.pem); make one with "
                               "`rejuv keys init " + dir.string() + "`");
  }
  auto cert = load_cert(dir / "public" / "ca.cert.pem");
  if (!cert) return fail(cert.error());
  auto key = load_key(dir / "private" / "ca.key.pem");
  if (!key) return fail(key.error());
  if (X509_check_private_key(cert->get(), key->get()) != 1) {
    return fail(dir.string() + ": private/ca.key.pem is not the key of public/ca.cert.pem");
  }
  return Ca{std::move(*cert), std::move(*key)};
}

std::string common_name(X509* cert) {
  char buf[256] = {};
  X509_NAME_get_text_by_NID(X509_get_subject_name(cert), NID_commonName, buf, sizeof buf);
  return buf;
}

// A host's identity: kept when its enclave holds one of the right CN, issued by this CA, with its key.
Result<void, std::string> ensure_identity(const fs::path& enclave, const std::string& cn, const Ca& ca) {
  const fs::path cert_path = enclave / enclave_file::kCert, key_path = enclave / enclave_file::kKey;
  if (fs::exists(cert_path) && fs::exists(key_path)) {
    auto cert = load_cert(cert_path);
    auto key = load_key(key_path);
    if (cert && key && common_name(cert->get()) == cn && X509_check_private_key(cert->get(), key->get()) == 1 &&
        X509_verify(cert->get(), X509_get0_pubkey(ca.cert.get())) == 1) {
      return {};
    }
  }
  auto key = new_key();
  if (!key) return fail(key.error());
  auto cert = new_cert(cn, key->get(), ca.cert.get(), ca.key.get());
  if (!cert) return fail(cert.error());
  auto key_pem = pem_of(key->get());
  auto cert_pem = pem_of(cert->get());
  if (!key_pem || !cert_pem) return fail(!key_pem ? key_pem.error() : cert_pem.error());
  if (auto r = write_file(key_path, *key_pem, 0600, Overwrite::Replace); !r) return r;
  return write_file(cert_path, *cert_pem, 0644, Overwrite::Replace);
}

}  // namespace

std::string governance_xml(std::uint32_t domain_id) {
  const std::string d = std::to_string(domain_id);
  return R"(<?xml version="1.0" encoding="UTF-8"?>
<!-- Governance of a Rejuv graph across hosts (docs/across_hosts.md), written by `rejuv keys hosts`: only
     authenticated participants join; discovery, liveliness, every RTPS message and every topic's data and
     metadata are encrypted; reading and writing any topic needs a grant of the participant's permissions. -->
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains>
        <id>)" + d + R"(</id>
      </domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>ENCRYPT</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
)";
}

std::string permissions_xml(const HostGrant& host, std::uint32_t domain_id) {
  const auto now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  const auto topics = [](const std::vector<std::string>& names) {
    std::string out;
    for (const std::string& n : names) out += "            <topic>" + xml(n) + "</topic>\n";
    return out;
  };
  std::string out = R"(<?xml version="1.0" encoding="UTF-8"?>
<!-- Permissions of host ")" + xml(host.host) + R"(" (docs/across_hosts.md), written by `rejuv keys hosts` from the
     policy: it may publish the cross-host topics one of its services writes and subscribe to those one of its
     services reads; anything else is denied. -->
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name=")" + xml(host.host) + R"(">
      <subject_name>CN=)" + xml(host.host) + R"(</subject_name>
      <validity>
        <not_before>)" + utc(now - kBackdateS) + R"(</not_before>
        <not_after>)" + utc(now + kValidityS) + R"(</not_after>
      </validity>
)";
  if (!host.publish.empty() || !host.subscribe.empty()) {
    out += "      <allow_rule>\n        <domains>\n          <id>" + std::to_string(domain_id) + "</id>\n        </domains>\n";
    if (!host.publish.empty()) out += "        <publish>\n          <topics>\n" + topics(host.publish) + "          </topics>\n        </publish>\n";
    if (!host.subscribe.empty()) out += "        <subscribe>\n          <topics>\n" + topics(host.subscribe) + "          </topics>\n        </subscribe>\n";
    out += "      </allow_rule>\n";
  }
  out += "      <default>DENY</default>\n    </grant>\n  </permissions>\n</dds>\n";
  return out;
}

Result<void, std::string> init_keystore(const fs::path& dir) {
  if (fs::exists(dir) && !fs::is_directory(dir)) return fail(dir.string() + ": exists and is not a directory");
  for (const char* f : {"public/ca.cert.pem", "private/ca.key.pem"}) {
    if (fs::exists(dir / f)) {
      return fail((dir / f).string() + " exists already: " + dir.string() +
                  " holds a CA; refusing to overwrite it (every identity and document it signed would be orphaned)");
    }
  }
  if (auto r = make_dir(dir / "public", fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                            fs::perms::others_read | fs::perms::others_exec);
      !r) {
    return r;
  }
  if (auto r = make_dir(dir / "private", fs::perms::owner_all); !r) return r;
  if (auto r = make_dir(dir / "enclaves", fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                              fs::perms::others_read | fs::perms::others_exec);
      !r) {
    return r;
  }
  auto key = new_key();
  if (!key) return fail(key.error());
  auto cert = new_cert("rejuv_ca", key->get(), nullptr, key->get());
  if (!cert) return fail(cert.error());
  auto key_pem = pem_of(key->get());
  auto cert_pem = pem_of(cert->get());
  if (!key_pem || !cert_pem) return fail(!key_pem ? key_pem.error() : cert_pem.error());
  // The key first: a CA certificate without its key would block a second `init` and sign nothing.
  if (auto r = write_file(dir / "private" / "ca.key.pem", *key_pem, 0600, Overwrite::Refuse); !r) return r;
  if (auto r = write_file(dir / "public" / "ca.cert.pem", *cert_pem, 0644, Overwrite::Refuse); !r) return r;
  // SROS2's names for the two roles of the one CA.
  for (const auto& [folder, role, target] : {std::tuple{"public", "identity_ca.cert.pem", "ca.cert.pem"},
                                             std::tuple{"public", "permissions_ca.cert.pem", "ca.cert.pem"},
                                             std::tuple{"private", "identity_ca.key.pem", "ca.key.pem"},
                                             std::tuple{"private", "permissions_ca.key.pem", "ca.key.pem"}}) {
    std::error_code ec;
    fs::remove(dir / folder / role, ec);
    fs::create_symlink(target, dir / folder / role, ec);
    if (ec) return fail((dir / folder / role).string() + ": " + ec.message());
  }
  return {};
}

Result<void, std::string> write_enclaves(const fs::path& dir, const std::vector<HostGrant>& hosts,
                                         std::uint32_t domain_id) {
  auto ca = load_ca(dir);
  if (!ca) return fail(ca.error());
  auto ca_pem = pem_of(ca->cert.get());
  if (!ca_pem) return fail(ca_pem.error());
  const fs::path enclaves = dir / "enclaves";
  const auto open = fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec | fs::perms::others_read |
                    fs::perms::others_exec;
  if (auto r = make_dir(enclaves, open); !r) return r;
  const std::string governance = governance_xml(domain_id);
  auto governance_p7s = smime_sign(governance, ca->cert.get(), ca->key.get());
  if (!governance_p7s) return fail(governance_p7s.error());
  if (auto r = write_file(enclaves / "governance.xml", governance, 0644, Overwrite::Replace); !r) return r;
  if (auto r = write_file(enclaves / enclave_file::kGovernance, *governance_p7s, 0644, Overwrite::Replace); !r) return r;
  for (const HostGrant& h : hosts) {
    const fs::path e = enclaves / h.host;
    if (auto r = make_dir(e, open); !r) return r;
    if (auto r = ensure_identity(e, h.host, *ca); !r) return r;
    const std::string permissions = permissions_xml(h, domain_id);
    auto permissions_p7s = smime_sign(permissions, ca->cert.get(), ca->key.get());
    if (!permissions_p7s) return fail(permissions_p7s.error());
    for (const auto& [name, text] :
         {std::pair<std::string_view, const std::string*>{enclave_file::kIdentityCa, &*ca_pem},
          {enclave_file::kPermissionsCa, &*ca_pem},
          {enclave_file::kGovernance, &*governance_p7s},
          {"permissions.xml", &permissions},
          {enclave_file::kPermissions, &*permissions_p7s}}) {
      if (auto r = write_file(e / name, *text, 0644, Overwrite::Replace); !r) return r;
    }
  }
  return {};
}

Result<std::string, std::string> verify_signed(const fs::path& dir, const fs::path& p7s) {
  auto ca = load_cert(dir / "public" / "ca.cert.pem");
  if (!ca) return fail(ca.error());
  auto text = read_file(p7s);
  if (!text) return fail(text.error());
  Bio in(BIO_new_mem_buf(text->data(), static_cast<int>(text->size())));
  BIO* content_raw = nullptr;
  Pkcs7 p7(SMIME_read_PKCS7(in.get(), &content_raw));
  Bio content(content_raw);
  if (!p7) return fail(ssl_error(p7s.string() + ": not an S/MIME signed document"));
  Store store(X509_STORE_new());
  if (!store || X509_STORE_add_cert(store.get(), ca->get()) != 1) return fail(ssl_error("trust store"));
  Bio out(BIO_new(BIO_s_mem()));
  if (PKCS7_verify(p7.get(), nullptr, store.get(), content.get(), out.get(), PKCS7_TEXT) != 1) {
    return fail(ssl_error(p7s.string() + ": signature does not verify against " + (dir / "public" / "ca.cert.pem").string()));
  }
  auto signed_text = bio_text(out.get());
  if (!signed_text) return signed_text;
  // S/MIME text is signed in canonical form (CRLF line ends): give it back as the file was written.
  std::string lf;
  for (const char c : *signed_text) {
    if (c != '\r') lf += c;
  }
  return lf;
}

namespace {

// The text between <tag> and </tag> from `from` on; npos-safe.
std::string section(const std::string& text, const std::string& tag) {
  const std::string open = "<" + tag + ">", close = "</" + tag + ">";
  const auto a = text.find(open);
  if (a == std::string::npos) return {};
  const auto b = text.find(close, a);
  return b == std::string::npos ? std::string{} : text.substr(a + open.size(), b - a - open.size());
}

std::set<std::string> topics_in(const std::string& text) {
  std::set<std::string> out;
  for (std::size_t at = text.find("<topic>"); at != std::string::npos; at = text.find("<topic>", at + 1)) {
    const auto end = text.find("</topic>", at);
    if (end == std::string::npos) break;
    out.insert(text.substr(at + 7, end - at - 7));
  }
  return out;
}

std::string listed(const std::set<std::string>& s) {
  std::string out;
  for (const auto& t : s) out += (out.empty() ? "" : ", ") + t;
  return out.empty() ? "nothing" : out;
}

}  // namespace

Result<std::vector<std::string>, std::string> check_enclaves(const fs::path& dir, const std::vector<HostGrant>& hosts,
                                                            std::uint32_t domain_id) {
  auto ca = load_ca(dir);
  if (!ca) return fail(ca.error());
  std::vector<std::string> out;
  for (const HostGrant& h : hosts) {
    const fs::path e = enclave_dir(dir, h.host);
    const auto bad = [&](const std::string& what) { out.push_back("enclave " + h.host + ": " + what); };
    if (!fs::is_directory(e)) {
      bad("missing (rejuv keys hosts writes it)");
      continue;
    }
    auto cert = load_cert(e / enclave_file::kCert);
    auto key = load_key(e / enclave_file::kKey);
    if (!cert || !key) {
      bad(!cert ? cert.error() : key.error());
    } else {
      if (common_name(cert->get()) != h.host) bad("cert.pem is for CN=" + common_name(cert->get()) + ", not CN=" + h.host);
      if (X509_verify(cert->get(), X509_get0_pubkey(ca->cert.get())) != 1) bad("cert.pem was not issued by this keystore's CA");
      if (X509_check_private_key(cert->get(), key->get()) != 1) bad("key.pem is not the key of cert.pem");
      struct ::stat st {};
      if (::stat((e / enclave_file::kKey).c_str(), &st) == 0 && (st.st_mode & 077U) != 0) bad("key.pem is readable by group or others");
    }
    auto permissions = verify_signed(dir, e / enclave_file::kPermissions);
    if (!permissions) {
      bad(permissions.error());
    } else {
      const std::set<std::string> want_pub(h.publish.begin(), h.publish.end());
      const std::set<std::string> want_sub(h.subscribe.begin(), h.subscribe.end());
      const auto got_pub = topics_in(section(*permissions, "publish"));
      const auto got_sub = topics_in(section(*permissions, "subscribe"));
      if (got_pub != want_pub) bad("permissions grant publishing " + listed(got_pub) + "; the policy grants " + listed(want_pub));
      if (got_sub != want_sub) bad("permissions grant subscribing to " + listed(got_sub) + "; the policy grants " + listed(want_sub));
      if (section(*permissions, "subject_name") != "CN=" + h.host) bad("permissions are for " + section(*permissions, "subject_name"));
      if (section(*permissions, "default") != "DENY") bad("permissions do not deny by default");
      if ((!want_pub.empty() || !want_sub.empty()) && section(section(*permissions, "domains"), "id") != std::to_string(domain_id)) {
        bad("permissions are for domain " + section(section(*permissions, "domains"), "id") + ", not " + std::to_string(domain_id));
      }
    }
    auto governance = verify_signed(dir, e / enclave_file::kGovernance);
    if (!governance) {
      bad(governance.error());
    } else if (section(*governance, "allow_unauthenticated_participants") != "false") {
      bad("governance admits unauthenticated participants");
    }
  }
  return out;
}

}  // namespace rejuv::keys
