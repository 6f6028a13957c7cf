#include "rejuv/sys/subid.hpp"

#include <fcntl.h>
#include <pwd.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <sstream>

namespace rejuv::sys {

namespace {

std::optional<std::uint32_t> decimal(std::string_view text) {
  std::uint32_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value, 10);
  if (ec != std::errc{} || end != text.data() + text.size() || text.empty()) return std::nullopt;
  return value;
}

// The file's text; nullopt with errno set when it cannot be read (a missing file is an empty one: no ranges).
std::optional<std::string> read_text(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    if (errno == ENOENT) return std::string();
    return std::nullopt;
  }
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

SubidFile parse_subid_file(std::string_view text) {
  SubidFile out;
  std::size_t number = 0;
  while (!text.empty()) {
    ++number;
    const std::size_t nl = text.find('\n');
    const std::string_view line = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view{} : text.substr(nl + 1);
    if (line.empty() || line.front() == '#') continue;
    const auto skip = [&](std::string reason) { out.skipped.push_back({number, std::move(reason)}); };
    const std::size_t c1 = line.find(':');
    const std::size_t c2 = c1 == std::string_view::npos ? c1 : line.find(':', c1 + 1);
    if (c2 == std::string_view::npos || line.find(':', c2 + 1) != std::string_view::npos) {
      skip("expected OWNER:FIRST:COUNT (three fields)");
      continue;
    }
    const std::string_view owner = line.substr(0, c1);
    const auto first = decimal(line.substr(c1 + 1, c2 - c1 - 1));
    const auto count = decimal(line.substr(c2 + 1));
    if (owner.empty()) {
      skip("expected an owner (a login name or a uid) before the first ':'");
    } else if (!first) {
      skip("expected FIRST, a decimal id below 2^32");
    } else if (!count || *count == 0) {
      skip("expected COUNT, a decimal number of ids, at least 1");
    } else if (std::uint64_t{*first} + *count > (std::uint64_t{1} << 32U)) {
      skip("the range ends above 2^32 (ids are 32-bit)");
    } else {
      out.entries.push_back({std::string(owner), IdRange{*first, *count}});
    }
  }
  return out;
}

std::vector<IdRange> ranges_of(const SubidFile& file, std::string_view name, uid_t uid) {
  const std::string uid_text = std::to_string(uid);
  std::vector<IdRange> out;
  for (const SubidEntry& e : file.entries) {
    if ((!name.empty() && e.owner == name) || e.owner == uid_text) out.push_back(e.range);
  }
  return out;
}

std::optional<std::uint32_t> nth_id(std::span<const IdRange> ranges, std::uint64_t n) {
  for (const IdRange& r : ranges) {
    if (n < r.count) return static_cast<std::uint32_t>(r.first + n);
    n -= r.count;
  }
  return std::nullopt;
}

IdRange free_range(std::span<const SubidFile> files, std::uint32_t count, std::uint32_t from) {
  const IdRange root_blocks{kServiceUidBase, kUidBlocks * kUidsPerBlock};
  for (std::uint64_t first = from; first + count <= std::uint64_t{1} << 32U; first += count) {
    const IdRange candidate{static_cast<std::uint32_t>(first), count};
    bool taken = candidate.overlaps(root_blocks);
    for (const SubidFile& f : files) {
      for (const SubidEntry& e : f.entries) taken = taken || candidate.overlaps(e.range);
    }
    if (!taken) return candidate;
  }
  return IdRange{from, count};  // every aligned range is taken: a suggestion still
}

std::string subordinate_block_lock_file(uid_t uid) {
  return "/tmp/rejuv-subordinate-ids-" + std::to_string(uid) + ".lock";
}

Result<SubordinateBlock, SubidError> SubordinateBlock::lease(uid_t uid, std::uint32_t hint,
                                                             const SubidSources& sources) {
  using K = SubidError::Kind;
  const auto fail = [](K kind, std::string message) {
    return std::unexpected(SubidError{.kind = kind, .message = std::move(message)});
  };
  // The name newuidmap looks the user up by (getpwuid: the kernel's real uid).
  std::array<char, 4096> buffer{};
  passwd entry{};
  passwd* found = nullptr;
  if (::getpwuid_r(uid, &entry, buffer.data(), buffer.size(), &found) != 0 || found == nullptr) {
    return fail(K::NoUser, "uid " + std::to_string(uid) +
                               " has no passwd entry, so it has no subordinate ids (subuid(5)): each service runs as "
                               "a uid of its own from the user's range (docs/sandbox.md)");
  }
  const std::string name = found->pw_name;
  for (const std::string* helper : {&sources.newuidmap, &sources.newgidmap}) {
    if (::access(helper->c_str(), X_OK) != 0) {
      return fail(K::NoHelper, *helper + " is missing (" + std::strerror(errno) +
                                   "): without root each service runs as a subordinate uid of its own, mapped by "
                                   "newuidmap and newgidmap; install them as root: apt-get install uidmap (or run "
                                   "with --insecure-sandbox, which runs every service as your uid)");
    }
  }
  std::array<SubidFile, 2> files;
  std::array<std::vector<IdRange>, 2> mine;
  const std::array<const std::string*, 2> paths{&sources.subuid, &sources.subgid};
  for (std::size_t i = 0; i < 2; ++i) {
    const auto text = read_text(*paths[i]);
    if (!text) return fail(K::System, "cannot read " + *paths[i] + ": " + std::strerror(errno));
    files[i] = parse_subid_file(*text);
    mine[i] = ranges_of(files[i], name, uid);
  }
  const auto total = [](const std::vector<IdRange>& ranges) {
    std::uint64_t n = 0;
    for (const IdRange& r : ranges) n += r.count;
    return n;
  };
  const std::uint64_t blocks = std::min(total(mine[0]), total(mine[1])) / kUidsPerBlock;
  if (blocks == 0) {
    const IdRange r = free_range(files);
    const std::string range = std::to_string(r.first) + "-" + std::to_string(r.end() - 1);
    std::string message = "user '" + name + "' (uid " + std::to_string(uid) + ") has " +
                          (mine[0].empty() ? "no subordinate uids in " + sources.subuid
                           : mine[1].empty() ? "no subordinate gids in " + sources.subgid
                                             : "fewer than " + std::to_string(kUidsPerBlock) +
                                                   " subordinate uids or gids") +
                          ": without root each service runs as a uid of its own from that range (docs/sandbox.md). "
                          "Add one as root:  usermod --add-subuids " + range + " --add-subgids " + range + " " +
                          name + "  (or run with --insecure-sandbox, which runs every service as your uid)";
    for (std::size_t i = 0; i < 2; ++i) {
      for (const SkippedLine& s : files[i].skipped) {
        message += "; " + *paths[i] + ":" + std::to_string(s.line) + ": skipped: " + s.reason;
      }
    }
    return fail(K::NoRange, std::move(message));
  }
  const std::string lock = subordinate_block_lock_file(uid);
  auto lease = lease_slot(lock.c_str(), 0, static_cast<std::uint32_t>(std::min<std::uint64_t>(blocks, 1U << 24U)),
                          hint);
  if (!lease) {
    if (lease.error().error == EBUSY) {
      return fail(K::Busy, "every block of " + std::to_string(kUidsPerBlock) + " subordinate ids of user '" + name +
                               "' is held by another kernel (" + lock + ")");
    }
    return fail(K::System, "a block of subordinate ids: " + lease.error().to_string());
  }
  return SubordinateBlock(std::move(*lease), std::move(mine[0]), std::move(mine[1]), sources);
}

MappedIds SubordinateBlock::ids_of(std::uint32_t index) const {
  REJUV_ASSERT(index < kUidsPerBlock, "a service index beyond a block");
  const std::uint64_t n = std::uint64_t{lease_.slot()} * kUidsPerBlock + index;
  const auto uid = nth_id(uids_, n);
  const auto gid = nth_id(gids_, n);
  REJUV_ASSERT(uid && gid, "lease() leases only blocks that both ranges cover");
  return MappedIds{.uid = *uid, .gid = *gid};
}

namespace {

// Runs one helper with explicit arguments and an empty environment; its stdout and stderr come back in the
// error when it fails.
SysResult<void> run_helper(std::string_view call, const std::string& path, std::vector<std::string> args) {
  std::array<int, 2> pipe_fds{-1, -1};
  if (::pipe2(pipe_fds.data(), O_CLOEXEC) != 0) return last_error("pipe2(id map helper)");
  UniqueFd read_end(pipe_fds[0]);
  UniqueFd write_end(pipe_fds[1]);
  posix_spawn_file_actions_t actions;
  posix_spawnattr_t attr;
  ::posix_spawn_file_actions_init(&actions);
  ::posix_spawnattr_init(&attr);
  ::posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  ::posix_spawn_file_actions_adddup2(&actions, write_end.get(), 1);
  ::posix_spawn_file_actions_adddup2(&actions, write_end.get(), 2);
  ::posix_spawn_file_actions_addclosefrom_np(&actions, 3);
  // The kernel blocks signals it reads from a signalfd: the helper starts with none blocked, all at default.
  sigset_t none;
  sigset_t all;
  sigemptyset(&none);
  sigfillset(&all);
  ::posix_spawnattr_setsigmask(&attr, &none);
  ::posix_spawnattr_setsigdefault(&attr, &all);
  ::posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  std::vector<char*> argv;
  args.insert(args.begin(), path);
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::array<char*, 1> envp{nullptr};
  pid_t helper = -1;
  const int rc = ::posix_spawn(&helper, path.c_str(), &actions, &attr, argv.data(), envp.data());
  ::posix_spawn_file_actions_destroy(&actions);
  ::posix_spawnattr_destroy(&attr);
  if (rc != 0) return std::unexpected(SysError{call, rc, "could not run " + path});
  write_end.reset();
  std::string said;
  std::array<char, 512> chunk{};
  for (;;) {
    const ssize_t n = ::read(read_end.get(), chunk.data(), chunk.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    if (said.size() < 4096) said.append(chunk.data(), static_cast<std::size_t>(n));
  }
  int status = 0;
  while (::waitpid(helper, &status, 0) < 0) {
    if (errno != EINTR) return last_error("waitpid(id map helper)");
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return {};
  while (!said.empty() && (said.back() == '\n' || said.back() == ' ')) said.pop_back();
  std::string command;
  for (const std::string& a : args) command += (command.empty() ? "" : " ") + a;
  const std::string how = WIFEXITED(status) ? "exited with " + std::to_string(WEXITSTATUS(status))
                                            : "killed by signal " + std::to_string(WTERMSIG(status));
  return std::unexpected(SysError{call, 0, "`" + command + "` " + how + (said.empty() ? "" : ": " + said)});
}

}  // namespace

SysResult<void> write_id_maps(pid_t pid, const MappedIds& ids, const SubidSources& sources) {
  const std::string target = std::to_string(pid);
  if (auto ok = run_helper("newuidmap", sources.newuidmap,
                           {target, std::to_string(ids.uid), std::to_string(ids.uid), "1"});
      !ok) {
    return ok;
  }
  return run_helper("newgidmap", sources.newgidmap, {target, std::to_string(ids.gid), std::to_string(ids.gid), "1"});
}

}  // namespace rejuv::sys
