#include "rejuv/flight/attack_library.hpp"

#include <cctype>
#include <string>

#include <Eigen/Eigenvalues>

namespace rejuv::flight {

namespace {

struct LawInfo {
  AttackLaw law;
  std::string_view name;
  int number;
  std::string_view service;
  double magnitude;
};

// One table: names and numbers of idl/launch.proto AttackKind, the reference graph's service, the default size.
constexpr std::array<LawInfo, kAllAttackLaws.size()> kLaws{{
    {AttackLaw::WorstCaseControl, "WORST_CASE_CONTROL", 1, "lqr_control", 0.0},
    {AttackLaw::EstimateShift, "ESTIMATE_SHIFT", 13, "ekf2", 2.0},
    {AttackLaw::SensorBias, "SENSOR_BIAS", 14, "sensors", 0.05},
    {AttackLaw::SetpointShift, "SETPOINT_SHIFT", 15, "gen_set_point", 0.5},
    {AttackLaw::GainOverwrite, "GAIN_OVERWRITE", 16, "lqr_control", 1.0},
    {AttackLaw::EstimateDrift, "ESTIMATE_DRIFT", 17, "ekf2", 0.2},
}};

const LawInfo& info(AttackLaw law) {
  for (const LawInfo& i : kLaws) {
    if (i.law == law) return i;
  }
  REJUV_ASSERT(false, "every AttackLaw is in the table");
  return kLaws[0];
}

}  // namespace

std::string_view to_string(AttackLaw law) { return info(law).name; }
int proto_number(AttackLaw law) { return info(law).number; }
std::string_view default_service(AttackLaw law) { return info(law).service; }
double default_magnitude(AttackLaw law) { return info(law).magnitude; }
double effective_magnitude(AttackLaw law, double magnitude) {
  return magnitude > 0.0 ? magnitude : default_magnitude(law);
}

std::optional<AttackLaw> attack_law_from_name(std::string_view name) {
  for (const LawInfo& i : kLaws) {
    if (i.name == name) return i.law;
  }
  return std::nullopt;
}

std::optional<AttackLaw> attack_law_from_number(int number) {
  for (const LawInfo& i : kLaws) {
    if (i.number == number) return i.law;
  }
  return std::nullopt;
}

std::optional<AttackLaw> attack_law_from_name_icase(std::string_view name) {
  std::string upper(name);
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return attack_law_from_name(upper);
}

std::string attack_law_names() {
  std::string out;
  for (const LawInfo& i : kLaws) {
    if (!out.empty()) out += ", ";
    out += i.name;
  }
  return out;
}

StateVec fdi_direction(const ControlDesign& design) {
  const StateMat& P = design.ellipsoid.P();
  const Eigen::Matrix<double, kStateDim, kStateDim> BK = design.continuous.B * design.mission.K();
  const StateMat M = BK.transpose() * P * BK;
  // M d = λ P d, eigenvectors normalised to dᵀ P d = 1, eigenvalues ascending: the last is the fastest.
  const Eigen::GeneralizedSelfAdjointEigenSolver<StateMat> solver(0.5 * (M + M.transpose()), P);
  StateVec d = solver.eigenvectors().col(kStateDim - 1);
  Eigen::Index largest = 0;
  (void)d.cwiseAbs().maxCoeff(&largest);
  if (d[largest] < 0.0) d = -d;
  return d;
}

StateVec estimate_offset(AttackLaw law, const StateVec& direction, double magnitude, Seconds tau) {
  switch (law) {
    case AttackLaw::EstimateShift: return magnitude * direction;
    case AttackLaw::EstimateDrift: return magnitude * tau.count() * direction;
    case AttackLaw::WorstCaseControl:
    case AttackLaw::SensorBias:
    case AttackLaw::SetpointShift:
    case AttackLaw::GainOverwrite: break;
  }
  return StateVec::Zero();
}

Eigen::Vector3d gyro_bias(double magnitude) { return Eigen::Vector3d(magnitude, 0.0, 0.0); }

StateVec setpoint_offset(double rate_m_s, Seconds tau) {
  StateVec offset = StateVec::Zero();
  offset[idx::kPos + 2] = rate_m_s * tau.count();  // NED: +z is down
  return offset;
}

GainMat overwritten_gain(const GainMat& K, double magnitude) { return -magnitude * K; }

}  // namespace rejuv::flight
