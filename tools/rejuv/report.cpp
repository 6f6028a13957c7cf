#include "report.hpp"

#include "rejuv/mavlink/frame.hpp"
#include "rejuv/mavlink/messages.hpp"

#include <google/protobuf/util/json_util.h>

#include <algorithm>

#include "args.hpp"

namespace rejuv::cli {

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

void fill_percentiles(proto::Percentiles& out, std::vector<double> values) {
  out.set_count(values.size());
  if (values.empty()) return;
  std::sort(values.begin(), values.end());
  out.set_p50(values[values.size() / 2]);
  out.set_p99(values[std::min(values.size() - 1, values.size() * 99 / 100)]);
  out.set_max(values.back());
}

void fill_percentiles(proto::Percentiles& out, const kernel::DurationSamples& samples) {
  const std::span<const double> kept = samples.values();
  fill_percentiles(out, std::vector<double>(kept.begin(), kept.end()));
  out.set_count(samples.count());
  out.set_max(samples.max());
}

void fill_image_phases(proto::ImagePhases& out, const kernel::SrStats& sr) {
  fill_percentiles(*out.mutable_checkpoint_snapshot(), sr.checkpoint_phases.a);
  fill_percentiles(*out.mutable_checkpoint_taken(), sr.checkpoint_phases.b);
  fill_percentiles(*out.mutable_checkpoint_save(), sr.checkpoint_phases.c);
  fill_percentiles(*out.mutable_rollback_kill(), sr.rollback_phases.a);
  fill_percentiles(*out.mutable_rollback_resume(), sr.rollback_phases.b);
  fill_percentiles(*out.mutable_rollback_restore(), sr.rollback_phases.c);
  out.set_images_by_pages(sr.images_by_pages);
  out.set_images_by_fork(sr.images_by_fork);
}

std::string to_json(const google::protobuf::Message& record) {
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  options.add_whitespace = true;
  std::string out;
  (void)google::protobuf::util::MessageToJsonString(record, &out, options);
  while (!out.empty() && out.back() == '\n') out.pop_back();
  return out;
}

void fill_network(proto::NetworkSummary& out, const kernel::NetStats& s, std::optional<std::uint16_t> port) {
  out.set_port(port.value_or(0));
  out.set_received(s.received);
  out.set_relayed(s.relayed);
  out.set_dropped_secure_interval(s.dropped_secure_interval);
  out.set_dropped_oversize(s.dropped_oversize);
  out.set_dropped_other(s.dropped_empty + s.dropped_no_receiver + s.dropped_busy);
  out.set_sent(s.sent);
  out.set_send_refused(s.send_refused);
  out.set_unsent_no_ground(s.unsent_no_ground);
  out.set_link_valid(s.judged_valid);
  out.set_link_refused(s.judged_refused);
  // ext_link's verdict code is 1 + mavlink::DecodeError (services/ext_link/main.cpp).
  for (std::size_t code = 1; code < s.refused_by_reason.size(); ++code) {
    if (s.refused_by_reason[code] == 0) continue;
    proto::LinkRefusals* r = out.add_link_refused_by_reason();
    r->set_reason(code - 1 < mavlink::kDecodeErrorCount
                      ? std::string(mavlink::to_string(static_cast<mavlink::DecodeError>(code - 1)))
                      : "reason " + std::to_string(code));
    r->set_count(s.refused_by_reason[code]);
  }
  out.set_signing(s.signing);
  out.set_signing_refused(s.signing_refused);
  for (std::size_t why = 0; why < s.signing_refused_by_reason.size(); ++why) {
    if (s.signing_refused_by_reason[why] == 0) continue;
    proto::LinkRefusals* r = out.add_signing_refused_by_reason();
    r->set_reason(std::string(mavlink::to_string(static_cast<mavlink::SigningRefusal>(why))));
    r->set_count(s.signing_refused_by_reason[why]);
  }
}

std::string describe_network(const proto::NetworkSummary& n) {
  if (n.port() == 0) return "off";
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "udp %u: %llu received, %llu relayed, dropped %llu in the SEI, %llu oversize, %llu other; %llu sent, "
                "%llu refused, %llu with no ground station",
                n.port(), static_cast<unsigned long long>(n.received()), static_cast<unsigned long long>(n.relayed()),
                static_cast<unsigned long long>(n.dropped_secure_interval()),
                static_cast<unsigned long long>(n.dropped_oversize()), static_cast<unsigned long long>(n.dropped_other()),
                static_cast<unsigned long long>(n.sent()), static_cast<unsigned long long>(n.send_refused()),
                static_cast<unsigned long long>(n.unsent_no_ground()));
  std::string out = buf;
  std::snprintf(buf, sizeof buf, "; ext_link: %llu valid, %llu refused", static_cast<unsigned long long>(n.link_valid()),
                static_cast<unsigned long long>(n.link_refused()));
  out += buf;
  for (const proto::LinkRefusals& r : n.link_refused_by_reason()) {
    out += (&r == &n.link_refused_by_reason(0) ? " (" : ", ") + r.reason() + " " + std::to_string(r.count());
  }
  if (n.link_refused_by_reason_size() > 0) out += ")";
  if (n.signing()) {
    out += "; signing: " + std::to_string(n.signing_refused()) + " refused";
    for (const proto::LinkRefusals& r : n.signing_refused_by_reason()) {
      out += (&r == &n.signing_refused_by_reason(0) ? " (" : ", ") + r.reason() + " " + std::to_string(r.count());
    }
    if (n.signing_refused_by_reason_size() > 0) out += ")";
  }
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
  std::fputs(",sp_n_m,sp_e_m,sp_d_m,sp_yaw_rad,mode,F_N,tau_phi_N_m,tau_theta_N_m,tau_psi_N_m,V,est_err_P\n", csv);
}

void write_trace_row(std::FILE* csv, const flight::TraceRow& r) {
  std::fprintf(csv, "%.3f", to_seconds(r.t).count());
  for (const flight::StateVec* v : {&r.x, &r.x_hat}) {
    for (Eigen::Index i = 0; i < flight::kStateDim; ++i) std::fprintf(csv, ",%.6g", (*v)[i]);
  }
  std::fprintf(csv, ",%.6g,%.6g,%.6g,%.6g,%s", r.x_sp[0], r.x_sp[1], r.x_sp[2], r.x_sp[flight::idx::kYaw],
               mode_name(r.mode));
  for (Eigen::Index j = 0; j < flight::kInputDim; ++j) std::fprintf(csv, ",%.6g", r.u[j]);
  std::fprintf(csv, ",%.6g,%.6g\n", r.V, r.est_err);
}

}  // namespace rejuv::cli
