#include "sweep/grid.hpp"

#include <google/protobuf/util/json_util.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "rejuv/flight/attack_library.hpp"
#include "rejuv/flight/sim_config.hpp"
#include "rejuv/launch/launch.hpp"
#include "sweep/params.hpp"

namespace rejuv::cli::sweep {
namespace {

namespace fs = std::filesystem;

std::optional<std::uint64_t> u64(std::string_view text) {
  std::uint64_t v = 0;
  const auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || p != text.data() + text.size() || text.empty()) return std::nullopt;
  return v;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

bool same_params(const proto::SweepRecord& r, const std::vector<proto::SweepParamValue>& params) {
  if (r.params_size() != static_cast<int>(params.size())) return false;
  for (std::size_t i = 0; i < params.size(); ++i) {
    const proto::SweepParamValue& a = r.params(static_cast<int>(i));
    if (a.path() != params[i].path() || a.value() != params[i].value()) return false;
  }
  return true;
}

proto::SweepStat stat(const std::vector<double>& v) {
  proto::SweepStat s;
  if (v.empty()) return s;
  double sum = 0, mx = v.front();
  for (const double x : v) {
    sum += x;
    mx = std::max(mx, x);
  }
  s.set_max(mx);
  s.set_mean(sum / static_cast<double>(v.size()));
  return s;
}

}  // namespace

std::string_view to_string(Runner r) {
  switch (r) {
    case Runner::Sim: return "sim";
    case Runner::Run: return "run";
  }
  return "?";
}

std::optional<Runner> runner_from(std::string_view name) {
  if (name == "sim") return Runner::Sim;
  if (name == "run") return Runner::Run;
  return std::nullopt;
}

Result<Shard, std::string> parse_shard(std::string_view text) {
  const auto slash = text.find('/');
  const auto i = u64(text.substr(0, slash));
  const auto n = slash == std::string_view::npos ? std::nullopt : u64(text.substr(slash + 1));
  if (!i || !n || *n == 0 || *i == 0 || *i > *n || *n > 100000) {
    return fail("--shard: expected i/n with 1 <= i <= n (e.g. 2/8), got '" + std::string(text) + "'");
  }
  return Shard{.index = static_cast<std::uint32_t>(*i - 1), .count = static_cast<std::uint32_t>(*n)};
}

Result<std::vector<std::uint64_t>, std::string> parse_seeds(std::string_view text) {
  std::vector<std::uint64_t> out;
  std::string_view rest = text;
  const auto bad = [&] {
    return fail("--seeds: expected a-b, a,b,c or one seed (e.g. 1-5), got '" + std::string(text) + "'");
  };
  if (text.empty()) return bad();
  while (true) {
    const auto comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    if (const auto dash = item.find('-'); dash != std::string_view::npos) {
      const auto a = u64(item.substr(0, dash)), b = u64(item.substr(dash + 1));
      if (!a || !b) return bad();
      if (*a > *b) return fail("--seeds: inverted range '" + std::string(item) + "'");
      if (*b - *a >= 10000) return fail("--seeds: more than 10000 seeds in '" + std::string(item) + "'");
      for (std::uint64_t s = *a; s <= *b; ++s) out.push_back(s);
    } else {
      const auto s = u64(item);
      if (!s) return bad();
      out.push_back(*s);
    }
    if (comma == std::string_view::npos) break;
    rest = rest.substr(comma + 1);
  }
  std::vector<std::uint64_t> sorted = out;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
    return fail("--seeds: a seed is listed twice in '" + std::string(text) + "'");
  }
  return out;
}

std::uint32_t cell_count(const proto::SweepPlan& plan) {
  std::uint32_t n = 1;
  for (const proto::SweepAxis& a : plan.axes()) n *= static_cast<std::uint32_t>(a.values_size());
  return n;
}

std::vector<proto::SweepParamValue> cell_params(const proto::SweepPlan& plan, std::uint32_t cell) {
  std::vector<proto::SweepParamValue> out(static_cast<std::size_t>(plan.axes_size()));
  std::uint32_t rest = cell;
  for (int i = plan.axes_size() - 1; i >= 0; --i) {
    const proto::SweepAxis& a = plan.axes(i);
    const auto n = static_cast<std::uint32_t>(a.values_size());
    out[static_cast<std::size_t>(i)].set_path(a.path());
    out[static_cast<std::size_t>(i)].set_value(a.values(static_cast<int>(rest % n)));
    rest /= n;
  }
  return out;
}

