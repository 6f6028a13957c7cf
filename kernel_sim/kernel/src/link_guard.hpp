// The links to other hosts closed in the secure execution interval (the paper's §III, §IV-D; docs/across_hosts.md
// "Closing the link"): one sys::LinkClosure per host this kernel runs services for (link_hosts), made when the
// kernel is created, held by this owner alone: an nftables table when the host's uplink is in a network namespace of its
// own (launch.proto Host.netns), else the host's link services frozen (below).
//
// At MC → RB (any mode of the secure interval entered from MC) every link is closed BEFORE the capability system
// revokes the link services' rights, so nothing crosses while the rights change; at CP → MC (MC entered) every
// link is opened AFTER the rights are back. A failed mode change undoes a close it made. Each close and open is
// logged with its mode change and its duration ("link vehicle closed at MC → RB (12 µs): …"), so that a test can
// check them against the mode trace (Observer::on_log beside on_sr_event).
//
// Where no table can be made — without CAP_NET_ADMIN, or for a host whose uplink is in the kernel's own namespace
// (a table over all of its interfaces would cut the ground station and the shell too) — the cgroups of that
// host's link services are frozen instead (cgroup.freeze, v2), and the kernel log says so — from the first
// MC → secure mode on: a link frozen through the kernel's start in SC and the plant's alignment (20 s) would not
// read its channel, which fills, and the kernel would kill it. It holds no right outside MC meanwhile.
// The guard knows the kernel only through what it is handed: the hosts (LinkHost), a log, and where a link
// service's cgroup is (LinkCgroup); it is built and tested alone (tests/unit/kernel/link_guard_test.cpp).
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/sys/link_closure.hpp"

namespace rejuv::kernel {

// A service that carries a host's link (rejuv_host_link): frozen where no table can be made.
struct LinkService {
  ServiceId id;
  std::string name;
};

// A host this kernel runs services for, as the guard closes its link.
struct LinkHost {
  std::string name;
  std::string netns;                        // its uplink's namespace; empty: the kernel's own (frozen, not a table)
  std::vector<LinkService> link_services;  // this kernel's link services on it
};

// A link service's cgroup when the guard would freeze it: not started yet (nothing to freeze; it is frozen from
// the next close after its start), its cgroup v2 directory, or why it has none.
struct LinkCgroup {
  bool started = false;
  std::optional<std::filesystem::path> dir;
  std::string note;  // why there is no directory
};

class LinkGuard {
 public:
  using Log = std::function<void(const std::string&)>;
  using CgroupOf = std::function<LinkCgroup(ServiceId)>;
  LinkGuard(Log log, CgroupOf cgroup_of) : log_(std::move(log)), cgroup_of_(std::move(cgroup_of)) {}

  // A closure per host of `hosts`; each logged. A host whose link can be closed neither way is logged and stays
  // open. A kernel that starts inside the secure interval (`mode`) starts with its links closed.
  void create(std::span<const LinkHost> hosts, SrMode mode);
  // Before the capability system enters `to` from `from`: every link closed if `to` is in the secure interval.
  void before_mode(SrMode from, SrMode to);
  // After it (`entered`: whether the mode changed): every link opened when MC was entered, or when the change
  // that closed them failed.
  void after_mode(SrMode from, SrMode to, bool entered);

 private:
  struct Link {
    std::string host;
    std::optional<LinkService> frozen_service;  // the fallback: the link service frozen
    sys::LinkClosure closure;                   // empty until the fallback's first close
  };
  void set_all(sys::LinkState want, SrMode from, SrMode to);
  // The fallback where no table can be made (`why`, logged): the link services of `host` frozen through their
  // cgroups.
  void freeze_links_of(const LinkHost& host, const std::string& why);
  void say(const char* format, ...) __attribute__((format(printf, 2, 3)));

  Log log_;
  CgroupOf cgroup_of_;
  std::vector<Link> links_;
  bool closed_for_change_ = false;  // before_mode closed them for the change in progress
};

// The hosts of this kernel's part of the graph whose links the guard closes, with their link services: none
// without SR (the mode never leaves MC) or without hosts.
[[nodiscard]] std::vector<LinkHost> link_hosts(const Kernel::Impl& k);
// The kernel's log and where its services' cgroups are, as the guard is handed them.
[[nodiscard]] LinkGuard::Log kernel_log(Kernel::Impl& k);
[[nodiscard]] LinkGuard::CgroupOf kernel_cgroups(const Kernel::Impl& k);

}  // namespace rejuv::kernel
