// The link to another host closed below DDS in the secure execution interval (the paper's §III and §IV-D: in RB,
// SC, UPDATE and CP the vehicle is closed to the outside). DDS Security permissions cannot change on a live
// Cyclone participant, so the kernel closes the uplink itself (docs/across_hosts.md "Closing the link").
//
// LinkClosure owns an nftables table of the `netdev` family in the uplink's network namespace, made through a
// netlink socket of its own (NETLINK_NETFILTER, opened inside that namespace):
//
//   table netdev rejuv_link_<label> {            flags owner
//     chain in_<dev>  { type filter hook ingress device <dev> priority 0; policy accept; }
//     chain out_<dev> { type filter hook egress  device <dev> priority 0; policy accept; }   (per uplink device)
//   }
//
// close() sets every chain's policy to drop (every packet of the uplink dropped both ways, ARP included, before
// the IP stack, and on the sending side before any packet tap sees it); open() sets it back to accept. Each is
// one nftables transaction (a NEWCHAIN per chain, the policy only), answered before it returns; both are
// idempotent. The table belongs to the socket (NFT_TABLE_F_OWNER): no other process can change or delete it,
// and the kernel deletes it when the socket closes — when the LinkClosure is destroyed, and also when its
// process dies, so a crashed kernel never leaves a host closed for good. (The table's dormant flag would
// unhook an open link entirely, but the kernel refuses to change the flags of an owned table: EOPNOTSUPP.)
//
// Why netlink and not the `nft` program: a mode change is on the kernel's path at MC → RB, and a fork+exec of
// `nft` per change costs a process start where the message costs a system call (docs/performance.md "Closing
// the link", bench/sys link_closure_bench); the owner flag, which removes the table with its process, exists
// only for the socket that made the table.
//
// Without CAP_NET_ADMIN in the namespace no table can be made (EPERM); the kernel then freezes the link
// process's cgroup instead (LinkClosure::freezing: cgroup.freeze of its v2 cgroup), which stops what the link
// sends and forwards but not what the kernel's own network stack answers (ARP, ICMP).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "rejuv/sys/fd.hpp"

namespace rejuv::sys {

// The network namespace `name` (an `ip netns` name: /run/netns/<name>), opened for setns.
[[nodiscard]] SysResult<UniqueFd> open_netns(const std::string& name);

// The uplink a LinkClosure closes.
struct UplinkSpec {
  std::string label{};                // names the table rejuv_link_<label>; 1…64 of [A-Za-z0-9_-]
  std::optional<std::string> netns{}; // an `ip netns` name (/run/netns/<netns>); unset: the caller's own namespace
  std::vector<std::string> devices{}; // the uplink's interfaces; empty: every interface of the namespace but lo
};

enum class LinkState : std::uint8_t { Open, Closed };

// How a LinkClosure closes its link.
enum class ClosureMechanism : std::uint8_t {
  Nftables,      // a netdev table in the uplink's namespace, its chains' policy drop while closed
  CgroupFreeze,  // the link process's cgroup frozen (cgroup.freeze), where no table may be made
};

class LinkClosure {
 public:
  LinkClosure() = default;
  LinkClosure(const LinkClosure&) = delete;
  LinkClosure& operator=(const LinkClosure&) = delete;
  LinkClosure(LinkClosure&& other) noexcept;
  LinkClosure& operator=(LinkClosure&& other) noexcept;
  ~LinkClosure() { release(); }

  // Makes the table, open (policy accept). Errors: the label is not a name (EINVAL), the namespace does not exist
  // (ENOENT, from /run/netns), a named device does not exist or the namespace has none but lo (ENODEV), no
  // CAP_NET_ADMIN there (EPERM), a table of that name exists already (EEXIST; EPERM when another process owns it);
  // detail says which.
  [[nodiscard]] static SysResult<LinkClosure> create(const UplinkSpec& spec);
  // Closes a link by freezing the cgroup v2 directory `cgroup` (where the link process runs), open (thawed).
  // ENOENT when it has no cgroup.freeze.
  [[nodiscard]] static SysResult<LinkClosure> freezing(std::filesystem::path cgroup, std::string label);

  // Closed: nothing crosses the uplink until open(). Idempotent (a second call sends nothing).
  [[nodiscard]] SysResult<void> close();
  [[nodiscard]] SysResult<void> open();

  [[nodiscard]] LinkState state() const { return state_; }
  [[nodiscard]] ClosureMechanism mechanism() const { return mechanism_; }
  [[nodiscard]] bool valid() const { return netlink_.valid() || !freeze_file_.empty(); }
  // "nftables table netdev rejuv_link_vehicle in netns rjN_vehicle on veth0" or "cgroup.freeze of /sys/...".
  [[nodiscard]] const std::string& description() const { return description_; }
  // The table's name (empty for a cgroup freeze).
  [[nodiscard]] const std::string& table() const { return table_; }

 private:
  [[nodiscard]] SysResult<void> set(LinkState want);
  // Deletes the table (the socket's close would too) or thaws the cgroup; the handle is empty after it.
  void release() noexcept;

  ClosureMechanism mechanism_ = ClosureMechanism::Nftables;
  LinkState state_ = LinkState::Open;
  UniqueFd netlink_{};                    // NETLINK_NETFILTER, in the uplink's namespace; owns the table
  std::uint32_t seq_ = 0;                 // netlink sequence numbers
  std::string table_{};
  std::vector<std::string> chains_{};     // its base chains, two per uplink device
  std::filesystem::path freeze_file_{};  // <cgroup>/cgroup.freeze
  std::string description_{};
};

}  // namespace rejuv::sys
