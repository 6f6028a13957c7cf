#include "ulog_recorder.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <cstdio>
#include <cstring>

#include <algorithm>
#include <cmath>

#include "payload.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/ulog/topics.hpp"

namespace rejuv::cli {
namespace {

namespace pb = google::protobuf;

std::uint64_t micros(Nanos t) { return t.count() <= 0 ? 0 : static_cast<std::uint64_t>(t.count()) / 1000; }

// `git describe` of the source tree the binary was built from, when git and the tree are there.
std::string version_of_sources() {
  const std::string cmd = "git -C '" + std::string(REJUV_SOURCE_DIR) + "' describe --always --dirty 2>/dev/null";
  std::FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return "unknown";
  std::array<char, 128> buf{};
  std::string out;
  while (std::fgets(buf.data(), buf.size(), p) != nullptr) out += buf.data();
  const int status = ::pclose(p);
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return status == 0 && !out.empty() ? out : "unknown";
}

// Every set numeric or boolean field of a launch message as a ULog parameter `prefix.field` (nested
// messages as `prefix.field.sub`): floats for numbers, int32 for booleans and enums. Text goes to info.
Result<void, ulog::UlogError> parameters_of(ulog::Encoder& enc, const pb::Message& m, const std::string& prefix) {
  const pb::Reflection* r = m.GetReflection();
  std::vector<const pb::FieldDescriptor*> fields;
  r->ListFields(m, &fields);
  for (const pb::FieldDescriptor* f : fields) {
    if (f->is_repeated()) continue;
    const std::string name = prefix + "." + f->name();
    Result<void, ulog::UlogError> ok{};
    switch (f->cpp_type()) {
      case pb::FieldDescriptor::CPPTYPE_DOUBLE: ok = enc.parameter(name, static_cast<float>(r->GetDouble(m, f))); break;
      case pb::FieldDescriptor::CPPTYPE_FLOAT: ok = enc.parameter(name, r->GetFloat(m, f)); break;
      case pb::FieldDescriptor::CPPTYPE_INT32: ok = enc.parameter(name, r->GetInt32(m, f)); break;
      case pb::FieldDescriptor::CPPTYPE_UINT32: ok = enc.parameter(name, static_cast<std::int32_t>(r->GetUInt32(m, f))); break;
      case pb::FieldDescriptor::CPPTYPE_INT64: ok = enc.parameter(name, static_cast<float>(r->GetInt64(m, f))); break;
      case pb::FieldDescriptor::CPPTYPE_UINT64: ok = enc.parameter(name, static_cast<float>(r->GetUInt64(m, f))); break;
      case pb::FieldDescriptor::CPPTYPE_BOOL: ok = enc.parameter(name, std::int32_t{r->GetBool(m, f) ? 1 : 0}); break;
      case pb::FieldDescriptor::CPPTYPE_ENUM: ok = enc.parameter(name, r->GetEnumValue(m, f)); break;
      case pb::FieldDescriptor::CPPTYPE_STRING: ok = enc.info_string(name, r->GetString(m, f)); break;
      case pb::FieldDescriptor::CPPTYPE_MESSAGE: ok = parameters_of(enc, r->GetMessage(m, f), name); break;
    }
    if (!ok) return ok;
  }
  return {};
}

// A launch Param: a number is a float parameter, text an info string.
Result<void, ulog::UlogError> param(ulog::Encoder& enc, const std::string& owner, const proto::Param& p) {
  const std::string name = owner + "." + p.name();
  if (p.has_text()) return enc.info_string(name, p.text());
  return enc.parameter(name, static_cast<float>(p.number()));
}

// The launch values the run flew with, defaults applied (what a reader cannot reconstruct from the launch file
// alone): the plant's physics and wind, the lockstep charges and alignment, the attack plan, the mission, the
// real-time plan and each service's sandbox limits.
// Numbers as float, counts, switches and enums as int32, names as info strings. The network block is not
// logged (its signing key is a secret).
Result<void, ulog::UlogError> effective_parameters(ulog::Encoder& enc, const proto::Launch& g) {
  const auto number = [&](const std::string& name, double v) { return enc.parameter(name, static_cast<float>(v)); };
  const auto integer = [&](const std::string& name, std::int64_t v) { return enc.parameter(name, static_cast<std::int32_t>(v)); };
  std::vector<Result<void, ulog::UlogError>> done;
  const proto::PlantSpec& plant = g.plant();
  done.push_back(number("plant.physics_rate_hz", launch::physics_rate_hz(plant)));
  done.push_back(number("plant.wind_mean_m_s", plant.wind_mean_m_s()));
  done.push_back(number("plant.wind_toward_deg", plant.wind_toward_deg()));
  done.push_back(number("plant.wind_gust_m_s", plant.wind_gust_m_s()));
  const proto::LockstepTiming& lockstep = g.lockstep();
  done.push_back(number("lockstep.checkpoint_charge_ms", launch::checkpoint_charge(lockstep).count() * 1e3));
  done.push_back(number("lockstep.rollback_charge_ms", launch::rollback_charge(lockstep).count() * 1e3));
  done.push_back(number("lockstep.alignment_s", launch::alignment(lockstep).count()));
  done.push_back(integer("attack.enabled", g.attack().enabled() ? 1 : 0));
  for (int j = 0; j < g.attack().attacks_size(); ++j) {
    const proto::Attack& a = g.attack().attacks(j);
    const std::string at = "attack." + std::to_string(j) + ".";
    done.push_back(integer(at + "kind", a.kind()));
    done.push_back(enc.info_string(at + "kind_name", proto::AttackKind_Name(a.kind())));
    done.push_back(enc.info_string(at + "service", a.service()));
    done.push_back(number(at + "start_s", a.start_s()));
    done.push_back(integer(at + "max_windows", a.max_windows()));
    done.push_back(number(at + "magnitude", a.magnitude()));
  }
  done.push_back(integer("stop_after_attacks", g.stop_after_attacks()));
  const proto::Mission& mission = g.mission();
  done.push_back(integer("mission.waypoints", mission.waypoints_size()));
  done.push_back(number("mission.path_length_m", launch::path_length_m(mission)));
  done.push_back(number("mission.timeout_s", launch::mission_timeout(mission).count()));
  const launch::RealtimeValues rt = launch::realtime_values(g.realtime());
  done.push_back(integer("realtime.enabled", g.realtime().enabled() ? 1 : 0));
  done.push_back(integer("realtime.kernel_priority", rt.kernel_priority));
  done.push_back(integer("realtime.plant_priority", rt.plant_priority));
  done.push_back(integer("realtime.max_rt_time_ms", rt.max_rt_time_ms));
  for (const proto::ServiceSpec& s : g.services()) {  // each service's sandbox limits, the graph's defaults applied
    const launch::SandboxLimitValues v = launch::sandbox_limits(g, s);
    const std::string at = s.name() + ".limits.";
    done.push_back(integer(at + "max_processes", v.max_processes));
    done.push_back(integer(at + "max_memory_mb", v.max_memory_mb));
    done.push_back(integer(at + "max_open_files", v.max_open_files));
    done.push_back(integer(at + "max_cpu_percent", v.max_cpu_percent));
    done.push_back(integer(at + "max_group_memory_mb", v.max_group_memory_mb));
    done.push_back(integer(at + "max_publications_per_s", v.max_publications_per_s));
    done.push_back(integer(s.name() + ".rt_priority", s.rt_priority()));
  }
  for (auto& d : done) {
    if (!d) return d;
  }
  return {};
}

// rejuv_sr_event: the SR events of the kernel (rejuv::SrEvent, core/sr_event.hpp), one message each.
#pragma pack(push, 1)
struct SrEventMessage {
  std::uint64_t timestamp;   // [µs]
  std::uint64_t generation;
  std::uint32_t epoch;
  std::uint8_t kind;         // SrEventKind: 0 mode, 1 handler_run, 2 timer_armed, 3 timer_refused, 4 limits_written,
                             // 5 checkpoint, 6 checkpoint_failed, 7 rollback, 8 cold_restart
  std::uint8_t mode;         // SrMode in force after it: 0 MC, 1 RB, 2 SC, 3 UPDATE, 4 CP
};
#pragma pack(pop)
const ulog::Format kSrEventFormat{.name = "rejuv_sr_event",
                                  .fields = {{.type = "uint64_t", .name = "timestamp"},
                                             {.type = "uint64_t", .name = "generation"},
                                             {.type = "uint32_t", .name = "epoch"},
                                             {.type = "uint8_t", .name = "kind"},
                                             {.type = "uint8_t", .name = "mode"}}};

// PX4's topics, as PX4's logger writes them, so that Flight Review's and PlotJuggler's PX4 layouts find the
// vehicle: from the estimator's x̂ (vehicle_state) vehicle_local_position and vehicle_attitude, from the plant's
// ground truth vehicle_local_position_groundtruth and vehicle_attitude_groundtruth (as PX4 SITL logs them).
// The fields are a subset of PX4's (msg/VehicleLocalPosition.msg, VehicleAttitude.msg) with PX4's names, types
// and units: NED metres and m/s, heading [rad], q = (w, x, y, z) body FRD to NED, std devs eph/epv/evh/evv [m, m/s].
#pragma pack(push, 1)
struct Px4LocalPosition {
  std::uint64_t timestamp;         // [µs] when routed (kernel clock)
  std::uint64_t timestamp_sample;  // [µs] the estimate's own time
  std::uint8_t xy_valid, z_valid, v_xy_valid, v_z_valid;
  float x, y, z, vx, vy, vz, heading, eph, epv, evh, evv;
};
struct Px4Attitude {
  std::uint64_t timestamp;
  std::uint64_t timestamp_sample;
  float q[4];
};
#pragma pack(pop)
ulog::Format px4_local_position_format(std::string name) {
  ulog::Format f{.name = std::move(name), .fields = {{.type = "uint64_t", .name = "timestamp"},
                                                     {.type = "uint64_t", .name = "timestamp_sample"}}};
  for (const char* b : {"xy_valid", "z_valid", "v_xy_valid", "v_z_valid"}) f.fields.push_back({.type = "bool", .name = b});
  for (const char* x : {"x", "y", "z", "vx", "vy", "vz", "heading", "eph", "epv", "evh", "evv"}) {
    f.fields.push_back({.type = "float", .name = x});
  }
  return f;
}
ulog::Format px4_attitude_format(std::string name) {
  return ulog::Format{.name = std::move(name), .fields = {{.type = "uint64_t", .name = "timestamp"},
                                                          {.type = "uint64_t", .name = "timestamp_sample"},
                                                          {.type = "float", .name = "q", .array = 4}}};
}
static_assert(sizeof(Px4LocalPosition) == 16 + 4 + 11 * 4 && sizeof(Px4Attitude) == 16 + 16, "packed as the formats say");

// One pose (position, velocity, attitude, and for an estimate its variances and validity) as the two PX4 messages.
struct Pose {
  const double* p;
  const double* v;
  const double* q;
  const double* var_p = nullptr;
  const double* var_v = nullptr;
  bool valid = true;
  std::uint64_t sample_ns = 0;
};
std::pair<Px4LocalPosition, Px4Attitude> px4_of(const Pose& s, std::uint64_t t_us) {
  const auto f = [](double x) { return static_cast<float>(x); };
  const auto std_of = [&](const double* var, int a, int b) {
    return var == nullptr ? 0.0F : f(std::sqrt(std::max(var[a], var[b])));
  };
  const double w = s.q[0], x = s.q[1], y = s.q[2], z = s.q[3];
  const auto valid = static_cast<std::uint8_t>(s.valid ? 1 : 0);
  Px4LocalPosition lp{.timestamp = t_us, .timestamp_sample = s.sample_ns / 1000,
                      .xy_valid = valid, .z_valid = valid, .v_xy_valid = valid, .v_z_valid = valid,
                      .x = f(s.p[0]), .y = f(s.p[1]), .z = f(s.p[2]), .vx = f(s.v[0]), .vy = f(s.v[1]), .vz = f(s.v[2]),
                      .heading = f(std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))),
                      .eph = std_of(s.var_p, 0, 1), .epv = std_of(s.var_p, 2, 2),
                      .evh = std_of(s.var_v, 0, 1), .evv = std_of(s.var_v, 2, 2)};
  Px4Attitude att{.timestamp = t_us, .timestamp_sample = s.sample_ns / 1000, .q = {f(w), f(x), f(y), f(z)}};
  return {lp, att};
}

