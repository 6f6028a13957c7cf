#include "rejuv/flight/sr_kernel_model.hpp"

namespace rejuv::flight {

std::string to_string(TimerError error) {
  switch (error) {
    case TimerError::AlreadyArmedThisEpoch: return "the rejuvenation timer was already armed in this epoch";
    case TimerError::BadDuration: return "timer duration must be positive";
  }
  return "unknown timer error";
}

Result<void, TimerError> RejuvenationTimer::arm(Epoch epoch, Nanos now, Nanos after) {
  if (after <= Nanos{0}) return fail(TimerError::BadDuration);
  if (armed_in_ == epoch) {
    ++refused_;
    return fail(TimerError::AlreadyArmedThisEpoch);
  }
  armed_in_ = epoch;
  deadline_ = now + after;
  return {};
}

bool RejuvenationTimer::fire_if_due(Nanos now) {
  if (!deadline_ || now < *deadline_) return false;
  deadline_.reset();
  return true;
}

}  // namespace rejuv::flight
