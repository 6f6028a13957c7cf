// The scheduling policy Cyclone's threads start with. Private to rejuv_dds, beside event_fd.hpp: the one
// other OS call of the DDS bridge (kernel_sim/sys has no scheduling calls).
#pragma once

namespace rejuv::dds::detail {

// While alive, the calling thread runs SCHED_BATCH (nice unchanged), so threads it creates inherit it; the
// destructor restores the previous policy. Failure (a policy this thread may not leave) changes nothing.
class BatchPolicyScope {
 public:
  BatchPolicyScope();
  ~BatchPolicyScope();
  BatchPolicyScope(const BatchPolicyScope&) = delete;
  BatchPolicyScope& operator=(const BatchPolicyScope&) = delete;

 private:
  int previous_ = -1;  // the policy to restore; -1: nothing was changed
};

}  // namespace rejuv::dds::detail
