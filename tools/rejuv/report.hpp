// What `rejuv sim` and `rejuv run` write the same way: the run summary as JSON, the time-series CSV (one
// column layout for both, so a runtime trace and a model trace plot and compare alike) and short mode names.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "rejuv/core/vocabulary.hpp"
#include "rejuv/flight/sr_sim.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "summary.pb.h"

namespace rejuv::cli {

// p50, max and count of `values` (empty: all zero).
void fill_percentiles(proto::Percentiles& out, std::vector<double> values);
// The same of the kernel's bounded durations: count and max exact, p50 of the kept sample.
void fill_percentiles(proto::Percentiles& out, const kernel::DurationSamples& samples);

// Where the checkpoints' and rollbacks' time went (their phases) and how the images were made.
void fill_image_phases(proto::ImagePhases& out, const kernel::SrStats& sr);

// Two-letter mode names for progress lines and the CSV (UPDATE is "UP").
[[nodiscard]] const char* mode_name(SrMode mode);

// A record (the run summary, a fault campaign) as JSON with the proto field names kept ("max_V", not "maxV":
// the names docs and scripts use) and every field printed.
[[nodiscard]] std::string to_json(const google::protobuf::Message& record);

// The network gate's counters into the summary, and as one line of the text summary.
void fill_network(proto::NetworkSummary& out, const kernel::NetStats& stats, std::optional<std::uint16_t> port);
[[nodiscard]] std::string describe_network(const proto::NetworkSummary& network);

// The trace CSV: t, x (12), x̂ (12), x_sp (position, yaw), mode, u (4), V, ‖x − x̂‖²_P.
void write_trace_header(std::FILE* csv);
void write_trace_row(std::FILE* csv, const flight::TraceRow& row);

}  // namespace rejuv::cli
