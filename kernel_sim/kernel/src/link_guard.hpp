// The links to other hosts closed in the secure execution interval (the paper's §III, §IV-D; docs/across_hosts.md
// "Closing the link"): one sys::LinkClosure per host this kernel runs services for, made when the kernel is
// created, held by this owner alone: an nftables table when the host's uplink is in a network namespace of its
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
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/vocabulary.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/sys/link_closure.hpp"

namespace rejuv::kernel {

class LinkGuard {
 public:
  explicit LinkGuard(Kernel::Impl& kernel) : k(kernel) {}

  // A closure per host this kernel runs services for (a graph with hosts, SR on); each logged. A host whose link can be closed neither way is logged and stays open.
  void create();
  // Before the capability system enters `to` from `from`: every link closed if `to` is in the secure interval.
  void before_mode(SrMode from, SrMode to);
  // After it (`entered`: whether the mode changed): every link opened when MC was entered, or when the change
  // that closed them failed.
  void after_mode(SrMode from, SrMode to, bool entered);

 private:
  struct Link {
    std::string host;
    std::optional<ServiceId> frozen_service;  // the cgroup fallback: the link service frozen
    sys::LinkClosure closure;                 // empty until the fallback's first close
  };
  void set_all(sys::LinkState want, SrMode from, SrMode to);
  // The fallback where no table can be made (`why`, logged): the link services of `host` frozen through their
  // cgroups.
  void freeze_links_of(const std::string& host, const std::string& why);

  Kernel::Impl& k;
  std::vector<Link> links_;
  bool closed_for_change_ = false;  // before_mode closed them for the change in progress
};

}  // namespace rejuv::kernel
