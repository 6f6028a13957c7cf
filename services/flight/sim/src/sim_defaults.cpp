#include "rejuv/flight/sim_config.hpp"

namespace rejuv::flight {

ControlDesignSpec control_spec_for(const SimConfig& config) {
  ControlDesignSpec spec = config.control;
  spec.vehicle = VehicleParams{.mass_kg = config.quad.mass_kg,
                               .inertia_diag_kg_m2 = config.quad.inertia_B_kg_m2.diagonal(),
                               .gravity_m_s2 = config.quad.gravity_m_s2,
                               .k1_N = config.quad.max_thrust_per_motor_N,
                               .k2_N_m = config.quad.max_torque_per_motor_N_m,
                               .arm_m = config.quad.arm_length_m};
  spec.control_period = to_seconds(config.sensors.gyro_period);
  return spec;
}

SimConfig SimConfig::defaults() {
  SimConfig c;
  // §VI-C: a 1 m square in the x–y plane at 3 m altitude (NED: z = −3), starting and ending at the origin.
  c.waypoints = {{{0, 0, -3}, 0}, {{1, 0, -3}, 0}, {{1, 1, -3}, 0}, {{0, 1, -3}, 0}, {{0, 0, -3}, 0}};
  return c;
}

}  // namespace rejuv::flight
