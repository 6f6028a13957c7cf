// Sensor samples as the plant's sensor models produce them and the estimator consumes them (docs/design.md §9). Kept
// apart from the sensor models so that the estimator depends on the data, not on how it is simulated.
// Frames: N = local NED, B = body FRD. `t` is when the quantity was measured (the sample's timestamp), which
// is earlier than when it is delivered when the sensor has a delay.
#pragma once

#include <Eigen/Core>

#include "rejuv/core/time.hpp"

namespace rejuv::plant {

// Rate gyro: body rate of B in N, expressed in B, with bias and noise, rad/s.
struct GyroSample {
  Nanos t{};
  Eigen::Vector3d omega_B_rad_s = Eigen::Vector3d::Zero();
};

// Accelerometer: specific force f = a − g expressed in B, m/s² (reads (0, 0, −g) when hovering level).
struct AccelSample {
  Nanos t{};
  Eigen::Vector3d f_B_m_s2 = Eigen::Vector3d::Zero();
};

// Magnetometer: Earth's field expressed in B, gauss.
struct MagSample {
  Nanos t{};
  Eigen::Vector3d b_B_gauss = Eigen::Vector3d::Zero();
};

// Barometer: altitude above the local origin (−p_z), m, and the static pressure it corresponds to, Pa.
struct BaroSample {
  Nanos t{};
  double altitude_m = 0;
  double pressure_pa = 0;
};

// GPS, already projected into the local NED frame: position, m; velocity, m/s; and the receiver's reported
// horizontal/vertical position accuracy (1σ), m.
struct GpsSample {
  Nanos t{};
  Eigen::Vector3d p_N_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_N_m_s = Eigen::Vector3d::Zero();
  double eph_m = 0;
  double epv_m = 0;
};

}  // namespace rejuv::plant