std::string with(std::string_view what, ulog::UlogError e) { return std::string(what) + ": " + std::string(ulog::to_string(e)); }

// The file's information (PX4's keys where they exist: sys_name, ver_sw).
Result<void, std::string> write_info(ulog::Encoder& enc, const kernel::Kernel& kernel, const UlogRecorder::RunInfo& info) {
  const proto::Launch& graph = kernel.graph().graph;
  for (const auto& [key, value] : {std::pair<std::string, std::string>{"sys_name", "Rejuv"},
                                   {"ver_sw", version_of_sources()},
                                   {"graph", graph.name()},
                                   {"graph_file", kernel.graph().path.string()},
                                   {"clock", std::string(kernel::to_string(kernel.clock_mode()))},
                                   {"sr", info.sr ? "on" : "off"},
                                   {"attack", info.attack ? "on" : "off"}}) {
    if (auto ok = enc.info_string(key, value); !ok) return fail(with("info " + key, ok.error()));
  }
  if (auto ok = enc.info_u64("seed", info.seed); !ok) return fail(with("info seed", ok.error()));
  return {};
}

// Parameters: the SR parameters, the plant's, every service's.
Result<void, std::string> write_parameters(ulog::Encoder& enc, const proto::Launch& graph) {
  if (auto ok = parameters_of(enc, graph.sr(), "sr"); !ok) return fail(with("sr parameters", ok.error()));
  if (auto ok = effective_parameters(enc, graph); !ok) return fail(with("launch parameters", ok.error()));
  for (const proto::Param& p : graph.plant().params()) {
    if (auto ok = param(enc, "plant", p); !ok) return fail(with("plant parameter " + p.name(), ok.error()));
  }
  for (const proto::ServiceSpec& s : graph.services()) {
    for (const proto::Param& p : s.params()) {
      if (auto ok = param(enc, s.name(), p); !ok) return fail(with(s.name() + " parameter " + p.name(), ok.error()));
    }
  }
  return {};
}

