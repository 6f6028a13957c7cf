#include "os.hpp"

#include <time.h>

#include <cerrno>

namespace rejuv::plant_app::os {

void sleep_until(Nanos monotonic_deadline) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(monotonic_deadline.count() / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(monotonic_deadline.count() % 1'000'000'000);
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace rejuv::plant_app::os
