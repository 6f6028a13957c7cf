// The options more than one `rejuv` command takes, declared once on the typed option layer (args.hpp) with one
// help text, range and default: the kernel's (--seed, --domain, --net-port, --charge, --insecure-sandbox: run,
// soak, faults, report), the attack kind (run, sim, report) and the files of a flight (--out, --trace,
// --no-figures: run, sim). Also where the service executables are found.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "args.hpp"
#include "figure_data.hpp"
#include "rejuv/flight/attack_library.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/sys/lease.hpp"
#include "run_summary.hpp"

namespace rejuv::cli {

using Charge = kernel::KernelOptions::Charge;  // its name: to_string (run_summary.hpp)

// --seed N: the seed of the plant and the services (or the model's noise), default the graph's.
Options& seed_option(Options& o, std::optional<std::uint64_t>& out, std::string help);
// --domain N: a DDS domain id, 0..launch::defaults::kMaxDdsDomainId.
Options& domain_option(Options& o, std::optional<std::uint64_t>& out, std::string help, std::string unset);
// --net-port P: the network gate's UDP port, 0..65535 (0: any free port).
Options& net_port_option(Options& o, std::optional<std::uint64_t>& out, std::string help, std::string unset);
// --charge model|measured (docs/design.md §6): what a lockstep run charges to simulated time per checkpoint and rollback.
Options& charge_option(Options& o, Charge& out, std::string_view why = "");
// --attack KIND (attack_option.hpp): the kind of the plan's first attack.
Options& attack_option(Options& o, std::optional<flight::AttackLaw>& out);

// --no-sr, --no-attack and --attack KIND of `rejuv run` and `rejuv sim`: what of the graph's SR and attack plan flies.
struct FlightSwitches {
  bool no_sr = false;
  bool no_attack = false;
  std::optional<flight::AttackLaw> attack{};
};
Options& flight_options(Options& o, FlightSwitches& out, std::string no_sr_help);

// --out DIR, --trace compact|full, --no-figures of `rejuv run` and `rejuv sim` (figures.hpp).
struct OutFlags {
  std::optional<std::filesystem::path> dir{};
  TraceDetail trace = TraceDetail::Compact;
  bool no_figures = false;
};
Options& out_options(Options& o, OutFlags& out);
// --trace and --no-figures describe --out's files: refused without it.
[[nodiscard]] Result<void, std::string> check_out_options(const Options& o, const OutFlags& out);

// The kernel's options of a flying command (run, soak).
struct KernelFlags {
  std::optional<std::uint64_t> seed{}, domain{}, net_port{};
  Charge charge = Charge::Model;
  bool insecure_sandbox = false;
};
// KernelOptions from the flags: seed, domain, port, charge, sandbox, where the services and the repository are.
[[nodiscard]] kernel::KernelOptions kernel_options(const KernelFlags& flags);
// Without --domain (options.dds_domain unset): a free DDS domain leased for as long as the lease is held, set in
// `options`, so that two runs on one machine do not share a domain's discovery traffic (each run's partition keeps
// them apart on one domain: rejuv/dds/run_partition.hpp). With --domain: nothing leased, that domain used.
[[nodiscard]] Result<std::optional<sys::DdsDomainLease>, std::string> lease_domain(kernel::KernelOptions& options);
inline constexpr const char* kLeasedDomainHelp = "a free one, leased for the run";

// A file closed when it goes.
struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using UniqueFile = std::unique_ptr<std::FILE, FileCloser>;
// Opens --summary-json and --csv (those given) before a long run, so that a bad path fails fast.
[[nodiscard]] Result<void, std::string> open_outputs(std::string_view command,
                                                     const std::optional<std::filesystem::path>& json_path,
                                                     const std::optional<std::filesystem::path>& csv_path,
                                                     UniqueFile& json_file, UniqueFile& csv_file);

// Where the service executables are: $REJUV_SERVICE_DIR, else the build's.
[[nodiscard]] std::filesystem::path service_dir();

}  // namespace rejuv::cli