// A format per topic (named after the policy object), and rejuv_sr_event's.
Result<void, std::string> define_topic_formats(ulog::Encoder& enc, const std::vector<kernel::Kernel::TopicInfo>& topics) {
  for (const kernel::Kernel::TopicInfo& t : topics) {
    const ulog::TopicLayout* layout = ulog::find_layout(t.type);
    // A type a service author declared in the policy (docs/writing_a_service.md "A new topic type"): the
    // policy gives its size, not its fields, so its messages are logged as their bytes (`data`), named in
    // the info `type.<topic>` so that a reader can decode them with the author's IDL.
    const ulog::Format format = layout != nullptr ? ulog::topic_format(t.name, *layout) : ulog::raw_format(t.name, t.size);
    if (layout == nullptr) {
      if (auto ok = enc.info_string("type." + std::string(t.name), std::string(t.type)); !ok) {
        return fail(with("info type." + std::string(t.name), ok.error()));
      }
    }
    if (auto ok = enc.format(format); !ok) return fail(with("format " + std::string(t.name), ok.error()));
  }
  if (auto ok = enc.format(kSrEventFormat); !ok) return fail(with("format rejuv_sr_event", ok.error()));
  return {};
}

}  // namespace

std::string_view to_string(UlogProfile profile) {
  switch (profile) {
    case UlogProfile::Default: return "default";
    case UlogProfile::Full: return "full";
  }
  return "?";
}

