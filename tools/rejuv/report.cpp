#include "report.hpp"

#include <google/protobuf/util/json_util.h>

#include "args.hpp"

namespace rejuv::cli {

int bad_input(const std::string& message) {
  std::fprintf(stderr, "%s\n", message.c_str());
  return static_cast<int>(Exit::BadInput);
}

const char* mode_name(SrMode mode) {
  switch (mode) {
    case SrMode::MC: return "MC";
    case SrMode::RB: return "RB";
    case SrMode::SC: return "SC";
    case SrMode::Update: return "UP";
    case SrMode::CP: return "CP";
  }
  return "?";
}

std::string to_json(const proto::RunSummary& summary) {
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  options.add_whitespace = true;
  std::string out;
  (void)google::protobuf::util::MessageToJsonString(summary, &out, options);
  while (!out.empty() && out.back() == '\n') out.pop_back();
  return out;
}

void write_trace_header(std::FILE* csv) {
  std::fputs("t_s", csv);
  for (const char* prefix : {"", "hat_"}) {
    for (const char* name : {"n_m", "e_m", "d_m", "vn_m_s", "ve_m_s", "vd_m_s", "roll_rad", "pitch_rad",
                             "yaw_rad", "p_rad_s", "q_rad_s", "r_rad_s"}) {
      std::fprintf(csv, ",%s%s", prefix, name);
    }
  }
  std::fputs(",sp_n_m,sp_e_m,sp_d_m,sp_yaw_rad,mode,F_N,tau_phi_N_m,tau_theta_N_m,tau_psi_N_m,V\n", csv);
}

void write_trace_row(std::FILE* csv, const flight::TraceRow& r) {
  std::fprintf(csv, "%.3f", to_seconds(r.t).count());
  for (const flight::StateVec* v : {&r.x, &r.x_hat}) {
    for (Eigen::Index i = 0; i < flight::kStateDim; ++i) std::fprintf(csv, ",%.6g", (*v)[i]);
  }
  std::fprintf(csv, ",%.6g,%.6g,%.6g,%.6g,%s", r.x_sp[0], r.x_sp[1], r.x_sp[2], r.x_sp[flight::idx::kYaw],
               mode_name(r.mode));
  for (Eigen::Index j = 0; j < flight::kInputDim; ++j) std::fprintf(csv, ",%.6g", r.u[j]);
  std::fprintf(csv, ",%.6g\n", r.V);
}

}  // namespace rejuv::cli
