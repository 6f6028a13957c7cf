// The options shared by several `rejuv` commands (common_options.hpp).
#include "common_options.hpp"

#include <cstdlib>
#include <tuple>

#include "attack_option.hpp"
#include "figures.hpp"
#include "rejuv/launch/launch.hpp"

#ifndef REJUV_SERVICE_DIR
#define REJUV_SERVICE_DIR ""
#endif

namespace rejuv::cli {

Options& seed_option(Options& o, std::optional<std::uint64_t>& out, std::string help) {
  return o.integer("--seed", "N", out, {}, std::move(help), "the graph's");
}

Options& domain_option(Options& o, std::optional<std::uint64_t>& out, std::string help, std::string unset) {
  return o.integer("--domain", "N", out, {0, launch::defaults::kMaxDdsDomainId}, std::move(help), std::move(unset));
}

Options& net_port_option(Options& o, std::optional<std::uint64_t>& out, std::string help, std::string unset) {
  return o.integer("--net-port", "P", out, {0, 0xFFFF}, std::move(help), std::move(unset));
}

Options& charge_option(Options& o, Charge& out, std::string_view why) {
  return o.choice<Charge>("--charge", {{"model", Charge::Model}, {"measured", Charge::Measured}}, out,
                          "simulated time charged per checkpoint and rollback in lockstep: 'model' (the launch file's\n"
                          "lockstep.*_charge_ms; two runs with one seed are identical) or 'measured' (their real durations,\n"
                          "for timing studies; the run then depends on the machine)" +
                              std::string(why));
}

Options& attack_option(Options& o, std::optional<flight::AttackLaw>& out) {
  return o.custom<flight::AttackLaw>("--attack", "KIND", out, parse_attack_kind,
                                     "the kind of the plan's first attack (its service follows: e.g. ESTIMATE_SHIFT "
                                     "compromises ekf2):\n" +
                                         flight::attack_law_names() +
                                         "\n(case-insensitive; docs/control.md \"Attack library\")",
                                     "the graph's");
}

Options& flight_options(Options& o, FlightSwitches& out, std::string no_sr_help) {
  o.flag("--no-sr", out.no_sr, std::move(no_sr_help)).flag("--no-attack", out.no_attack, "disable the attack plan");
  return attack_option(o, out.attack);
}

Options& out_options(Options& o, OutFlags& out) {
  return o.path("--out", "DIR", out.dir, kOutHelp)
      .choice<TraceDetail>("--trace", {{"compact", TraceDetail::Compact}, {"full", TraceDetail::Full}}, out.trace,
                           kTraceHelp)
      .flag("--no-figures", out.no_figures, kNoFiguresHelp);
}

Result<void, std::string> check_out_options(const Options& o, const OutFlags& out) {
  if (o.given("--trace") && !out.dir) return fail("--trace is the detail of --out's trace: give --out DIR");
  if (out.no_figures && !out.dir) return fail("--no-figures goes with --out DIR");
  return {};
}

kernel::KernelOptions kernel_options(const KernelFlags& flags) {
  kernel::KernelOptions options;
  options.charge = flags.charge;
  options.sandbox = flags.insecure_sandbox ? kernel::KernelOptions::Sandbox::Insecure
                                           : kernel::KernelOptions::Sandbox::Strict;
  options.service_dir = service_dir();
  options.repo_root = REJUV_SOURCE_DIR;
  options.seed = flags.seed;
  if (flags.domain) options.dds_domain = static_cast<std::uint32_t>(*flags.domain);
  if (flags.net_port) options.network_port = static_cast<std::uint16_t>(*flags.net_port);
  return options;
}

Result<std::optional<sys::DdsDomainLease>, std::string> lease_domain(kernel::KernelOptions& options) {
  if (options.dds_domain) return std::optional<sys::DdsDomainLease>{};
  auto lease = sys::lease_dds_domain_for_worker(0);
  if (!lease) return fail("no free DDS domain to lease (" + lease.error().to_string() + "): give --domain N");
  options.dds_domain = static_cast<std::uint32_t>(lease->slot());
  return std::optional<sys::DdsDomainLease>(std::move(*lease));
}

Result<void, std::string> open_outputs(std::string_view command, const std::optional<std::filesystem::path>& json_path,
                                       const std::optional<std::filesystem::path>& csv_path, UniqueFile& json_file,
                                       UniqueFile& csv_file) {
  for (auto [path, file, flag] : {std::tuple{&json_path, &json_file, "--summary-json"}, std::tuple{&csv_path, &csv_file, "--csv"}}) {
    if (!*path) continue;
    file->reset(std::fopen((*path)->c_str(), "w"));
    if (!*file) return fail(std::string(command) + ": cannot write " + flag + " file '" + (*path)->string() + "'");
  }
  return {};
}

std::filesystem::path service_dir() {
  if (const char* env = std::getenv("REJUV_SERVICE_DIR"); env != nullptr && *env != '\0') return env;
  return REJUV_SERVICE_DIR;
}

}  // namespace rejuv::cli