Result<std::unique_ptr<UlogRecorder>, std::string> UlogRecorder::create(const std::filesystem::path& path,
                                                                        const kernel::Kernel& kernel,
                                                                        const RunInfo& info,
                                                                        const UlogOptions& options) {
  auto file = ulog::FileWriter::create(path, 0);
  if (!file) return fail("cannot write the ULog file '" + path.string() + "'");
  std::unique_ptr<UlogRecorder> rec(new UlogRecorder(std::move(*file), options));
  ulog::Encoder& enc = rec->writer_.encoder();
  const std::vector<kernel::Kernel::TopicInfo> topics = kernel.topics();
  for (std::size_t i = 0; i < kernel.service_count(); ++i) {
    rec->service_names_.push_back(kernel.stats(ServiceId{static_cast<std::uint32_t>(i)}).name);
  }
  if (auto ok = write_info(enc, kernel, info); !ok) return fail(ok.error());
  for (const auto& [key, value] :
       {std::pair<std::string, std::string>{"ulog_profile", std::string(to_string(options.profile))},
        {"ulog_interval_ms", std::to_string(options.interval.count())},
        {"ulog_budget_kb_s", std::to_string(options.budget_bytes_per_s / 1000)}}) {
    if (auto ok = enc.info_string(key, value); !ok) return fail(with("info " + key, ok.error()));
  }
  if (auto ok = write_parameters(enc, kernel.graph().graph); !ok) return fail(ok.error());
  if (auto ok = define_topic_formats(enc, topics); !ok) return fail(ok.error());
  if (auto ok = rec->define_px4_formats(topics); !ok) return fail(ok.error());
  if (auto ok = rec->subscribe(topics); !ok) return fail(ok.error());
  return rec;
}