std::vector<Task> tasks_of(const proto::SweepPlan& plan, Shard shard) {
  std::vector<Task> out;
  for (const std::string& name : plan.runners()) {
    const Runner runner = runner_from(name).value_or(Runner::Sim);
    for (std::uint32_t c = 0; c < cell_count(plan); ++c) {
      if (c % shard.count != shard.index) continue;
      for (const std::uint64_t seed : plan.seeds()) out.push_back(Task{.cell = c, .seed = seed, .runner = runner});
    }
  }
  return out;
}

namespace {

// A swept attack kind of the attack library goes to the service that carries it, as `--attack` does:
// sweeping attack.attacks[0].kind over the library's kinds would otherwise leave them on lqr_control, whose
// hooks refuse four of six. A kind the named service has a hook for stays where the graph put it.
void move_attack_to_its_service(proto::Launch& launch) {
  for (proto::Attack& a : *launch.mutable_attack()->mutable_attacks()) {
    const auto law = flight::attack_law_from_number(static_cast<int>(a.kind()));
    if (!law) continue;
    const proto::ServiceSpec* named = launch::find_service(launch, a.service());
    if (named != nullptr) {
      const auto hooks = launch::attack_hooks_of(named->executable());
      if (!hooks || std::find(hooks->begin(), hooks->end(), a.kind()) != hooks->end()) continue;
    }
    const std::string service(flight::default_service(*law));
    if (launch::find_service(launch, service) != nullptr) a.set_service(service);
  }
}

}  // namespace

Result<proto::Launch, std::string> cell_launch(const proto::Launch& base, const fs::path& base_dir,
                                               const proto::SweepPlan& plan, std::uint32_t cell) {
  proto::Launch launch = base;
  for (const proto::SweepParamValue& p : cell_params(plan, cell)) {
    if (auto set = set_field(launch, p.path(), p.value()); !set) return fail(set.error());
  }
  move_attack_to_its_service(launch);
  launch.set_stop_after_attacks(plan.attacks());
  if (plan.charges() == kChargesPaper) {  // the runtime charges what the model does by default (§VI-B)
    const flight::SimConfig paper = flight::SimConfig::defaults();
    launch.mutable_lockstep()->set_checkpoint_charge_ms(paper.t_cp.count() * 1e3);
    launch.mutable_lockstep()->set_rollback_charge_ms(paper.t_rb.count() * 1e3);
  }
  // The cell's launch lives in DIR: paths relative to the original launch file become absolute.
  if (!launch.policy().empty() && fs::path(launch.policy()).is_relative()) {
    launch.set_policy((base_dir / launch.policy()).lexically_normal().string());
  }
  if (!launch.dds().config().empty() && fs::path(launch.dds().config()).is_relative()) {
    launch.mutable_dds()->set_config((base_dir / launch.dds().config()).lexically_normal().string());
  }
  return launch;
}

fs::path record_path(const fs::path& dir, const Task& task) {
  char name[96];
  std::snprintf(name, sizeof name, "cell-%04u_seed-%llu_%s.json", task.cell,
                static_cast<unsigned long long>(task.seed), std::string(to_string(task.runner)).c_str());
  return dir / "cells" / name;
}

namespace {

std::optional<proto::SweepRecord> parse_record(const fs::path& p) {
  proto::SweepRecord r;
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = true;
  if (!google::protobuf::util::JsonStringToMessage(slurp(p), &r, options).ok()) return std::nullopt;
  return r;
}

bool belongs(const proto::SweepRecord& r, const proto::SweepPlan& plan) {
  if (r.cell() >= cell_count(plan) || r.attacks() != plan.attacks()) return false;
  if (std::find(plan.seeds().begin(), plan.seeds().end(), r.seed()) == plan.seeds().end()) return false;
  if (std::find(plan.runners().begin(), plan.runners().end(), r.runner()) == plan.runners().end()) return false;
  return same_params(r, cell_params(plan, r.cell()));
}

}  // namespace

