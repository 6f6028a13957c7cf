// `rejuv audit POLICY [--launch GRAPH] [--format text|json]` (docs/design.md §4, §10): prints the service ×
// object × mode matrix and every violation of the SR invariants, in the file:line:column format of a
// compiler (text) or as one JSON document (CI). Exit 0 clean, 1 on violations, 2 on bad input.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "common_options.hpp"
#include "host_part.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/policy/audit.hpp"
#include "rejuv/policy/hosts.hpp"
#include "rejuv/policy/policy.hpp"

namespace rejuv::cli {

namespace {

enum class Format : std::uint8_t { Text, Json };

// RFC 8259 string escaping; bytes ≥ 0x80 pass through (the inputs are UTF-8 text files).
std::string json_string(std::string_view s) {
  std::string out = "\"";
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      default:
        if (c < 0x20U) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(c));
          out += buf;
        } else {
          out += ch;
        }
    }
  }
  return out + "\"";
}

std::string json_location(const SourceLocation& w) {
  return "\"file\":" + json_string(w.file) + ",\"line\":" + std::to_string(w.line) +
         ",\"column\":" + std::to_string(w.column);
}

std::string_view kind_word(LoadErrorKind k) {
  switch (k) {
    case LoadErrorKind::CannotRead: return "cannot_read";
    case LoadErrorKind::Syntax: return "syntax";
    case LoadErrorKind::Semantic: return "semantic";
  }
  return "?";
}

// A file that cannot be read or parsed: the compiler-style line on stderr, and for CI a JSON document.
int bad_input(Format format, const std::string& policy_path, const LoadError& e) {
  if (format == Format::Json) {
    print(stdout, "{\"policy\":" + json_string(policy_path) + ",\"ok\":false,\"error\":{\"kind\":" +
                      json_string(kind_word(e.kind)) + ",\"message\":" + json_string(e.message) + "," +
                      json_location(e.where) + "},\"findings\":[],\"matrix\":[]}\n");
  }
  return refuse(e.to_string());
}

// Pads `s` to `width` terminal columns (the empty-cell dot is one column but two bytes).
std::string pad(std::string_view s, std::size_t width, std::size_t display = std::string::npos) {
  const std::size_t shown = display == std::string::npos ? s.size() : display;
  return std::string(s) + std::string(shown < width ? width - shown : 1, ' ');
}

void trim_right(std::string& s) {
  while (!s.empty() && s.back() == ' ') {
    s.pop_back();
  }
}

std::string text_matrix(const policy::Policy& p) {
  const auto rows = policy::matrix(p);
  std::size_t sw = 7, ow = 6;  // "service", "object"
  for (const auto& r : rows) {
    sw = std::max(sw, p.service(r.service).name.size());
    ow = std::max(ow, p.object(r.object).name.size());
  }
  constexpr std::size_t kCell = 7;  // "UPDATE" + one space
  std::string out = pad("service", sw + 2) + pad("object", ow + 2);
  for (const SrMode m : kAllModes) {
    out += pad(to_string(m), kCell);
  }
  trim_right(out);
  out += "\n";
  for (const auto& r : rows) {
    out += pad(p.service(r.service).name, sw + 2) + pad(p.object(r.object).name, ow + 2);
    for (const SrMode m : kAllModes) {
      const Rights cell = r.rights[index_of(m)];
      out += cell.empty() ? pad("\u00b7", kCell, 1) : pad(cell.to_string(), kCell);
    }
    trim_right(out);
    out += "\n";
  }
  return out;
}

std::string json_matrix(const policy::Policy& p) {
  std::string out = "[";
  bool first = true;
  for (const auto& r : policy::matrix(p)) {
    out += first ? "" : ",";
    first = false;
    out += "{\"service\":" + json_string(p.service(r.service).name) +
           ",\"object\":" + json_string(p.object(r.object).name) +
           ",\"kind\":" + json_string(to_string(p.object(r.object).kind)) + ",\"modes\":{";
    for (const SrMode m : kAllModes) {
      out += (m == kAllModes.front() ? "" : ",") + json_string(to_string(m)) + ":" +
             json_string(r.rights[index_of(m)].letters());
    }
    out += "}}";
  }
  return out + "]";
}

