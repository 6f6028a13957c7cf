// LinkClosure (link_closure.hpp): an nftables netdev table made and toggled over NETLINK_NETFILTER, the messages
// built here (nfnetlink batches, as libnftnl builds them: BATCH_BEGIN, the nf_tables messages, BATCH_END).
#include "rejuv/sys/link_closure.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <linux/netfilter.h>
#include <linux/netfilter/nf_tables.h>
#include <linux/netfilter/nfnetlink.h>
#include <linux/netlink.h>
#include <net/if.h>
#include <sched.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <utility>

namespace rejuv::sys {

SysResult<UniqueFd> open_netns(const std::string& name) {
  const std::string path = "/run/netns/" + name;
  UniqueFd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (!fd) return std::unexpected(SysError{"open(/run/netns)", errno, path});
  return fd;
}

namespace {

namespace fs = std::filesystem;

constexpr std::size_t kMaxLabel = 64;
// How long a netlink answer may take before close()/open() report it missing (never a hang).
constexpr timeval kAnswerTimeout{.tv_sec = 2, .tv_usec = 0};

bool is_label(const std::string& label) {
  return !label.empty() && label.size() <= kMaxLabel &&
         std::all_of(label.begin(), label.end(), [](char c) {
           return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
         });
}

// The calling thread inside another network namespace for the scope (setns affects this thread only); back in
// its own at the end. Sockets made meanwhile stay in the namespace they were made in.
class InNetns {
 public:
  static SysResult<InNetns> enter(const std::string& name) {
    UniqueFd own(::open("/proc/thread-self/ns/net", O_RDONLY | O_CLOEXEC));
    if (!own) return last_error("open(/proc/thread-self/ns/net)");
    auto target = open_netns(name);
    if (!target) return std::unexpected(std::move(target.error()));
    if (::setns(target->get(), CLONE_NEWNET) != 0) return std::unexpected(SysError{"setns", errno, name});
    return InNetns(std::move(own));
  }
  InNetns(InNetns&& other) noexcept = default;
  InNetns(const InNetns&) = delete;
  InNetns& operator=(const InNetns&) = delete;
  InNetns& operator=(InNetns&&) = delete;
  ~InNetns() {
    if (own_) REJUV_ASSERT(::setns(own_.get(), CLONE_NEWNET) == 0, "the thread could not return to its network namespace");
  }

 private:
  explicit InNetns(UniqueFd own) : own_(std::move(own)) {}
  UniqueFd own_;
};

// One nfnetlink batch: messages appended with their attributes, sent at once, each acknowledged.
class Batch {
 public:
  explicit Batch(std::uint32_t& seq) : seq_(seq) { header(NFNL_MSG_BATCH_BEGIN, NLM_F_REQUEST, AF_UNSPEC, NFNL_SUBSYS_NFTABLES); }

  // An nf_tables message (NFT_MSG_*) of `family`; acknowledged.
  void message(std::uint16_t type, std::uint16_t flags, std::uint8_t family) {
    finish();
    header(static_cast<std::uint16_t>((NFNL_SUBSYS_NFTABLES << 8) | type),
           static_cast<std::uint16_t>(NLM_F_REQUEST | NLM_F_ACK | flags), family, 0);
    ++acked_;
  }
  void attr(std::uint16_t type, const void* data, std::size_t size) {
    const std::size_t at = grow(NLA_HDRLEN + NLA_ALIGN(size));
    nlattr a{.nla_len = static_cast<std::uint16_t>(NLA_HDRLEN + size), .nla_type = type};
    std::memcpy(buf_.data() + at, &a, sizeof a);
    if (size > 0) std::memcpy(buf_.data() + at + NLA_HDRLEN, data, size);
  }
  void attr_string(std::uint16_t type, const std::string& s) { attr(type, s.c_str(), s.size() + 1); }
  void attr_be32(std::uint16_t type, std::uint32_t value) {
    const std::uint32_t be = htonl(value);
    attr(type, &be, sizeof be);
  }
  std::size_t nest() {
    const std::size_t at = grow(NLA_HDRLEN);
    return at;
  }
  void end_nest(std::size_t at, std::uint16_t type) {
    nlattr a{.nla_len = static_cast<std::uint16_t>(buf_.size() - at),
             .nla_type = static_cast<std::uint16_t>(type | NLA_F_NESTED)};
    std::memcpy(buf_.data() + at, &a, sizeof a);
  }

