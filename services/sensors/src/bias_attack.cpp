#include "rejuv/services/sensors/imu_combiner.hpp"

#if defined(REJUV_ATTACK_HOOKS)

#include <memory>

#include "rejuv/attacks/hooks.hpp"
#include "rejuv/sdk/service.hpp"

namespace rejuv::services {

bool arm_library_attack(sdk::Service& svc, ImuCombiner& combiner) {
  auto plan = attacks::law_attack_of(svc, {flight::AttackLaw::SensorBias});
  if (!svc.require(plan, "bad attack params")) return false;
  if (!*plan) return arm_replay_attack(svc, combiner);  // one hook: SENSOR_BIAS or a replay attack
  auto window = std::make_shared<attacks::LawWindow>(**plan);
  combiner.set_attack_hook([&svc, window](rejuv_msg_SensorCombined& m) {
    if (!attacks::law_tau(*window, svc)) return;
    const Eigen::Vector3d bias = flight::gyro_bias(window->attack().magnitude);
    for (int i = 0; i < 3; ++i) m.omega_B_rad_s[i] += bias[i];
  });
  return true;
}

}  // namespace rejuv::services

#endif  // REJUV_ATTACK_HOOKS