Result<void, std::string> UlogRecorder::define_px4_formats(const std::vector<kernel::Kernel::TopicInfo>& topics) {
  ulog::Encoder& enc = writer_.encoder();
  const auto taken = [&](std::string_view name) {
    return std::any_of(topics.begin(), topics.end(), [&](const kernel::Kernel::TopicInfo& t) { return t.name == name; });
  };
  for (const auto& [name, type, truth] :
       {std::tuple{"vehicle_state", msgs::TopicTraits<rejuv_msg_VehicleStateEstimate>::name, false},
        std::tuple{"ground_truth", msgs::TopicTraits<rejuv_msg_GroundTruth>::name, true}}) {
    const auto source = std::find_if(topics.begin(), topics.end(), [&](const kernel::Kernel::TopicInfo& t) {
      return t.name == name && t.type == type;
    });
    Px4Topics x{.source = source == topics.end() ? ObjectId{} : source->id, .truth = truth};
    if (source == topics.end() || taken(x.local_position_name()) || taken(x.attitude_name())) continue;
    if (auto ok = enc.format(px4_local_position_format(x.local_position_name())); !ok) {
      return fail(with("format " + x.local_position_name(), ok.error()));
    }
    if (auto ok = enc.format(px4_attitude_format(x.attitude_name())); !ok) return fail(with("format " + x.attitude_name(), ok.error()));
    px4_.push_back(x);
  }
  return {};
}

Result<void, std::string> UlogRecorder::subscribe(const std::vector<kernel::Kernel::TopicInfo>& topics) {
  ulog::Encoder& enc = writer_.encoder();
  for (const kernel::Kernel::TopicInfo& t : topics) {
    const auto id = enc.add_logged(t.name);
    if (!id) return fail(with("subscription " + std::string(t.name), id.error()));
    if (by_object_.size() <= t.id.value()) {
      by_object_.resize(t.id.value() + 1);
      names_.resize(t.id.value() + 1);
      routed_.resize(t.id.value() + 1);
    }
    by_object_[t.id.value()] = *id;
    names_[t.id.value()] = std::string(t.name);
  }
  // Each topic's share of the size budget: the budget over the topics (docs/ulog.md "Size budget").
  const std::uint64_t share =
      std::max<std::uint64_t>(1, options_.budget_bytes_per_s / std::max<std::size_t>(1, topics.size()));
  const auto per_s =
      static_cast<std::uint64_t>(std::chrono::milliseconds{std::chrono::seconds{1}} / options_.interval);
  topic_log_.resize(by_object_.size());
  for (TopicLog& t : topic_log_) {
    t.profile = RateBudget(std::max<std::uint64_t>(per_s, 1), UlogOptions::kProfileBurst);
    t.budget = RateBudget(share, share * static_cast<std::uint64_t>(UlogOptions::kBudgetBurst.count()));
  }
  const auto sr_id = enc.add_logged(kSrEventFormat.name);
  if (!sr_id) return fail(with("subscription rejuv_sr_event", sr_id.error()));
  sr_event_id_ = *sr_id;
  for (Px4Topics& x : px4_) {
    const auto lp = enc.add_logged(x.local_position_name());
    if (!lp) return fail(with("subscription " + x.local_position_name(), lp.error()));
    const auto att = enc.add_logged(x.attitude_name());
    if (!att) return fail(with("subscription " + x.attitude_name(), att.error()));
    x.local_position = *lp;
    x.attitude = *att;
  }
  return {};
}