  // Sends the batch and reads one answer per message; the first error, with `what` in its detail.
  SysResult<void> commit(int fd, const std::string& what) {
    finish();
    header(NFNL_MSG_BATCH_END, NLM_F_REQUEST, AF_UNSPEC, NFNL_SUBSYS_NFTABLES);
    finish();
    sockaddr_nl kernel{.nl_family = AF_NETLINK, .nl_pad = 0, .nl_pid = 0, .nl_groups = 0};
    if (::sendto(fd, buf_.data(), buf_.size(), 0, reinterpret_cast<const sockaddr*>(&kernel), sizeof kernel) < 0) {
      return std::unexpected(SysError{"sendto(netlink)", errno, what});
    }
    std::optional<SysError> first;
    alignas(nlmsghdr) std::array<char, 8192> in{};
    while (acked_ > 0) {
      const ssize_t n = ::recv(fd, in.data(), in.size(), 0);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) {
        return std::unexpected(SysError{"recv(netlink)", errno, what + (errno == EAGAIN ? ": no answer" : "")});
      }
      // The answers, one nlmsghdr after another (NLMSG_OK/NLMSG_NEXT, without their C casts).
      for (std::size_t at = 0; at + NLMSG_HDRLEN <= static_cast<std::size_t>(n);) {
        nlmsghdr h{};
        std::memcpy(&h, in.data() + at, sizeof h);
        if (h.nlmsg_len < NLMSG_HDRLEN || at + h.nlmsg_len > static_cast<std::size_t>(n)) break;
        if (h.nlmsg_type == NLMSG_ERROR && h.nlmsg_len >= NLMSG_HDRLEN + sizeof(nlmsgerr)) {
          --acked_;
          nlmsgerr e{};
          std::memcpy(&e, in.data() + at + NLMSG_HDRLEN, sizeof e);
          if (e.error != 0 && !first) first = SysError{"nf_tables", -e.error, what};
        }
        at += NLMSG_ALIGN(h.nlmsg_len);
      }
    }
    if (first) return std::unexpected(*first);
    return {};
  }

 private:
  void header(std::uint16_t type, std::uint16_t flags, std::uint8_t family, std::uint16_t res_id) {
    start_ = grow(NLMSG_HDRLEN + NLMSG_ALIGN(sizeof(nfgenmsg)));
    nlmsghdr h{.nlmsg_len = 0, .nlmsg_type = type, .nlmsg_flags = flags, .nlmsg_seq = ++seq_, .nlmsg_pid = 0};
    std::memcpy(buf_.data() + start_, &h, sizeof h);
    nfgenmsg g{.nfgen_family = family, .version = NFNETLINK_V0, .res_id = htons(res_id)};
    std::memcpy(buf_.data() + start_ + NLMSG_HDRLEN, &g, sizeof g);
    open_ = true;
  }
  void finish() {
    if (!open_) return;
    const auto len = static_cast<std::uint32_t>(buf_.size() - start_);
    std::memcpy(buf_.data() + start_, &len, sizeof len);  // nlmsg_len is the header's first field
    open_ = false;
  }
  std::size_t grow(std::size_t by) {
    const std::size_t at = buf_.size();
    buf_.resize(at + NLMSG_ALIGN(by), 0);
    return at;
  }

