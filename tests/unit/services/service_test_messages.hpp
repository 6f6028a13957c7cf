// Message builders shared by the SR services' tests (lqr_control, safety_control, checkpoint_p and the
// lqr_control attack).
#pragma once

#include <Eigen/Geometry>

#include "rejuv/flight/hover_model.hpp"
#include "rejuv/flight_io/messages.hpp"

namespace rejuv::services::testing {

// vehicle_state carrying x (euler angles → quaternion, as the estimator forms it).
inline rejuv_msg_VehicleStateEstimate state_message(const flight::StateVec& x, Nanos t) {
  rejuv_msg_VehicleStateEstimate m{};
  m.timestamp_ns = flight_io::stamp(t);
  const Eigen::Vector3d euler = x.segment<3>(flight::idx::kAtt);
  const Eigen::Quaterniond q = Eigen::AngleAxisd(euler.z(), Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(euler.y(), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(euler.x(), Eigen::Vector3d::UnitX());
  for (int i = 0; i < 3; ++i) {
    m.p_N_m[i] = x[flight::idx::kPos + i];
    m.v_N_m_s[i] = x[flight::idx::kVel + i];
    m.omega_B_rad_s[i] = x[flight::idx::kRate + i];
  }
  m.q_NB[0] = q.w();
  m.q_NB[1] = q.x();
  m.q_NB[2] = q.y();
  m.q_NB[3] = q.z();
  return m;
}

}  // namespace rejuv::services::testing
