// `rejuv keys init DIR`, `rejuv keys hosts|check DIR --launch GRAPH [--domain N]` (docs/across_hosts.md): the DDS
// Security keystore of a graph across hosts, generated from its policy (keystore.hpp). `hosts` refuses a graph
// that does not audit clean: what it grants is what the audit checked; `check` compares a keystore with the
// policy. Exit 0 done (or matching), 1 audit findings (or a mismatch), 2 bad
// input (a bad DIR, an unreadable or malformed graph, a graph without hosts).
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "keystore.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/policy/audit.hpp"
#include "rejuv/policy/hosts.hpp"
#include "rejuv/policy/policy.hpp"

namespace rejuv::cli {

namespace {

constexpr std::string_view kSummary =
    "The DDS Security keystore of a graph across hosts (docs/across_hosts.md), in SROS2's layout:\n"
    "  rejuv keys init DIR                      a CA (EC prime256v1) for identities and permissions\n"
    "  rejuv keys hosts DIR --launch GRAPH      per host of GRAPH: an identity (CN = the host), permissions\n"
    "                                           granting exactly its cross-host topics (default DENY) and the\n"
    "                                           governance (encrypted, authenticated only), signed by the CA\n"
    "  rejuv keys check DIR --launch GRAPH      whether DIR still matches GRAPH's policy\n"
    "Exit 0 done, 1 when GRAPH does not audit clean, 2 on bad input.";

int keys_init(std::span<const std::string_view> args) {
  std::string dir;
  Options opts("keys init", "Makes the keystore's CA in DIR (public/, private/ 0700, enclaves/); refuses a DIR\n"
                            "that holds one already.");
  opts.positional("DIR", dir, "the keystore folder (made if missing)");
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (auto r = keys::init_keystore(dir); !r) return refuse("keys", r.error());
  print(stdout, "keys: CA made in " + dir + " (public/ca.cert.pem, private/ca.key.pem)\n");
  return static_cast<int>(Exit::Ok);
}

// What `keys hosts` and `keys check` share: DIR, GRAPH, the domain, and what the audited policy grants each host.
struct HostsRequest {
  std::string dir;
  std::filesystem::path launch_path;
  std::optional<std::uint64_t> domain;
  std::vector<keys::HostGrant> grants;
  std::uint32_t domain_id = 0;
};

void declare_hosts_options(Options& opts, HostsRequest& r) {
  opts.positional("DIR", r.dir, "the keystore folder (made by `rejuv keys init`)")
      .path("--launch", "GRAPH", r.launch_path, "the launch graph (*.launch.pbtxt) with its `hosts`")
      .required()
      .integer("--domain", "N", r.domain, IntRange{0, launch::defaults::kMaxDdsDomainId},
               "the DDS domain the permissions and governance cover", "the graph's dds.domain_id");
}

// Loads GRAPH and its policy, refuses a graph that does not audit clean, and fills r.grants; the exit code on
// failure (reported).
std::optional<int> load_grants(HostsRequest& r) {
  if (!std::filesystem::is_directory(r.dir)) {
    return refuse("keys", r.dir + ": no such keystore folder; make one with `rejuv keys init " + r.dir + "`");
  }
  const std::filesystem::path& launch_path = r.launch_path;
  auto g = launch::load_launch(launch_path);
  if (!g) return refuse("keys", g.error().to_string());
  if (g->graph.hosts_size() == 0) {
    return refuse("keys", launch_path.string() + ": the graph declares no `hosts { name address }`: nothing crosses "
                                            "between hosts, so there is nothing to secure");
  }
  auto pol = policy::load_policy(g->policy_path, g->policy_includes);
  if (!pol) return refuse("keys", pol.error().to_string());
  if (auto ok = policy::check_used_objects(*pol, *g); !ok) return refuse("keys", ok.error().to_string());
  const auto findings = policy::audit(*pol, *g);
  if (!findings.empty()) {
    for (const auto& f : findings) print(stderr, f.to_string() + "\n");
    print(stderr, "rejuv keys: " + launch_path.string() + " does not audit clean (" + std::to_string(findings.size()) +
                      " finding(s)): it grants nothing\n");
    return static_cast<int>(Exit::Findings);
  }
  for (auto& t : policy::host_topics(*pol, policy::placement(*pol, *g), launch::dds_naming(g->graph.dds()))) {
    r.grants.push_back(keys::HostGrant{std::move(t.host), std::move(t.publish), std::move(t.subscribe)});
  }
  r.domain_id = static_cast<std::uint32_t>(r.domain.value_or(g->graph.dds().domain_id()));
  return std::nullopt;
}

// Declares DIR, --launch and --domain on opts, parses args and loads the grants; the exit code when the command
// stops there (help printed or input refused).
std::optional<int> parse_hosts_request(Options& opts, std::span<const std::string_view> args, HostsRequest& r) {
  declare_hosts_options(opts, r);
  if (auto exit = opts.parse_or_exit(args)) return exit;
  return load_grants(r);
}

int keys_hosts(std::span<const std::string_view> args) {
  HostsRequest req;
  Options opts("keys hosts",
               "Writes an enclave per host of GRAPH into the keystore DIR: enclaves/<host>/{cert.pem,key.pem,\n"
               "identity_ca.cert.pem,permissions_ca.cert.pem,governance.p7s,permissions.xml,permissions.p7s}.\n"
               "An identity already there is kept; permissions and governance are written again.");
  if (auto exit = parse_hosts_request(opts, args, req)) return *exit;
  const auto domain_id = req.domain_id;
  if (auto r = keys::write_enclaves(req.dir, req.grants, domain_id); !r) return refuse("keys", r.error());
  for (const auto& h : req.grants) {
    const auto list = [](const std::vector<std::string>& v) {
      std::string s;
      for (const auto& n : v) s += (s.empty() ? "" : ", ") + n;
      return s.empty() ? std::string("-") : s;
    };
    print(stdout, "keys: enclave " + h.host + " (domain " + std::to_string(domain_id) + "): publish " + list(h.publish) +
                      "; subscribe " + list(h.subscribe) + "\n");
  }
  return static_cast<int>(Exit::Ok);
}

int keys_check(std::span<const std::string_view> args) {
  HostsRequest req;
  Options opts("keys check",
               "Checks that the keystore DIR matches GRAPH's policy: per host an identity of its CN issued by the\n"
               "CA, permissions signed by the CA granting exactly its cross-host topics (default DENY), and a\n"
               "governance signed by the CA that refuses unauthenticated participants. Exit 0 when it matches,\n"
               "1 on a mismatch (each one printed), 2 on bad input.");
  if (auto exit = parse_hosts_request(opts, args, req)) return *exit;
  auto mismatches = keys::check_enclaves(req.dir, req.grants, req.domain_id);
  if (!mismatches) return refuse("keys", mismatches.error());
  for (const auto& m : *mismatches) print(stderr, "keys: " + m + "\n");
  if (!mismatches->empty()) {
    print(stdout, "keys: FAILED: " + req.dir + " does not match the policy of " + req.launch_path.string() + " (" +
                      std::to_string(mismatches->size()) + " mismatch(es))\n");
    return static_cast<int>(Exit::Findings);
  }
  print(stdout, "keys: OK: " + req.dir + " matches the policy of " + req.launch_path.string() + " (" +
                    std::to_string(req.grants.size()) + " hosts)\n");
  return static_cast<int>(Exit::Ok);
}

}  // namespace

int run_keys(std::span<const std::string_view> args) {
  if (args.empty() || args[0] == "--help" || args[0] == "-h") {
    print(args.empty() ? stderr : stdout, "usage: rejuv keys init DIR | rejuv keys hosts|check DIR --launch GRAPH [--domain N]\n\n" +
                                              std::string(kSummary) + "\n\n'rejuv keys init|hosts|check --help' show the options.\n");
    return static_cast<int>(args.empty() ? Exit::BadInput : Exit::Ok);
  }
  if (args[0] == "init") return keys_init(args.subspan(1));
  if (args[0] == "hosts") return keys_hosts(args.subspan(1));
  if (args[0] == "check") return keys_check(args.subspan(1));
  return refuse("keys", "unknown subcommand '" + std::string(args[0]) + "': expected init, hosts or check (rejuv keys --help)");
}

}  // namespace rejuv::cli