  std::uint32_t& seq_;
  std::vector<char> buf_;
  std::size_t start_ = 0;
  bool open_ = false;
  int acked_ = 0;
};

// A base chain's policy in each state: every packet through the hook accepted, or dropped.
constexpr std::uint32_t chain_policy(LinkState state) {
  switch (state) {
    case LinkState::Open:
      return NF_ACCEPT;
    case LinkState::Closed:
      return NF_DROP;
  }
  return NF_DROP;
}

// The uplink's devices: the named ones (each must exist), or every interface of the namespace but loopback.
SysResult<std::vector<std::string>> uplink_devices(const UplinkSpec& spec, const std::string& where) {
  if (!spec.devices.empty()) {
    for (const std::string& d : spec.devices) {
      if (d.empty() || d.size() >= IFNAMSIZ || ::if_nametoindex(d.c_str()) == 0) {
        return std::unexpected(SysError{"if_nametoindex", ENODEV, "no interface '" + d + "' " + where});
      }
    }
    return spec.devices;
  }
  struct if_nameindex* all = ::if_nameindex();
  if (all == nullptr) return last_error("if_nameindex");
  std::vector<std::string> out;
  for (const struct if_nameindex* i = all; i->if_index != 0; ++i) {
    if (std::string_view(i->if_name) != "lo") out.emplace_back(i->if_name);
  }
  ::if_freenameindex(all);
  if (out.empty()) return std::unexpected(SysError{"if_nameindex", ENODEV, "no interface but lo " + where});
  return out;
}

}  // namespace

LinkClosure::LinkClosure(LinkClosure&& other) noexcept
    : mechanism_(other.mechanism_),
      state_(std::exchange(other.state_, LinkState::Open)),
      netlink_(std::move(other.netlink_)),
      seq_(other.seq_),
      table_(std::exchange(other.table_, {})),
      chains_(std::exchange(other.chains_, {})),
      freeze_file_(std::exchange(other.freeze_file_, {})),
      description_(std::exchange(other.description_, {})) {}

LinkClosure& LinkClosure::operator=(LinkClosure&& other) noexcept {
  if (this != &other) {
    release();
    mechanism_ = other.mechanism_;
    state_ = std::exchange(other.state_, LinkState::Open);
    netlink_ = std::move(other.netlink_);
    seq_ = other.seq_;
    table_ = std::exchange(other.table_, {});
    chains_ = std::exchange(other.chains_, {});
    freeze_file_ = std::exchange(other.freeze_file_, {});
    description_ = std::exchange(other.description_, {});
  }
  return *this;
}

SysResult<LinkClosure> LinkClosure::create(const UplinkSpec& spec) {
  if (!is_label(spec.label)) {
    return std::unexpected(SysError{"LinkClosure", EINVAL, "label '" + spec.label + "' is not 1…64 of [A-Za-z0-9_-]"});
  }
  const std::string where = spec.netns ? "in netns " + *spec.netns : "in the kernel's own namespace";
  std::optional<InNetns> inside;
  if (spec.netns) {
    auto entered = InNetns::enter(*spec.netns);
    if (!entered) return std::unexpected(entered.error());
    inside.emplace(std::move(*entered));
  }
  auto devices = uplink_devices(spec, where);
  if (!devices) return std::unexpected(devices.error());
  LinkClosure link;
  link.netlink_ = UniqueFd(::socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_NETFILTER));
  if (!link.netlink_) return last_error("socket(NETLINK_NETFILTER)");
  inside.reset();  // the socket stays in the uplink's namespace
  if (::setsockopt(link.netlink_.get(), SOL_SOCKET, SO_RCVTIMEO, &kAnswerTimeout, sizeof kAnswerTimeout) != 0) {
    return last_error("setsockopt(SO_RCVTIMEO)");
  }
  link.table_ = "rejuv_link_" + spec.label;
  Batch batch(link.seq_);
  batch.message(NFT_MSG_NEWTABLE, NLM_F_CREATE | NLM_F_EXCL, NFPROTO_NETDEV);
  batch.attr_string(NFTA_TABLE_NAME, link.table_);
  batch.attr_be32(NFTA_TABLE_FLAGS, NFT_TABLE_F_OWNER);
  std::string on;
  for (const std::string& dev : *devices) {
    for (const auto& [prefix, hook] : {std::pair{"in_", NF_NETDEV_INGRESS}, std::pair{"out_", NF_NETDEV_EGRESS}}) {
      batch.message(NFT_MSG_NEWCHAIN, NLM_F_CREATE | NLM_F_EXCL, NFPROTO_NETDEV);
      batch.attr_string(NFTA_CHAIN_TABLE, link.table_);
      link.chains_.push_back(prefix + dev);
      batch.attr_string(NFTA_CHAIN_NAME, link.chains_.back());
      const std::size_t h = batch.nest();
      batch.attr_be32(NFTA_HOOK_HOOKNUM, static_cast<std::uint32_t>(hook));
      batch.attr_be32(NFTA_HOOK_PRIORITY, 0);
      batch.attr_string(NFTA_HOOK_DEV, dev);
      batch.end_nest(h, NFTA_CHAIN_HOOK);
      batch.attr_be32(NFTA_CHAIN_POLICY, chain_policy(LinkState::Open));
      batch.attr_string(NFTA_CHAIN_TYPE, "filter");
    }
    on += (on.empty() ? "" : ", ") + dev;
  }
  if (auto made = batch.commit(link.netlink_.get(), "table netdev " + link.table_ + " " + where); !made) {
    return std::unexpected(made.error());
  }
  link.mechanism_ = ClosureMechanism::Nftables;
  link.description_ = "nftables table netdev " + link.table_ + " " + where + " on " + on;
  return link;
}

