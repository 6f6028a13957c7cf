// A process of the kernel's own that opens /proc/<pid>/pagemap of one service's processes from inside that
// service's user namespace (docs/sandbox.md "Without root"). Images by written pages need each incarnation's
// pagemap (docs/protocol.md "Checkpoint and rollback"). A kernel with root opens it itself
// (open_pagemap_without_frames). A kernel without root cannot: the file is mode 0400 and owned by the
// service's subordinate uid, and reading it past that needs CAP_DAC_READ_SEARCH where that uid is mapped —
// in the service's user namespace, which the kernel's uid owns. The agent is forked from the kernel, enters
// that namespace (setns, with every capability there and none outside it) and answers each request with
// the fd. It never holds CAP_SYS_ADMIN in the initial namespace, so its pagemaps show no physical frames.
//
// The service must be dumpable (sdk boot.cpp, wire::kKeepDumpableEnv): a non-dumpable process whose
// binary's owner is not mapped in its namespace is readable only with CAP_SYS_PTRACE in the initial one.
#pragma once

#include <sys/types.h>

#include <cstdint>

#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/fd.hpp"
#include "rejuv/sys/process.hpp"

namespace rejuv::sys {

class PagemapAgent {
 public:
  PagemapAgent() = default;
  // An agent in the user namespace of `member` (a process of the service). Fails where the kernel may not
  // enter it (not its owner, or the kernel has root and no need).
  [[nodiscard]] static SysResult<PagemapAgent> start(pid_t member);
  PagemapAgent(PagemapAgent&&) noexcept = default;
  PagemapAgent& operator=(PagemapAgent&&) noexcept = default;
  PagemapAgent(const PagemapAgent&) = delete;
  PagemapAgent& operator=(const PagemapAgent&) = delete;
  // Closing the socket ends the agent; ChildProcess kills and reaps whatever is left.
  ~PagemapAgent() = default;

  [[nodiscard]] bool valid() const { return socket_.valid() && process_.running(); }
  [[nodiscard]] pid_t pid() const { return process_.pid(); }
  // Whether `member` lives in the namespace this agent entered (a cold restart makes a new one).
  [[nodiscard]] bool serves(pid_t member) const;
  // /proc/<pid>/pagemap of a process in the agent's namespace, read-only. Waits at most a second for the
  // answer (the agent only opens a file).
  [[nodiscard]] SysResult<UniqueFd> open_pagemap(pid_t pid) const;

 private:
  PagemapAgent(SeqPacket socket, ChildProcess process, std::uint64_t ns)
      : socket_(std::move(socket)), process_(std::move(process)), namespace_(ns) {}
  SeqPacket socket_;
  ChildProcess process_;
  std::uint64_t namespace_ = 0;  // the inode of the user namespace it entered
};

}  // namespace rejuv::sys
