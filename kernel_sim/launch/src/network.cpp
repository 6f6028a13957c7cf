// The launch file's network block: the signing key of the kernel's network gate (docs/mavlink.md "Signing").
#include <sys/stat.h>

#include <cctype>
#include <fstream>
#include <sstream>

#include "rejuv/launch/launch.hpp"

namespace rejuv::launch {

Result<std::optional<mavlink::SigningKey>, KeyError> signing_key(const proto::NetworkSpec& network,
                                                                const std::filesystem::path& launch_path) {
  if (!network.signing_key().empty() && !network.signing_key_file().empty()) {
    return fail(KeyError{.field = "signing_key_file", .message = "give `signing_key` or `signing_key_file`, not both"});
  }
  if (!network.signing_key().empty()) {
    auto key = mavlink::SigningKey::from_hex(network.signing_key());
    if (!key) return fail(KeyError{.field = "signing_key", .message = "`network.signing_key`: " + key.error()});
    return std::optional<mavlink::SigningKey>(*key);
  }
  if (network.signing_key_file().empty()) return std::optional<mavlink::SigningKey>{};
  std::filesystem::path file = network.signing_key_file();
  if (file.is_relative()) file = launch_path.parent_path() / file;
  const auto bad = [&](const std::string& why) {
    return fail(KeyError{.field = "signing_key_file", .message = "`network.signing_key_file` " + file.string() + ": " + why});
  };
  // The key is a secret: a file others may read is refused (as ssh refuses a private key that is).
  struct ::stat st {};
  if (::stat(file.c_str(), &st) != 0) return bad("cannot be read");
  if (!S_ISREG(st.st_mode)) return bad("not a regular file");
  if ((st.st_mode & (S_IRWXG | S_IRWXO)) != 0) return bad("readable or writable by group or others (chmod 600 it)");
  std::ifstream in(file);
  if (!in) return bad("cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  std::string hex = text.str();
  while (!hex.empty() && std::isspace(static_cast<unsigned char>(hex.back())) != 0) hex.pop_back();
  std::size_t first = 0;
  while (first < hex.size() && std::isspace(static_cast<unsigned char>(hex[first])) != 0) ++first;
  auto key = mavlink::SigningKey::from_hex(std::string_view(hex).substr(first));
  if (!key) return bad(key.error());
  return std::optional<mavlink::SigningKey>(*key);
}

std::optional<HostPort> ground_address(std::string_view text) {
  const auto colon = text.rfind(':');
  if (colon == std::string_view::npos) return std::nullopt;
  const std::string_view ip = text.substr(0, colon);
  const std::string_view port = text.substr(colon + 1);
  // Four decimal octets 0 … 255.
  int octets = 0;
  std::size_t i = 0;
  while (i <= ip.size()) {
    std::size_t j = i;
    unsigned value = 0;
    while (j < ip.size() && ip[j] >= '0' && ip[j] <= '9' && j - i < 3) value = value * 10 + static_cast<unsigned>(ip[j++] - '0');
    if (j == i || value > 255) return std::nullopt;
    ++octets;
    if (j == ip.size()) break;
    if (ip[j] != '.') return std::nullopt;
    i = j + 1;
  }
  if (octets != 4) return std::nullopt;
  if (port.empty() || port.size() > 5) return std::nullopt;
  unsigned p = 0;
  for (const char c : port) {
    if (c < '0' || c > '9') return std::nullopt;
    p = p * 10 + static_cast<unsigned>(c - '0');
  }
  if (p == 0 || p > 65535) return std::nullopt;
  return HostPort{.ip = std::string(ip), .port = static_cast<std::uint16_t>(p)};
}

}  // namespace rejuv::launch
