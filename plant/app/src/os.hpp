// The one OS call of the plant process that kernel_sim/sys does not offer: an absolute sleep on
// CLOCK_MONOTONIC (clock_nanosleep, TIMER_ABSTIME), the realtime clock mode's pacing (docs/design.md §6).
#pragma once

#include "rejuv/core/time.hpp"

namespace rejuv::plant_app::os {

// Sleeps until CLOCK_MONOTONIC reaches `monotonic_deadline` (sys::monotonic_now()'s clock); returns at once
// when it already has. EINTR resumes the sleep.
void sleep_until(Nanos monotonic_deadline);

}  // namespace rejuv::plant_app::os
