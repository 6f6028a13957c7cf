#include "rejuv/sys/landlock.hpp"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

namespace rejuv::sys {

namespace {

// <linux/landlock.h> of Debian 12 stops at ABI 2: the numbers and layouts of the kernel's UAPI, spelled here.
constexpr long kSysCreateRuleset = 444;  // landlock_create_ruleset
constexpr long kSysAddRule = 445;        // landlock_add_rule
constexpr long kSysRestrictSelf = 446;   // landlock_restrict_self
constexpr std::uint32_t kCreateRulesetVersion = 1U << 0U;
constexpr int kRulePathBeneath = 1;

constexpr std::uint64_t kExecute = 1ULL << 0U;
constexpr std::uint64_t kReadFile = 1ULL << 2U;
constexpr std::uint64_t kReadDir = 1ULL << 3U;
// The file-system rights each ABI knows: 13 in ABI 1 (bits 0–12), REFER (13) in 2, TRUNCATE (14) in 3,
// IOCTL_DEV (15) in 5.
constexpr std::uint64_t fs_rights(int abi) {
  if (abi >= 5) return (1ULL << 16U) - 1;
  if (abi >= 3) return (1ULL << 15U) - 1;
  if (abi >= 2) return (1ULL << 14U) - 1;
  return (1ULL << 13U) - 1;
}
constexpr std::uint64_t kNetBindTcp = 1ULL << 0U;     // ABI 4
constexpr std::uint64_t kNetConnectTcp = 1ULL << 1U;  // ABI 4
constexpr std::uint64_t kScopeAbstractUnixSocket = 1ULL << 0U;  // ABI 6
constexpr std::uint64_t kScopeSignal = 1ULL << 1U;              // ABI 6

struct RulesetAttr {
  std::uint64_t handled_access_fs;
  std::uint64_t handled_access_net;
  std::uint64_t scoped;
};
struct __attribute__((packed)) PathBeneathAttr {
  std::uint64_t allowed_access;
  std::int32_t parent_fd;
};

// The size of the ruleset attribute the ABI reads: fs only (1–3), + net (4–5), + scoped (6+).
constexpr std::size_t attr_size(int abi) {
  if (abi >= 6) return sizeof(RulesetAttr);
  if (abi >= 4) return 2 * sizeof(std::uint64_t);
  return sizeof(std::uint64_t);
}

}  // namespace

std::vector<LandlockRule> service_landlock_rules(const std::string& executable) {
  std::vector<LandlockRule> rules;
  for (const char* dir : {"/lib", "/lib64", "/usr/lib", "/usr/lib64", "/usr/local/lib", "/etc/ld.so.cache"}) {
    rules.push_back(LandlockRule{.path = dir, .grant = LandlockGrant::ReadExecute});
  }
  rules.push_back(LandlockRule{.path = executable, .grant = LandlockGrant::ReadExecute});
  rules.push_back(LandlockRule{.path = "/proc/self", .grant = LandlockGrant::Read});
  return rules;
}

bool path_within(const std::vector<LandlockRule>& rules, std::string_view path, pid_t own_pid) {
  if (!path.starts_with('/')) return false;
  for (std::size_t at = 1; at <= path.size();) {  // no "." or ".." component: the comparison is lexical
    const std::size_t end = std::min(path.find('/', at), path.size());
    const std::string_view part = path.substr(at, end - at);
    if (part == "." || part == "..") return false;
    at = end + 1;
  }
  const std::string own_proc = "/proc/" + std::to_string(own_pid);
  const auto beneath = [&](std::string_view root) {
    return path == root || (path.starts_with(root) && path[root.size()] == '/');
  };
  for (const LandlockRule& rule : rules) {
    if (beneath(rule.path)) return true;
    if (rule.path == "/proc/self" && own_pid > 0 && beneath(own_proc)) return true;
  }
  return false;
}

SysResult<std::string> read_string_of(pid_t pid, std::uint64_t address, std::size_t max) {
  std::string out(max, '\0');
  // Page by page: a string near the end of a mapping must not fail for the bytes past it.
  std::size_t got = 0;
  while (got < max) {
    const std::uint64_t at = address + got;
    const std::size_t to_page_end = 4096 - static_cast<std::size_t>(at % 4096);
    const std::size_t want = std::min(max - got, to_page_end);
    iovec local{out.data() + got, want};
    iovec remote{reinterpret_cast<void*>(at), want};  // NOLINT: an address in the other process
    const ssize_t n = ::process_vm_readv(pid, &local, 1, &remote, 1, 0);
    if (n <= 0) {
      if (got == 0) return last_error("process_vm_readv");
      break;
    }
    const auto nul = out.find('\0', got);
    got += static_cast<std::size_t>(n);
    if (nul != std::string::npos && nul < got) {
      out.resize(nul);
      return out;
    }
  }
  return std::unexpected(SysError{"process_vm_readv (no NUL within the bound)", ENAMETOOLONG});
}

int landlock_abi() {
  const long abi = ::syscall(kSysCreateRuleset, nullptr, 0, kCreateRulesetVersion);
  return abi < 0 ? 0 : static_cast<int>(abi);
}

int restrict_in_child(const std::vector<LandlockRule>& rules, int abi, int executable) noexcept {
  if (abi <= 0) return 0;
  const std::uint64_t handled = fs_rights(abi);
  RulesetAttr attr{.handled_access_fs = handled,
                   .handled_access_net = abi >= 4 ? (kNetBindTcp | kNetConnectTcp) : 0,
                   .scoped = abi >= 6 ? (kScopeAbstractUnixSocket | kScopeSignal) : 0};
  const long ruleset = ::syscall(kSysCreateRuleset, &attr, attr_size(abi), 0U);
  if (ruleset < 0) return errno;
  int err = 0;
  for (const LandlockRule& rule : rules) {
    const int fd = ::open(rule.path.c_str(), O_PATH | O_CLOEXEC);
    if (fd < 0) continue;  // a folder this system does not have (/lib64, /usr/lib64 …)
    struct stat st {};
    const bool folder = ::fstat(fd, &st) == 0 && S_ISDIR(st.st_mode);
    std::uint64_t allowed = kReadFile | (rule.grant == LandlockGrant::ReadExecute ? kExecute : 0);
    if (folder) allowed |= kReadDir;  // a rule on a file may name only rights that apply to files
    PathBeneathAttr beneath{.allowed_access = allowed & handled, .parent_fd = fd};
    if (::syscall(kSysAddRule, ruleset, kRulePathBeneath, &beneath, 0U) != 0) err = errno;
    ::close(fd);
    if (err != 0) break;
  }
  if (err == 0 && executable >= 0) {
    PathBeneathAttr beneath{.allowed_access = (kReadFile | kExecute) & handled, .parent_fd = executable};
    if (::syscall(kSysAddRule, ruleset, kRulePathBeneath, &beneath, 0U) != 0) err = errno;
  }
  if (err == 0 && ::prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0) err = errno;
  if (err == 0 && ::syscall(kSysRestrictSelf, ruleset, 0U) != 0) err = errno;
  ::close(static_cast<int>(ruleset));
  return err;
}

}  // namespace rejuv::sys
