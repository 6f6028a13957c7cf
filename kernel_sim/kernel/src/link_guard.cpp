// The links to other hosts closed in the secure interval (link_guard.hpp).
#include "link_guard.hpp"

#include <cerrno>
#include <chrono>
#include <set>

#include "impl.hpp"
#include "rejuv/policy/hosts.hpp"

namespace rejuv::kernel {

namespace {

// "MC → RB", or "the start in SC" (create: the kernel starts inside the secure interval).
std::string transition(SrMode from, SrMode to) {
  if (from == to) return "the start in " + std::string(to_string(to));
  return std::string(to_string(from)) + " → " + std::string(to_string(to));
}

}  // namespace

void LinkGuard::create() {
  const proto::Launch& g = k.graph.graph;
  if (!k.sr || g.hosts_size() == 0) return;  // without SR the mode never leaves MC
  std::set<std::string> served;  // the hosts this kernel runs services for
  for (const ServiceRuntime& s : k.services) {
    if (!s.config.skip && s.config.spec != nullptr) served.emplace(launch::host_of(g, *s.config.spec));
  }
  for (const proto::Host& h : g.hosts()) {
    if (!served.contains(h.name())) continue;
    if (h.netns().empty()) {
      // The uplink is one of the interfaces of the kernel's own namespace: a table that dropped them all would
      // also cut the ground station and the shell, so the link processes are frozen instead.
      freeze_links_of(h.name(), "its uplink is in the kernel's own network namespace (hosts.netns unset), "
                                "whose every interface a table would close");
      continue;
    }
    auto made = sys::LinkClosure::create(sys::UplinkSpec{.label = h.name(), .netns = h.netns(), .devices = {}});
    if (!made) {
      const std::string why = made.error().to_string();
      if (made.error().error == EPERM) {
        freeze_links_of(h.name(), "no nftables table without CAP_NET_ADMIN (" + why + ")");
      } else {
        k.log("link %s: cannot be closed in the secure interval: %s", h.name().c_str(), why.c_str());
      }
      continue;
    }
    k.log("link %s: closed in the secure interval by %s", h.name().c_str(), made->description().c_str());
    links_.push_back(Link{.host = h.name(), .frozen_service = std::nullopt, .closure = std::move(*made)});
  }
  // A kernel that starts inside the secure interval (the boot's handler run) starts with its links closed.
  if (in_secure_interval(k.caps.mode())) set_all(sys::LinkState::Closed, k.caps.mode(), k.caps.mode());
}

void LinkGuard::freeze_links_of(const std::string& host, const std::string& why) {
  const proto::Launch& g = k.graph.graph;
  bool any = false;
  for (const ServiceRuntime& s : k.services) {
    if (s.config.skip || s.config.spec == nullptr || launch::host_of(g, *s.config.spec) != host ||
        !policy::is_host_link(g, *s.config.spec)) {
      continue;
    }
    any = true;
    // Its cgroup is made at its first spawn, after this: the freezing closure is made at the first close.
    k.log("link %s: %s; closed in the secure interval by freezing %s's cgroup (cgroup.freeze, v2) instead, from "
          "the first MC → RB (not through the start in SC and the alignment: its channel would fill)",
          host.c_str(), why.c_str(), s.name.c_str());
    links_.push_back(Link{.host = host, .frozen_service = s.id, .closure = {}});
  }
  if (!any) {
    k.log("link %s: %s, and no link service to freeze: it stays open in the secure interval", host.c_str(),
          why.c_str());
  }
}

void LinkGuard::before_mode(SrMode from, SrMode to) {
  closed_for_change_ = false;
  if (links_.empty() || in_secure_interval(from) || !in_secure_interval(to)) return;
  set_all(sys::LinkState::Closed, from, to);
  closed_for_change_ = true;
}

void LinkGuard::after_mode(SrMode from, SrMode to, bool entered) {
  if (links_.empty()) return;
  if (entered ? to == SrMode::MC : closed_for_change_) set_all(sys::LinkState::Open, from, to);
  closed_for_change_ = false;
}

void LinkGuard::set_all(sys::LinkState want, SrMode from, SrMode to) {
  const bool close = want == sys::LinkState::Closed;
  for (Link& l : links_) {
    if (!l.closure.valid() && l.frozen_service) {
      const ServiceRuntime& s = k.services[l.frozen_service->value()];
      if (s.proc.phase() == Phase::NotStarted) continue;  // the kernel's start: frozen from the first MC → RB
      const auto& dir = s.sandbox.cgroup.unified_dir();
      auto frozen = dir ? sys::LinkClosure::freezing(*dir, s.name)
                        : sys::SysResult<sys::LinkClosure>(std::unexpected(sys::SysError{"cgroup v2", ENOENT, s.sandbox.cgroup_note}));
      if (!frozen) {
        k.log("link %s: %s's cgroup cannot be frozen at %s: %s", l.host.c_str(), s.name.c_str(),
              transition(from, to).c_str(), frozen.error().to_string().c_str());
        continue;
      }
      l.closure = std::move(*frozen);
    }
    if (!l.closure.valid() || l.closure.state() == want) continue;
    const auto t0 = std::chrono::steady_clock::now();
    auto done = close ? l.closure.close() : l.closure.open();
    const auto us = std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - t0);
    if (!done) {
      k.log("link %s: could not be %s at %s: %s", l.host.c_str(), close ? "closed" : "opened",
            transition(from, to).c_str(), done.error().to_string().c_str());
      continue;
    }
    k.log("link %s %s at %s (%lld µs)", l.host.c_str(), close ? "closed" : "opened", transition(from, to).c_str(),
          static_cast<long long>(us.count()));
  }
}

}  // namespace rejuv::kernel