// A 'D' message: its header (msg_size, msg_type), msg_id, then the payload [bytes].
constexpr std::uint64_t kDataOverhead = 3 + 2;

UlogRecorder::Admit UlogRecorder::admit(std::size_t i, const kernel::Publication& p, std::uint64_t bytes) {
  TopicLog& topic = topic_log_[i];
  if (options_.profile == UlogProfile::Default && !topic.profile.take(p.t)) return Admit::Sampled;
  if (topic.over && topic.budget.refilled(p.t, 50)) {  // back under its share, with room: the episode ends
    say_over_budget(i, p.t, Episode::Ends);
    topic.over = false;
  }
  if (!topic.over && topic.budget.take(p.t, bytes)) return Admit::Write;
  const std::string who = p.publisher && p.publisher->value() < service_names_.size()
                              ? "'" + service_names_[p.publisher->value()] + "'"
                              : std::string("the kernel");
  if (topic.publishers.find(who) == std::string::npos)
    topic.publishers += (topic.publishers.empty() ? "" : ", ") + who;
  if (!topic.over) {
    topic.over = true;
    topic.over_since = p.t;
    topic.over_messages = 0;
    topic.over_bytes = 0;
    say_over_budget(i, p.t, Episode::Begins);
  }
  ++topic.over_messages;
  ++topic.over_total;
  topic.over_bytes += bytes;
  return Admit::OverBudget;
}

// One logged string when a topic's episode over its share begins, one when it ends (or at close): what was
// not written, and who published it. At most one pair per topic per half a budget burst.
void UlogRecorder::say_over_budget(std::size_t i, Nanos t, Episode episode) {
  const TopicLog& topic = topic_log_[i];
  const unsigned long long share_kb_s = topic.budget.per_second() / 1000;
  char text[400];
  if (episode == Episode::Begins) {
    std::snprintf(
        text, sizeof text,
        "ulog: topic '%s' over its share of the log's size budget (%llu kB/s): its messages are not "
        "logged until it is back under it (published by %s)",
        names_[i].c_str(), share_kb_s, topic.publishers.c_str());
  } else {
    std::snprintf(
        text, sizeof text,
        "ulog: topic '%s': %llu message(s), %llu bytes, published by %s from t = %.3f s were not logged "
        "(over its share of the log's size budget, %llu kB/s)",
        names_[i].c_str(), static_cast<unsigned long long>(topic.over_messages),
        static_cast<unsigned long long>(topic.over_bytes), topic.publishers.c_str(),
        to_seconds(topic.over_since).count(), share_kb_s);
  }
  log(ulog::LogLevel::Warning, t, text);
}

void UlogRecorder::on_publication(const kernel::Publication& p) {
  if (p.topic.value() >= by_object_.size() || !by_object_[p.topic.value()]) return;
  const std::size_t i = p.topic.value();
  ++routed_[i];
  last_t_ = std::max(last_t_, p.t);
  std::uint64_t bytes = kDataOverhead + sizeof(std::uint64_t) + p.payload.size();
  for (const Px4Topics& x : px4_) {
    if (x.source == p.topic) bytes += 2 * kDataOverhead + sizeof(Px4LocalPosition) + sizeof(Px4Attitude);
  }
  if (admit(i, p, bytes) != Admit::Write) return;
  ++topic_log_[i].logged;
  const std::uint64_t t = micros(p.t);
  scratch_.resize(sizeof t + p.payload.size());
  std::memcpy(scratch_.data(), &t, sizeof t);
  std::memcpy(scratch_.data() + sizeof t, p.payload.data(), p.payload.size());
  if (auto ok = writer_.encoder().data(*by_object_[p.topic.value()], scratch_); !ok) {
    if (error_.empty()) error_ = with("data of " + std::string(p.name), ok.error());
    return;
  }
  ++data_messages_;
  for (Px4Topics& x : px4_) {
    if (x.source == p.topic) write_px4(x, p);
  }
  writer_.flush_if_large();
}

