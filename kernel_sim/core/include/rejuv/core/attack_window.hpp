// When a windowed attack of the launch plan acts (docs/design.md §9; idl/launch.proto Attack: start_s, max_windows),
// decided from what the kernel's time page shows (the time, the SR mode, the rollback epoch). One rule for
// every hook that carries an attack out (services/attacks, the SDK's CUSTOM hook rejuv/sdk/attack_hook.hpp)
// and for the run summary that counts them by kind (tools/rejuv), so that what is counted is what was meant.
//
// A window is keyed by the rollback epoch: every epoch has one secure interval (RB…CP) followed by one MC
// window, so "the first call in epoch e while in MC" is the start of the MC window of e — also in a restored
// image, whose memory is that of the checkpoint. The first attacked epoch is fixed in the secure interval (so
// it is in every later checkpoint): the first one whose secure interval is seen at or after `start`. With SR
// off there is one endless MC window, attacked once from `start` on.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rejuv/core/ids.hpp"
#include "rejuv/core/result.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/core/vocabulary.hpp"

namespace rejuv {

// The windows an attack acts in: MC windows, or (NETWORK_IN_SEI) the secure intervals.
enum class AttackWindowKind : std::uint8_t { MissionControl, SecureInterval };

// Whether the graph rejuvenates (sr.enabled, boot param; `rejuv run --no-sr` turns it off).
enum class Rejuvenation : std::uint8_t { On, Off };

// One attack's windows as the plan gives them.
struct AttackSchedule {
  Nanos start{0};                 // first window that starts at or after this kernel time
  std::uint32_t max_windows = 0;  // 0 = every window
  AttackWindowKind window = AttackWindowKind::MissionControl;
  Rejuvenation sr = Rejuvenation::On;
};

// Decides, call by call, whether a window of the schedule starts now and is to be attacked. Called with the
// time page's reading at least once in every secure interval and every window (a hook's timer, a kernel
// observer's step).
class AttackWindowClock {
 public:
  explicit AttackWindowClock(const AttackSchedule& schedule) : schedule_(schedule) {}
  // True exactly once, at the first call of a window that is to be attacked.
  [[nodiscard]] bool begins(Nanos now, SrMode mode, Epoch epoch);
  // True while the window last begun is still open at (mode, epoch): the same epoch and the same kind of
  // interval with SR; from its start on without SR (the one window never ends).
  [[nodiscard]] bool open(SrMode mode, Epoch epoch) const;
  // Ordinal of the window last attacked (0 = the first), e.g. to vary an attack from window to window.
  [[nodiscard]] std::uint32_t ordinal() const { return ordinal_; }
  [[nodiscard]] const AttackSchedule& schedule() const { return schedule_; }

 private:
  AttackSchedule schedule_;
  std::optional<std::uint32_t> first_epoch_{};
  std::optional<std::uint32_t> window_epoch_{};    // the epoch whose window of our kind was last seen
  std::optional<std::uint32_t> attacked_epoch_{};  // the epoch of the window last begun (attacked)
  std::uint32_t ordinal_ = 0;
  bool attacked_without_sr_ = false;
};

// ---- The plan as a service reads it: its boot params (rejuv/sdk/service.hpp "Params") ----
//
// sr.enabled, attack.enabled, attack.count and, per attack j, attack.<j>.kind (text), .start_s, .max_windows and
// .magnitude. One reader for every hook that acts on the plan (services/attacks, the SDK's CUSTOM hook), so that
// they agree on what a plan says and on what is malformed.

// A malformed attack param: which one and what was expected.
struct AttackParamError {
  std::string param{};
  std::string message{};
  [[nodiscard]] std::string to_string() const { return param + ": " + message; }
};

// Param lookups (the SDK's param/text_param, or a map in tests): nullopt / "" when absent.
using NumberLookup = std::function<std::optional<double>(std::string_view)>;
using TextLookup = std::function<std::string(std::string_view)>;

// One attack of the plan, whatever its kind; each kind reads its magnitude by its own rule.
struct BootAttack {
  std::string kind;              // the AttackKind name (idl/launch.proto)
  std::string prefix;            // "attack.<j>.": the params it was read from
  Seconds start{0};              // kernel time (the kernel has added the pre-flight alignment)
  std::uint32_t max_windows = 0;  // 0 = every window
  std::optional<double> magnitude{};
};

struct BootAttackPlan {
  Rejuvenation sr = Rejuvenation::On;
  bool enabled = false;  // attack.enabled: the plan is on and names this service
  std::vector<BootAttack> attacks{};
};

// A whole number in [0, max]; absent = 0.
[[nodiscard]] Result<std::uint32_t, AttackParamError> whole_param(const NumberLookup& number, const std::string& name,
                                                                   double max);

// The plan of the boot params. An attack count or a max_windows that is not a whole number, or a negative or
// non-finite start, is an error (bad input never aborts, docs/conventions.md).
[[nodiscard]] Result<BootAttackPlan, AttackParamError> boot_attack_plan(const NumberLookup& number,
                                                                        const TextLookup& text);

}  // namespace rejuv
