#include "thread_policy.hpp"

#include <sched.h>

namespace rejuv::dds::detail {

BatchPolicyScope::BatchPolicyScope() {
  const int current = ::sched_getscheduler(0);
  if (current != SCHED_OTHER) return;  // real-time or already batch: leave it alone
  const sched_param param{};
  if (::sched_setscheduler(0, SCHED_BATCH, &param) == 0) previous_ = current;
}

BatchPolicyScope::~BatchPolicyScope() {
  if (previous_ < 0) return;
  const sched_param param{};
  (void)::sched_setscheduler(0, previous_, &param);
}

}  // namespace rejuv::dds::detail