void UlogRecorder::write_px4(Px4Topics& x, const kernel::Publication& p) {
  Pose pose{};
  rejuv_msg_VehicleStateEstimate est{};
  rejuv_msg_GroundTruth truth{};
  if (x.truth) {
    truth = payload_as<rejuv_msg_GroundTruth>(p.payload);
    pose = Pose{.p = truth.p_N_m, .v = truth.v_N_m_s, .q = truth.q_NB, .sample_ns = truth.timestamp_ns};
  } else {
    est = payload_as<rejuv_msg_VehicleStateEstimate>(p.payload);
    pose = Pose{.p = est.p_N_m, .v = est.v_N_m_s, .q = est.q_NB, .var_p = est.variance_p_m2, .var_v = est.variance_v_m2_s2,
                .valid = (est.flags & 2U) != 0, .sample_ns = est.timestamp_ns};
  }
  const auto [lp, att] = px4_of(pose, micros(p.t));
  for (const auto& [id, bytes] : {std::pair{x.local_position, std::as_bytes(std::span(&lp, 1))},
                                  std::pair{x.attitude, std::as_bytes(std::span(&att, 1))}}) {
    if (auto ok = writer_.encoder().data(id, bytes); !ok) {
      if (error_.empty()) error_ = with("data of PX4's topics from " + std::string(p.name), ok.error());
      return;
    }
    ++data_messages_;
  }
  ++x.written;
}

void UlogRecorder::log(ulog::LogLevel level, Nanos t, std::string_view text) {
  writer_.encoder().log(level, micros(t), text);
  ++logged_strings_;
  writer_.flush_if_large();
}

void UlogRecorder::on_log(const kernel::LogLine& line) {
  ulog::LogLevel level = ulog::LogLevel::Info;
  switch (line.level) {
    case kernel::LogLine::Level::Debug: level = ulog::LogLevel::Debug; break;
    case kernel::LogLine::Level::Info: level = ulog::LogLevel::Info; break;
    case kernel::LogLine::Level::Warning: level = ulog::LogLevel::Warning; break;
    case kernel::LogLine::Level::Error: level = ulog::LogLevel::Error; break;
  }
  std::string text(line.source);
  text += ": ";
  text += line.text;
  log(level, line.t, text);
}

void UlogRecorder::on_sr_event(const SrEvent& e) {
  const SrEventMessage m{.timestamp = micros(e.t),
                         .generation = e.g.value(),
                         .epoch = e.epoch.value(),
                         .kind = static_cast<std::uint8_t>(e.kind),
                         .mode = static_cast<std::uint8_t>(index_of(e.mode))};
  if (auto ok = writer_.encoder().data(sr_event_id_, std::as_bytes(std::span(&m, 1))); !ok) {
    if (error_.empty()) error_ = with("data of rejuv_sr_event", ok.error());
  } else {
    ++data_messages_;
    ++sr_events_;
  }
  char text[160];
  const auto generation = static_cast<unsigned long long>(e.g.value());
  switch (e.kind) {
    case SrEventKind::Mode:
      std::snprintf(text, sizeof text, "sr: mode %s (epoch %u)", std::string(to_string(e.mode)).c_str(), e.epoch.value());
      break;
    case SrEventKind::HandlerRun:
      std::snprintf(text, sizeof text, "sr: handler run (epoch %u)", e.epoch.value());
      break;
    case SrEventKind::TimerArmed:
      std::snprintf(text, sizeof text, "sr: timer armed for %.3f s (epoch %u)", to_seconds(e.span).count(), e.epoch.value());
      break;
    case SrEventKind::TimerRefused:
      std::snprintf(text, sizeof text, "sr: second timer arm in epoch %u refused", e.epoch.value());
      break;
    case SrEventKind::LimitsWritten:
      std::snprintf(text, sizeof text, "sr: restricted limits written (epoch %u)", e.epoch.value());
      break;
    case SrEventKind::Checkpoint:
      std::snprintf(text, sizeof text, "sr: checkpoint generation %llu committed", generation);
      break;
    case SrEventKind::CheckpointFailed:
      std::snprintf(text, sizeof text, "sr: checkpoint generation %llu abandoned", generation);
      break;
    case SrEventKind::Rollback:
      std::snprintf(text, sizeof text, "sr: rollback to generation %llu (epoch %u)", generation, e.epoch.value());
      break;
    case SrEventKind::ColdRestart:
      std::snprintf(text, sizeof text, "sr: cold restart of the rejuvenated services");
      break;
  }
  const bool routine = e.kind == SrEventKind::Mode || e.kind == SrEventKind::Checkpoint ||
                       e.kind == SrEventKind::TimerArmed || e.kind == SrEventKind::LimitsWritten ||
                       e.kind == SrEventKind::HandlerRun;
  log(routine ? ulog::LogLevel::Info : ulog::LogLevel::Notice, e.t, text);
}

