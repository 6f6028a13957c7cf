// `--charge model|measured` (DESIGN §6): what a lockstep run charges to simulated time for a checkpoint or a
// rollback. One parser and one help text for every command that flies the kernel (run, soak, faults).
#pragma once

#include <string>
#include <string_view>

#include "args.hpp"
#include "rejuv/kernel/kernel.hpp"

namespace rejuv::cli {

inline constexpr const char* kChargeHelp =
    "simulated time charged per checkpoint and rollback in lockstep: 'model' (the launch file's\n"
    "lockstep.*_charge_ms; two runs with one seed are identical) or 'measured' (their real durations,\n"
    "for timing studies; the run then depends on the machine)";

[[nodiscard]] inline Result<kernel::KernelOptions::Charge, std::string> to_charge(std::string_view text,
                                                                                 std::string_view option) {
  auto choice = to_choice(text, option, {"model", "measured"});
  if (!choice) return fail(choice.error());
  return *choice == "model" ? kernel::KernelOptions::Charge::Model : kernel::KernelOptions::Charge::Measured;
}

[[nodiscard]] inline std::string_view to_string(kernel::KernelOptions::Charge charge) {
  switch (charge) {
    case kernel::KernelOptions::Charge::Model: return "model";
    case kernel::KernelOptions::Charge::Measured: return "measured";
  }
  return "?";
}

}  // namespace rejuv::cli