std::optional<proto::SweepRecord> kept_record(const fs::path& dir, const proto::SweepPlan& plan, const Task& task) {
  const fs::path p = record_path(dir, task);
  std::error_code ec;
  if (!fs::exists(p, ec)) return std::nullopt;
  auto r = parse_record(p);
  if (!r || !belongs(*r, plan) || r->cell() != task.cell || r->seed() != task.seed ||
      r->runner() != to_string(task.runner)) {
    return std::nullopt;
  }
  return r;
}

std::vector<proto::SweepRecord> kept_records(const fs::path& dir, const proto::SweepPlan& plan) {
  std::vector<proto::SweepRecord> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir / "cells", ec)) {
    const fs::path& p = entry.path();
    if (p.extension() != ".json" || !p.filename().string().starts_with("cell-")) continue;
    if (auto r = parse_record(p); r && belongs(*r, plan)) out.push_back(std::move(*r));
  }
  std::sort(out.begin(), out.end(), [](const proto::SweepRecord& a, const proto::SweepRecord& b) {
    return std::tuple(a.cell(), a.runner(), a.seed()) < std::tuple(b.cell(), b.runner(), b.seed());
  });
  return out;
}

Result<void, std::string> write_atomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return fail("cannot write '" + tmp.string() + "'");
    out << text;
    out.flush();
    if (!out) return fail("cannot write '" + tmp.string() + "'");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    return fail("cannot rename to '" + path.string() + "'");
  }
  return {};
}

std::string to_json_text(const google::protobuf::Message& m) {
  std::string out;
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  (void)google::protobuf::util::MessageToJsonString(m, &out, options);
  return out;
}

Result<void, std::string> write_record(const fs::path& dir, const proto::SweepRecord& r) {
  const Task task{.cell = r.cell(), .seed = r.seed(), .runner = runner_from(r.runner()).value_or(Runner::Sim)};
  return write_atomically(record_path(dir, task), to_json_text(r));
}

Result<void, std::string> write_plan(const fs::path& dir, const proto::SweepPlan& plan) {
  return write_atomically(dir / "plan.json", to_json_text(plan));
}

Result<proto::SweepPlan, std::string> read_plan(const fs::path& dir) {
  const fs::path p = dir / "plan.json";
  std::error_code ec;
  if (!fs::exists(p, ec)) return fail(dir.string() + ": no plan.json (not a sweep folder)");
  proto::SweepPlan plan;
  if (!google::protobuf::util::JsonStringToMessage(slurp(p), &plan).ok()) {
    return fail(p.string() + ": not a sweep plan (JSON of rejuv.proto.SweepPlan)");
  }
  return plan;
}

bool same_plan(const proto::SweepPlan& a, const proto::SweepPlan& b) {
  return a.SerializeAsString() == b.SerializeAsString();
}

proto::SweepReport aggregate(const proto::SweepPlan& plan, const std::vector<proto::SweepRecord>& records) {
  proto::SweepReport report;
  *report.mutable_plan() = plan;
  std::map<std::pair<std::uint32_t, std::string>, std::vector<const proto::SweepRecord*>> by_cell;
  for (const proto::SweepRecord& r : records) by_cell[{r.cell(), r.runner()}].push_back(&r);
  std::size_t found = 0;
  for (std::uint32_t c = 0; c < cell_count(plan); ++c) {
    for (const std::string& runner : plan.runners()) {
      const auto it = by_cell.find({c, runner});
      if (it == by_cell.end()) continue;
      proto::SweepCellResult& cell = *report.add_cells();
      cell.set_cell(c);
      for (const proto::SweepParamValue& p : cell_params(plan, c)) *cell.add_params() = p;
      cell.set_runner(runner);
      std::vector<double> v, e, dm, dx, rb, at, mt;
      for (const proto::SweepRecord* r : it->second) {
        ++found;
        *cell.add_records() = *r;
        cell.set_seeds(cell.seeds() + 1);
        if (r->status() != "ok") {
          if (cell.error().empty()) cell.set_error("seed " + std::to_string(r->seed()) + ": " + r->error());
          continue;
        }
        const proto::RunSummary& s = r->summary();
        cell.set_ok(cell.ok() + 1);
        cell.set_completed(cell.completed() + (s.mission_completed() || s.stopped_after_attacks() ? 1 : 0));
        cell.set_safe(cell.safe() + (s.left_safety_set() ? 0 : 1));
        v.push_back(s.max_v());
        e.push_back(s.max_est_err_p());
        dm.push_back(s.d_mean_m());
        dx.push_back(s.d_max_m());
        rb.push_back(static_cast<double>(s.rollbacks()));
        at.push_back(static_cast<double>(s.attacks()));
        mt.push_back(s.mission_time_s());
        const auto attacks = static_cast<std::uint32_t>(s.attacks());
        cell.set_attacks_min(cell.ok() == 1 ? attacks : std::min(cell.attacks_min(), attacks));
        if (plan.attacks() > 0 && attacks < plan.attacks()) cell.set_short_of_attacks(cell.short_of_attacks() + 1);
      }
      *cell.mutable_max_v() = stat(v);
      *cell.mutable_max_est_err_p() = stat(e);
      *cell.mutable_d_mean_m() = stat(dm);
      *cell.mutable_d_max_m() = stat(dx);
      *cell.mutable_rollbacks() = stat(rb);
      *cell.mutable_attacks() = stat(at);
      *cell.mutable_mission_time_s() = stat(mt);
    }
  }
  const std::size_t planned = static_cast<std::size_t>(cell_count(plan)) * static_cast<std::size_t>(plan.seeds_size()) *
                              static_cast<std::size_t>(plan.runners_size());
  report.set_missing(static_cast<std::uint32_t>(planned - std::min(planned, found)));
  return report;
}