void UlogRecorder::fill(proto::UlogSummary& s, std::uint64_t bytes) const {
  s.set_path(writer_.path().string());
  s.set_bytes(bytes);
  s.set_data_messages(data_messages_);
  s.set_logged_strings(logged_strings_);
  s.set_sr_events(sr_events_);
  for (const Px4Topics& x : px4_) {
    (*s.mutable_px4_by_topic())[x.local_position_name()] = x.written;
    (*s.mutable_px4_by_topic())[x.attitude_name()] = x.written;
  }
  for (std::size_t i = 0; i < names_.size(); ++i) {
    if (!by_object_[i]) continue;
    (*s.mutable_routed_by_topic())[names_[i]] = routed_[i];
    (*s.mutable_logged_by_topic())[names_[i]] = topic_log_[i].logged;
    if (topic_log_[i].over_total > 0)
      (*s.mutable_over_budget_by_topic())[names_[i]] = topic_log_[i].over_total;
  }
  s.set_profile(std::string(to_string(options_.profile)));
  s.set_interval_ms(static_cast<double>(options_.interval.count()));
  s.set_budget_kb_s(static_cast<double>(options_.budget_bytes_per_s) / 1000.0);
}

Result<std::uint64_t, std::string> UlogRecorder::close() {
  for (std::size_t i = 0; i < topic_log_.size();
       ++i) {  // an episode still going: what it left out, said last
    if (topic_log_[i].over) say_over_budget(i, last_t_, Episode::Ends);
  }
  auto size = writer_.close();
  if (!error_.empty()) return fail("ULog file '" + writer_.path().string() + "': " + error_);
  if (!size) return fail("ULog file '" + writer_.path().string() + "': " + std::string(ulog::to_string(size.error())));
  return *size;
}

Result<std::unique_ptr<UlogRecorder>, std::string> write_ulog_to(const std::filesystem::path& path,
                                                                 const kernel::Kernel& kernel,
                                                                 const UlogRecorder::RunInfo& info,
                                                                 const UlogOptions& options,
                                                                 kernel::ObserverFanout& observers) {
  auto recorder = UlogRecorder::create(path, kernel, info, options);
  if (recorder) observers.add(recorder->get());
  return recorder;
}

Result<void, std::string> finish_ulog(UlogRecorder& recorder, proto::RunSummary& summary) {
  const auto bytes = recorder.close();
  if (!bytes) return fail(bytes.error());
  recorder.fill(*summary.mutable_ulog(), *bytes);
  const proto::UlogSummary& u = summary.ulog();
  std::fprintf(stderr, "rejuv run: wrote %s (%.1f MB, %llu data messages, %llu logged strings)\n", u.path().c_str(),
               static_cast<double>(u.bytes()) / 1e6, static_cast<unsigned long long>(u.data_messages()),
               static_cast<unsigned long long>(u.logged_strings()));
  return {};
}

}  // namespace rejuv::cli
