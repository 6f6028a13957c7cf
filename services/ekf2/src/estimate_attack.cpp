#include "rejuv/services/ekf2/ekf2_node.hpp"

#if defined(REJUV_ATTACK_HOOKS)

#include <memory>

#include "rejuv/sdk/service.hpp"

#include "rejuv/attacks/hooks.hpp"
#include "rejuv/flight_io/sdk_params.hpp"

namespace rejuv::services {

void shift_estimate(rejuv_msg_VehicleStateEstimate& m, const flight::StateVec& offset) {
  for (int i = 0; i < 3; ++i) {
    m.p_N_m[i] += offset[flight::idx::kPos + i];
    m.v_N_m_s[i] += offset[flight::idx::kVel + i];
    m.omega_B_rad_s[i] += offset[flight::idx::kRate + i];
  }
  const Eigen::Vector3d euler =
      flight::euler_from_quaternion(Eigen::Quaterniond(m.q_NB[0], m.q_NB[1], m.q_NB[2], m.q_NB[3])) +
      offset.segment<3>(flight::idx::kAtt);
  const Eigen::Quaterniond q = Eigen::AngleAxisd(euler[2], Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(euler[1], Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(euler[0], Eigen::Vector3d::UnitX());
  m.q_NB[0] = q.w();
  m.q_NB[1] = q.x();
  m.q_NB[2] = q.y();
  m.q_NB[3] = q.z();
}

bool arm_library_attack(sdk::Service& svc, Ekf2Node& node) {
  auto plan = attacks::law_attack_of(svc, {flight::AttackLaw::EstimateShift, flight::AttackLaw::EstimateDrift});
  if (!svc.require(plan, "bad attack params")) return false;
  if (!*plan) return true;
  auto design = flight_io::control_design(flight_io::params_of(svc));
  if (!svc.require(design, "bad params")) return false;
  // The attacker's memory: its window and the direction (the honest controller's fastest way out).
  auto window = std::make_shared<attacks::LawWindow>(**plan);
  const flight::StateVec direction = flight::fdi_direction(*design);
  node.set_attack_hook([&svc, window, direction](rejuv_msg_VehicleStateEstimate& m) {
    const auto tau = attacks::law_tau(*window, svc);
    if (!tau) return;
    const attacks::LawAttack& a = window->attack();
    shift_estimate(m, flight::estimate_offset(a.law, direction, a.magnitude, *tau));
  });
  return true;
}

}  // namespace rejuv::services

#endif  // REJUV_ATTACK_HOOKS