std::string charges_text(const proto::SweepReport& report) {
  std::string out;
  for (const std::string& runner : report.plan().runners()) {
    for (const proto::SweepCellResult& c : report.cells()) {
      const auto ok = std::find_if(c.records().begin(), c.records().end(),
                                   [](const proto::SweepRecord& r) { return r.status() == "ok"; });
      if (c.runner() != runner || ok == c.records().end()) continue;
      char text[96];
      std::snprintf(text, sizeof text, "%s%s %.3g/%.3g ms", out.empty() ? "" : ", ", runner.c_str(),
                    ok->summary().charging().checkpoint_charge_ms(), ok->summary().charging().rollback_charge_ms());
      out += text;
      break;
    }
  }
  return out;
}

std::string to_csv(const proto::SweepReport& report) {
  std::string out;
  for (const proto::SweepAxis& a : report.plan().axes()) out += a.path() + ",";
  out += "runner,seeds,ok,completed,safe,max_V_max,max_V_mean,max_est_err_P_max,max_est_err_P_mean,d_mean_m_mean,"
         "d_max_m_max,rollbacks_mean,attacks_min,attacks_mean,short_of_attacks,mission_time_s_mean,mission_time_s_max,"
         "checkpoint_charge_ms,rollback_charge_ms,error\n";
  for (const proto::SweepCellResult& c : report.cells()) {
    for (const proto::SweepParamValue& p : c.params()) out += p.value() + ",";
    const proto::Charging* charged = nullptr;  // what the cell's missions were charged (one launch: all alike)
    for (const proto::SweepRecord& r : c.records()) {
      if (r.status() != "ok") continue;
      charged = &r.summary().charging();
    }
    char line[512];
    std::snprintf(line, sizeof line, "%s,%u,%u,%u,%u,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%u,%.6g,%u,%.6g,%.6g,",
                  c.runner().c_str(), c.seeds(), c.ok(), c.completed(), c.safe(), c.max_v().max(), c.max_v().mean(),
                  c.max_est_err_p().max(), c.max_est_err_p().mean(), c.d_mean_m().mean(), c.d_max_m().max(),
                  c.rollbacks().mean(), c.attacks_min(), c.attacks().mean(), c.short_of_attacks(),
                  c.mission_time_s().mean(), c.mission_time_s().max());
    out += line;
    if (charged != nullptr) {
      std::snprintf(line, sizeof line, "%.6g,%.6g,", charged->checkpoint_charge_ms(), charged->rollback_charge_ms());
      out += line;
    } else {
      out += ",,";
    }
    std::string error = c.error();
    std::replace(error.begin(), error.end(), ',', ';');
    std::replace(error.begin(), error.end(), '\n', ' ');
    out += error + "\n";
  }
  return out;
}

}  // namespace rejuv::cli::sweep