std::string verdict(const policy::Policy& p, const std::vector<policy::Finding>& findings,
                    const launch::LoadedLaunch* graph) {
  const std::string subject = "policy \"" + (p.name().empty() ? p.file() : p.name()) + "\"" +
                              (graph != nullptr ? " with graph \"" + graph->graph.name() + "\"" : "");
  if (findings.empty()) {
    return "audit: OK: " + subject + " satisfies timer, sei, limits, persistent, lateral, coverage, checkpoint, mode, restricted, controls" + std::string(graph != nullptr ? ", hosts" : "") + " and " +
           std::to_string(p.deny_rules().size()) + " deny rule(s)\n";
  }
  // Count per id, in first-seen order.
  std::vector<std::pair<std::string, int>> counts;
  for (const auto& f : findings) {
    const std::string id = f.id();
    auto it = std::find_if(counts.begin(), counts.end(), [&](const auto& c) { return c.first == id; });
    if (it == counts.end()) {
      counts.emplace_back(id, 1);
    } else {
      ++it->second;
    }
  }
  std::string by;
  for (const auto& [id, n] : counts) {
    by += (by.empty() ? "" : ", ") + id + " " + std::to_string(n);
  }
  return "audit: FAILED: " + subject + " has " + std::to_string(findings.size()) + " violation(s) (" + by +
         ")\n";
}

// What `rejuv audit` was asked for.
struct AuditRequest {
  std::string policy_path;
  std::optional<std::filesystem::path> launch_path;
  Format format = Format::Text;
};

void declare_audit_options(Options& opts, AuditRequest& r) {
  opts.positional("POLICY", r.policy_path, "the policy (*.policy.pbtxt); optional with --launch", false)
      .path("--launch", "GRAPH", r.launch_path, "also check against this launch graph (*.launch.pbtxt)")
      .choice<Format>("--format", {{"text", Format::Text}, {"json", Format::Json}}, r.format, "output format (json for CI)");
}

// --launch's graph, its services' params checked against what they declare (as `rejuv run` refuses them);
// without POLICY, the policy it names becomes r.policy_path. The error is the exit code (reported).
Result<std::optional<launch::LoadedLaunch>, int> load_audit_graph(AuditRequest& r) {
  if (!r.launch_path) return std::optional<launch::LoadedLaunch>{};
  auto g = launch::load_launch(*r.launch_path);
  if (!g) return fail(bad_input(r.format, r.policy_path, g.error()));
  if (auto ok = launch::check_declared_params(*g, service_dir()); !ok) {
    return fail(bad_input(r.format, r.policy_path, ok.error()));
  }
  if (r.policy_path.empty()) r.policy_path = g->policy_path.string();
  // Auditing a candidate policy against a graph that names another one is allowed, but say so.
  std::error_code ec;
  if (r.format == Format::Text && !std::filesystem::equivalent(g->policy_path, r.policy_path, ec)) {
    print(stderr, "rejuv audit: note: " + r.launch_path->string() + " names the policy " + g->policy_path.string() +
                      ", not " + r.policy_path + "\n");
  }
  return std::optional<launch::LoadedLaunch>(std::move(*g));
}

std::string text_report(const policy::Policy& pol, const std::string& policy_path,
                        const std::vector<policy::Finding>& findings, const launch::LoadedLaunch* graph) {
  std::string out = "policy \"" + pol.name() + "\" (" + policy_path + "): " + std::to_string(pol.services().size()) +
                    " services, " + std::to_string(pol.objects().size()) + " objects, " +
                    std::to_string(pol.grants().size()) + " grants, " + std::to_string(pol.deny_rules().size()) +
                    " deny rules\n\n";
  out += text_matrix(pol);
  if (!findings.empty()) {
    out += "\n";
    for (const auto& f : findings) out += f.to_string() + "\n";
  }
  return out + "\n" + verdict(pol, findings, graph);
}

std::string json_report(const policy::Policy& pol, const AuditRequest& r, const std::vector<policy::Finding>& findings) {
  std::string out = "{\"policy\":" + json_string(r.policy_path) + ",\"name\":" + json_string(pol.name()) +
                    ",\"launch\":" + (r.launch_path ? json_string(r.launch_path->string()) : std::string("null")) +
                    ",\"ok\":" + (findings.empty() ? "true" : "false") + ",\"findings\":[";
  for (std::size_t i = 0; i < findings.size(); ++i) {
    const auto& f = findings[i];
    out += (i == 0 ? "" : ",") + std::string("{\"invariant\":") + json_string(f.id()) +
           ",\"message\":" + json_string(f.message) + "," + json_location(f.where) + "}";
  }
  return out + "],\"matrix\":" + json_matrix(pol) + "}\n";
}

