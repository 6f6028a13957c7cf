// The links to other hosts closed in the secure interval (link_guard.hpp).
#include "link_guard.hpp"

#include <cerrno>
#include <chrono>
#include <cstdarg>
#include <cstdio>
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

std::vector<LinkHost> link_hosts(const Kernel::Impl& k) {
  const proto::Launch& g = k.graph.graph;
  if (!k.sr || g.hosts_size() == 0) return {};
  std::set<std::string> served;  // the hosts this kernel runs services for
  for (const ServiceRuntime& s : k.services) {
    if (!s.config.skip && s.config.spec != nullptr) served.emplace(launch::host_of(g, *s.config.spec));
  }
  std::vector<LinkHost> out;
  for (const proto::Host& h : g.hosts()) {
    if (!served.contains(h.name())) continue;
    LinkHost host{.name = h.name(), .netns = h.netns(), .link_services = {}};
    for (const ServiceRuntime& s : k.services) {
      if (s.config.skip || s.config.spec == nullptr || launch::host_of(g, *s.config.spec) != h.name() ||
          !policy::is_host_link(g, *s.config.spec)) {
        continue;
      }
      host.link_services.push_back(LinkService{.id = s.id, .name = s.name});
    }
    out.push_back(std::move(host));
  }
  return out;
}

LinkGuard::Log kernel_log(Kernel::Impl& k) {
  return [&k](const std::string& line) { k.log("%s", line.c_str()); };
}

LinkGuard::CgroupOf kernel_cgroups(const Kernel::Impl& k) {
  return [&k](ServiceId id) {
    const ServiceRuntime& s = k.services[id.value()];
    if (s.proc.phase() == Phase::NotStarted) return LinkCgroup{.started = false, .dir = std::nullopt, .note = ""};
    const auto& dir = s.sandbox.cgroup.unified_dir();
    return LinkCgroup{.started = true, .dir = dir ? std::optional(*dir) : std::nullopt, .note = s.sandbox.cgroup_note};
  };
}

void LinkGuard::say(const char* format, ...) {
  va_list args;
  va_start(args, format);
  const std::string line = log_line(format, args);
  va_end(args);
  log_(line);
}

void LinkGuard::create(std::span<const LinkHost> hosts, SrMode mode) {
  for (const LinkHost& h : hosts) {
    if (h.netns.empty()) {
      // The uplink is one of the interfaces of the kernel's own namespace: a table that dropped them all would
      // also cut the ground station and the shell, so the link processes are frozen instead.
      freeze_links_of(h, "its uplink is in the kernel's own network namespace (hosts.netns unset), whose every "
                         "interface a table would close");
      continue;
    }
    auto made = sys::LinkClosure::create(sys::UplinkSpec{.label = h.name, .netns = h.netns, .devices = {}});
    if (!made) {
      const std::string why = made.error().to_string();
      if (made.error().error == EPERM) {
        freeze_links_of(h, "no nftables table without CAP_NET_ADMIN (" + why + ")");
      } else {
        say("link %s: cannot be closed in the secure interval: %s", h.name.c_str(), why.c_str());
      }
      continue;
    }
    say("link %s: closed in the secure interval by %s", h.name.c_str(), made->description().c_str());
    links_.push_back(Link{.host = h.name, .frozen_service = std::nullopt, .closure = std::move(*made)});
  }
  // A kernel that starts inside the secure interval (the boot's handler run) starts with its links closed.
  if (in_secure_interval(mode)) set_all(sys::LinkState::Closed, mode, mode);
}

void LinkGuard::freeze_links_of(const LinkHost& host, const std::string& why) {
  for (const LinkService& s : host.link_services) {
    // Its cgroup is made at its first spawn, after this: the freezing closure is made at the first close.
    say("link %s: %s; closed in the secure interval by freezing %s's cgroup (cgroup.freeze, v2) instead, from the "
        "first MC → RB (not through the start in SC and the alignment: its channel would fill)",
        host.name.c_str(), why.c_str(), s.name.c_str());
    links_.push_back(Link{.host = host.name, .frozen_service = s, .closure = {}});
  }
  if (host.link_services.empty()) {
    say("link %s: %s, and no link service to freeze: it stays open in the secure interval", host.name.c_str(),
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
      const LinkService& s = *l.frozen_service;
      const LinkCgroup cgroup = cgroup_of_(s.id);
      if (!cgroup.started) continue;  // the kernel's start: frozen from the first MC → RB
      auto frozen = cgroup.dir ? sys::LinkClosure::freezing(*cgroup.dir, s.name)
                               : sys::SysResult<sys::LinkClosure>(std::unexpected(sys::SysError{"cgroup v2", ENOENT, cgroup.note}));
      if (!frozen) {
        say("link %s: %s's cgroup cannot be frozen at %s: %s", l.host.c_str(), s.name.c_str(),
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
      say("link %s: could not be %s at %s: %s", l.host.c_str(), close ? "closed" : "opened",
          transition(from, to).c_str(), done.error().to_string().c_str());
      continue;
    }
    say("link %s %s at %s (%lld µs)", l.host.c_str(), close ? "closed" : "opened", transition(from, to).c_str(),
        static_cast<long long>(us.count()));
  }
}

}  // namespace rejuv::kernel
