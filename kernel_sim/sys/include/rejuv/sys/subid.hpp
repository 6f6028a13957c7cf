// Subordinate ids (subuid(5), subgid(5)): the uids and gids a user without root may map into a user namespace
// of its own through the setuid helpers newuidmap(1) and newgidmap(1) (Debian's `uidmap`). A kernel without
// root runs each service as one of them (docs/sandbox.md "its own uid"), so that a service is never the
// kernel's uid: it can neither read the files of the kernel's user (a signing key of mode 0600) nor signal,
// trace or prlimit the kernel. The kernel, as the owner of each service's user namespace, keeps every
// capability over it (signals, ptrace-mode reads of /proc, priorities).
//
// Which ids: a block of kUidsPerBlock consecutive positions in the user's ranges (its uids and its gids,
// each counted through the user's ranges in file order), leased like the root path's blocks (lease.hpp), so
// that two kernels of one user never share an id. Service i gets position 256·b + i of both.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/result.hpp"
#include "rejuv/sys/fd.hpp"
#include "rejuv/sys/lease.hpp"

namespace rejuv::sys {

// first .. first + count - 1.
struct IdRange {
  std::uint32_t first = 0;
  std::uint32_t count = 0;
  [[nodiscard]] std::uint64_t end() const { return std::uint64_t{first} + count; }  // one past the last
  [[nodiscard]] bool overlaps(const IdRange& other) const {
    return first < other.end() && other.first < end();
  }
};

// One line of a subuid/subgid file: "OWNER:FIRST:COUNT", OWNER a login name or a decimal uid.
struct SubidEntry {
  std::string owner;
  IdRange range;
};
// A line the parser skipped — as newuidmap ignores it — with its number (from 1) and what was expected.
struct SkippedLine {
  std::size_t line = 0;
  std::string reason;
};
struct SubidFile {
  std::vector<SubidEntry> entries;   // in file order
  std::vector<SkippedLine> skipped;  // malformed lines (empty lines and # comments are not listed)
};

// Parses the text of /etc/subuid or /etc/subgid. FIRST and COUNT are decimal; COUNT ≥ 1; the range must end
// at or below 2^32 (ids are 32-bit). Never fails: what cannot be read is listed in `skipped`.
[[nodiscard]] SubidFile parse_subid_file(std::string_view text);

// The ranges of the user `name` with uid `uid`, in file order: entries whose owner is the name, or the uid in
// decimal (newuidmap matches both).
[[nodiscard]] std::vector<IdRange> ranges_of(const SubidFile& file, std::string_view name, uid_t uid);

// The n-th id counting through `ranges` in order; nullopt past their end.
[[nodiscard]] std::optional<std::uint32_t> nth_id(std::span<const IdRange> ranges, std::uint64_t n);

// A range of `count` ids, aligned to `count`, from `from` on, that overlaps no entry of `files` and none of the
// root path's service uid blocks (lease.hpp): what the refusal suggests to add.
[[nodiscard]] IdRange free_range(std::span<const SubidFile> files, std::uint32_t count = 65536,
                                 std::uint32_t from = 6 * 65536);

// Where the ids and the helpers are (the defaults: the system's).
struct SubidSources {
  std::string subuid = "/etc/subuid";
  std::string subgid = "/etc/subgid";
  std::string newuidmap = "/usr/bin/newuidmap";
  std::string newgidmap = "/usr/bin/newgidmap";
};

// Why a kernel without root cannot have subordinate ids for its services. The message says what to do.
struct SubidError {
  enum class Kind : std::uint8_t {
    NoUser,     // the kernel's uid has no passwd entry (no name to look up)
    NoHelper,   // newuidmap or newgidmap is missing or not executable
    NoRange,    // no subordinate uids or gids for the user (or fewer than one block)
    Busy,       // every block of the user's ranges is held by another kernel
    System,     // a file could not be read, a lock file could not be opened
  };
  Kind kind = Kind::System;
  std::string message;
  [[nodiscard]] const std::string& to_string() const { return message; }
};

// The ids one service runs as, outside its user namespace (inside, it has the same numbers: the map is the
// identity on them).
struct MappedIds {
  uid_t uid = 0;
  gid_t gid = 0;
};

// A block of the user's subordinate ids, held until destroyed (or the process ends). Move-only.
class SubordinateBlock {
 public:
  // Reads the files and leases a block for the user `uid`, searching from `hint` (e.g. the pid).
  [[nodiscard]] static Result<SubordinateBlock, SubidError> lease(uid_t uid, std::uint32_t hint,
                                                                  const SubidSources& sources = {});
  // The ids of service `index` (< kUidsPerBlock).
  [[nodiscard]] MappedIds ids_of(std::uint32_t index) const;
  [[nodiscard]] std::uint32_t block() const { return lease_.slot(); }
  [[nodiscard]] const SubidSources& sources() const { return sources_; }

 private:
  SubordinateBlock(Lease lease, std::vector<IdRange> uids, std::vector<IdRange> gids, SubidSources sources)
      : lease_(std::move(lease)), uids_(std::move(uids)), gids_(std::move(gids)), sources_(std::move(sources)) {}
  Lease lease_;
  std::vector<IdRange> uids_;
  std::vector<IdRange> gids_;
  SubidSources sources_;
};

// The lock file of a user's blocks (one per user: another user's ranges are disjoint from this one's).
[[nodiscard]] std::string subordinate_block_lock_file(uid_t uid);

// Writes the uid and gid maps of `pid`'s user namespace — `ids.uid` and `ids.gid` mapped to themselves, one
// id each — by running newuidmap and newgidmap (fork + exec of `sources`' paths, explicit arguments, an empty
// environment). The process must be of this uid, in a user namespace it made and has no map yet. The error
// carries what the helper wrote to stderr.
[[nodiscard]] SysResult<void> write_id_maps(pid_t pid, const MappedIds& ids, const SubidSources& sources);

}  // namespace rejuv::sys