// A graph across hosts (docs/across_hosts.md "The link"): each host's part audited with the links `rejuv run
// --host` adds to it (policy/hosts.hpp add_host_links), as that host's kernel audits it; their findings join the
// graph's (each once), and `links` says what each host's links carry. An error: the links could not be made.
Result<std::vector<policy::Finding>, std::string> audit_links(const std::string& policy_path,
                                                              const launch::LoadedLaunch& graph, std::string& links) {
  std::vector<policy::Finding> out;
  if (graph.graph.hosts_size() < 2) return out;
  auto dir = RunTempDir::create("rejuv-audit-");
  if (!dir) return fail(dir.error());
  for (const proto::Host& h : graph.graph.hosts()) {
    auto loaded = launch::load_launch(graph.path);  // a graph of its own per host (a loaded graph is not copied)
    if (!loaded) return fail(loaded.error().to_string());
    launch::LoadedLaunch& part = *loaded;
    auto added = policy::add_host_links(part, h.name(), dir->path());
    if (!added) return fail("host " + h.name() + ": " + added.error());
    auto pol = policy::load_policy(policy_path, part.policy_includes);
    if (!pol) return fail("host " + h.name() + ": " + pol.error().to_string());
    for (const policy::HostLink& l : added->links) {
      std::string carried;
      for (const auto& [ids, right] : {std::pair{&l.writes, "W"}, std::pair{&l.reads, "R"}}) {
        for (const ObjectId t : *ids) carried += (carried.empty() ? "" : ", ") + pol->object(t).name + " " + right;
      }
      links += "link: host \"" + h.name() + "\" runs " + policy::link_service_name(added->hosts[l.peer]) +
               " (rejuv_host_link, MC only): " + carried + "\n";
    }
    for (policy::Finding& f : policy::audit(*pol, part)) out.push_back(std::move(f));
  }
  return out;
}

}  // namespace

int run_audit(std::span<const std::string_view> args) {
  AuditRequest r;
  Options opts("audit",
               "Checks a capability policy against the CPS SR invariants of docs/design.md §4 (timer, sei, limits,\n"
               "persistent, lateral, coverage) and its own deny rules, and prints the service x object x\n"
               "mode matrix. Exit 0 when clean, 1 on violations, 2 when a file cannot be read or parsed.\n"
               "With --launch and no POLICY, the policy the graph names (with its policy fragments).");
  declare_audit_options(opts, r);
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (r.policy_path.empty() && !r.launch_path) {
    return refuse("audit", "POLICY is required without --launch GRAPH (rejuv audit --help)");
  }
  const auto graph = load_audit_graph(r);
  if (!graph) return graph.error();
  // With a graph, its policy fragments (`policy_include`) are part of the policy audited.
  const auto pol = policy::load_policy(r.policy_path, *graph ? std::span<const ExtraFragment>((*graph)->policy_includes)
                                                             : std::span<const ExtraFragment>());
  if (!pol) return bad_input(r.format, r.policy_path, pol.error());
  if (*graph) {
    if (auto ok = policy::check_used_objects(*pol, **graph); !ok) return bad_input(r.format, r.policy_path, ok.error());
  }
  auto findings = *graph ? policy::audit(*pol, **graph) : policy::audit(*pol);
  std::string links;
  if (*graph) {
    auto with_links = audit_links(r.policy_path, **graph, links);
    if (!with_links) return refuse("audit", "the links between hosts: " + with_links.error());
    for (policy::Finding& f : *with_links) {
      const std::string text = f.to_string();
      if (std::none_of(findings.begin(), findings.end(), [&](const policy::Finding& g) { return g.to_string() == text; })) {
        findings.push_back(std::move(f));
      }
    }
  }
  switch (r.format) {
    case Format::Text:
      print(stdout, (links.empty() ? "" : links + "\n") + text_report(*pol, r.policy_path, findings, *graph ? &**graph : nullptr));
      break;
    case Format::Json: print(stdout, json_report(*pol, r, findings)); break;
  }
  return static_cast<int>(findings.empty() ? Exit::Ok : Exit::Findings);
}

}  // namespace rejuv::cli