SysResult<LinkClosure> LinkClosure::freezing(fs::path cgroup, std::string label) {
  fs::path file = cgroup / "cgroup.freeze";
  if (::access(file.c_str(), W_OK) != 0) return std::unexpected(SysError{"access(cgroup.freeze)", errno, file.string()});
  LinkClosure link;
  link.mechanism_ = ClosureMechanism::CgroupFreeze;
  link.freeze_file_ = std::move(file);
  link.description_ = "cgroup.freeze of " + cgroup.string() + " (" + label + ")";
  return link;
}

SysResult<void> LinkClosure::close() { return set(LinkState::Closed); }
SysResult<void> LinkClosure::open() { return set(LinkState::Open); }

SysResult<void> LinkClosure::set(LinkState want) {
  REJUV_ASSERT(valid(), "close/open on an empty LinkClosure");
  if (state_ == want) return {};
  switch (mechanism_) {
    case ClosureMechanism::Nftables: {
      // Every chain's policy in one transaction: the link closes (or opens) both ways at once.
      Batch batch(seq_);
      for (const std::string& chain : chains_) {
        batch.message(NFT_MSG_NEWCHAIN, NLM_F_CREATE, NFPROTO_NETDEV);
        batch.attr_string(NFTA_CHAIN_TABLE, table_);
        batch.attr_string(NFTA_CHAIN_NAME, chain);
        batch.attr_be32(NFTA_CHAIN_POLICY, chain_policy(want));
      }
      if (auto ok = batch.commit(netlink_.get(), table_); !ok) return ok;
      break;
    }
    case ClosureMechanism::CgroupFreeze: {
      UniqueFd fd(::open(freeze_file_.c_str(), O_WRONLY | O_CLOEXEC));
      if (!fd) return std::unexpected(SysError{"open(cgroup.freeze)", errno, freeze_file_.string()});
      const char value = want == LinkState::Closed ? '1' : '0';
      if (::write(fd.get(), &value, 1) != 1) {
        return std::unexpected(SysError{"write(cgroup.freeze)", errno, freeze_file_.string()});
      }
      break;
    }
  }
  state_ = want;
  return {};
}

void LinkClosure::release() noexcept {
  if (!valid()) return;
  switch (mechanism_) {
    case ClosureMechanism::Nftables: {
      // Closing the socket deletes the owned table too; the explicit delete makes it gone when this returns.
      Batch batch(seq_);
      batch.message(NFT_MSG_DELTABLE, 0, NFPROTO_NETDEV);
      batch.attr_string(NFTA_TABLE_NAME, table_);
      (void)batch.commit(netlink_.get(), table_);
      netlink_.reset();
      break;
    }
    case ClosureMechanism::CgroupFreeze:
      (void)set(LinkState::Open);
      freeze_file_.clear();
      break;
  }
  state_ = LinkState::Open;
}

}  // namespace rejuv::sys
