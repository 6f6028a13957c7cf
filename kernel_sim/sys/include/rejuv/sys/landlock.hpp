// Landlock (Linux 5.13+; ABI 6 in 6.12+): what a service may open while it boots, enforced by the kernel on the
// object opened, not on a path string the caller could change (no TOCTOU), for any executable a graph names.
//
// Seccomp cannot read an open's path (it is in memory), and a path read by the kernel could be changed after
// the read; without this a booting binary could read /proc/<kernel>/cmdline, the launch file it names and the
// MAVLink signing key that names. The kernel's spawn restricts every service process, between fork and exec,
// to a ruleset that grants only what the dynamic loader and the SDK's start-up read:
//   - the system's library folders and the loader's cache (read, execute): /lib, /lib64, /usr/lib, /usr/lib64,
//     /usr/local/lib, /etc/ld.so.cache;
//   - the service's own binary (read, execute);
//   - its own /proc/<pid> (read): /proc/self/maps and /proc/self/exe, which the SDK reads once at boot.
// Every other file-system access right Landlock knows (per the running kernel's ABI) is handled and so refused:
// no write, no create, no read of anything else (/proc of another process, the launch file, the key, /etc).
// With ABI ≥ 4 TCP bind and connect are refused too (there is no network in the namespace anyway), and with
// ABI ≥ 6 the domain is scoped: no signal to a process outside it (the kernel, another service, a process of
// the user), SIGIO included, and no abstract Unix socket outside it. Images and strays, forked from the
// service, inherit the domain; each service is a domain of its own.
//
// A memfd reopened through /proc/self/fd/N is not on a path Landlock governs: the time page is protected by
// its seals instead (sys::seal_against_writes).
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

// What one rule grants beneath its path.
enum class LandlockGrant : std::uint8_t {
  ReadExecute,  // read and execute files, list folders (libraries, the binary)
  Read,         // read files, list folders (the service's own /proc/<pid>)
};

struct LandlockRule {
  std::string path;  // absolute; "/proc/self" is resolved in the child (its own /proc/<pid>)
  LandlockGrant grant = LandlockGrant::Read;
};

// The ruleset of a service whose binary is `executable`, in the order the child applies it.
[[nodiscard]] std::vector<LandlockRule> service_landlock_rules(const std::string& executable);

// Whether `path`, as a boot call names it, lies within `rules` (lexically: absolute, no "." or ".." component,
// beneath a rule's path; "/proc/self" also as "/proc/<own_pid>"). The kernel's own look at an open while a
// service boots (kernel/src/warden.cpp): what it sees outside is refused and counted against the service;
// what it cannot see (the path changed after it read it, a symbolic link) Landlock still refuses, on the
// object. So the count is the kernel's and the enforcement Landlock's.
[[nodiscard]] bool path_within(const std::vector<LandlockRule>& rules, std::string_view path, pid_t own_pid);

// The NUL-terminated string at `address` in process `pid` (at most `max` bytes; process_vm_readv), e.g. the
// path a boot call names. The caller checks afterwards that the call still waits (the pid was not reused).
[[nodiscard]] SysResult<std::string> read_string_of(pid_t pid, std::uint64_t address, std::size_t max);

// The running kernel's Landlock ABI version (0: Landlock absent or disabled).
[[nodiscard]] int landlock_abi();

// In a freshly forked child (async-signal-safe: raw system calls on the prepared rules, no allocation):
// creates the ruleset for `abi`, adds each rule whose path it can open and, when `executable` is an fd (the
// binary the spawner opened, which the child may have no search right to reach by path), read and execute on
// it; sets no_new_privs and restricts the calling process. Returns 0 or an errno. `abi` 0 does nothing.
[[nodiscard]] int restrict_in_child(const std::vector<LandlockRule>& rules, int abi, int executable = -1) noexcept;

}  // namespace rejuv::sys
