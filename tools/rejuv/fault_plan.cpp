// The fault campaign's plan and record (fault_campaign.hpp): the fault kinds and phases, which pairs make
// sense, the seeded plan of missions, a fault's verdict, and one outcome per line between a job process and the
// campaign.
// The missions themselves fly in fault_campaign.cpp.
#include <algorithm>
#include <random>
#include <sstream>
#include <utility>

#include "fault_campaign.hpp"

namespace rejuv::cli::faults {

std::string_view to_string(FaultKind kind) {
  switch (kind) {
    case FaultKind::KillLive: return "kill-live";
    case FaultKind::HangLive: return "hang-live";
    case FaultKind::KillImage: return "kill-image";
    case FaultKind::StopImage: return "stop-image";
    case FaultKind::KillImages: return "kill-all-images";
    case FaultKind::KillGroup: return "kill-group";
    case FaultKind::StallPlant: return "stall-plant-1s";
    case FaultKind::KillDriver: return "kill-output-driver";
    case FaultKind::KillPlant: return "kill-plant";
  }
  return "?";
}

bool is_terminal(FaultKind kind) { return kind == FaultKind::KillDriver || kind == FaultKind::KillPlant; }

std::string_view to_string(Where where) {
  switch (where) {
    case Where::MC: return "MC";
    case Where::SecureInterval: return "secure-interval";
    case Where::CheckpointSnapshotsSent: return "ckpt:snapshots-sent";
    case Where::CheckpointTaken: return "ckpt:taken";
    case Where::RollbackKilled: return "rb:killed";
    case Where::RollbackResumesSent: return "rb:resumes-sent";
  }
  return "?";
}

bool makes_sense(FaultKind kind, Where where) {
  const bool in_rollback = where == Where::RollbackKilled || where == Where::RollbackResumesSent;
  switch (kind) {
    case FaultKind::KillLive:
    case FaultKind::HangLive: return !in_rollback;
    case FaultKind::KillPlant: return where != Where::CheckpointTaken && where != Where::RollbackResumesSent;
    case FaultKind::KillImage:
    case FaultKind::StopImage:
    case FaultKind::KillImages:
    case FaultKind::KillGroup:
    case FaultKind::StallPlant:
    case FaultKind::KillDriver: return true;
  }
  return false;
}

std::vector<Mission> plan(std::uint64_t seed, std::uint32_t injections, std::uint32_t per_mission,
                          const std::vector<std::string>& rejuvenated, Nanos flight, bool realtime) {
  std::mt19937_64 rng(seed);
  std::vector<std::pair<FaultKind, Where>> ordinary, terminal;
  for (const FaultKind k : kAllFaultKinds) {
    if (realtime && k == FaultKind::StallPlant) continue;  // fault_campaign.hpp: the world itself in real time
    for (const Where w : kAllWheres) {
      if (makes_sense(k, w)) (is_terminal(k) ? terminal : ordinary).emplace_back(k, w);
    }
  }
  std::shuffle(ordinary.begin(), ordinary.end(), rng);
  std::shuffle(terminal.begin(), terminal.end(), rng);
  std::vector<Planned> drawn;
  std::size_t next_ordinary = 0, next_terminal = 0;
  for (std::uint32_t i = 0; i < injections; ++i) {
    const bool take_terminal = i % 10 == 9;  // about one in ten: each ends its mission
    auto& list = take_terminal ? terminal : ordinary;
    std::size_t& next = take_terminal ? next_terminal : next_ordinary;
    if (next == list.size()) {
      std::shuffle(list.begin(), list.end(), rng);
      next = 0;
    }
    const auto [kind, where] = list[next++];
    Planned p{.kind = kind, .where = where, .target = {}, .at = Nanos{0}};
    switch (kind) {
      case FaultKind::KillDriver: p.target = "output_driver"; break;
      case FaultKind::KillPlant:
      case FaultKind::StallPlant: p.target = "plant"; break;
      case FaultKind::KillLive:
      case FaultKind::HangLive:
      case FaultKind::KillImage:
      case FaultKind::StopImage:
      case FaultKind::KillImages:
      case FaultKind::KillGroup: p.target = rejuvenated[rng() % rejuvenated.size()]; break;
    }
    drawn.push_back(std::move(p));
  }
  std::vector<Mission> missions;
  Mission current;
  const auto close = [&] {
    if (current.faults.empty()) return;
    // Spread over the flight: one slot each, the moment drawn in the first 60 % of its slot so that the
    // kernel has recovered before the next one is armed.
    const Nanos start = std::chrono::seconds{6};
    const Nanos slot = (flight - start) / static_cast<std::int64_t>(current.faults.size());
    std::uniform_real_distribution<double> u(0.0, 0.6);
    for (std::size_t j = 0; j < current.faults.size(); ++j) {
      current.faults[j].at = start + slot * static_cast<std::int64_t>(j) +
                             Nanos{static_cast<std::int64_t>(u(rng) * static_cast<double>(slot.count()))};
    }
    current.index = static_cast<std::uint32_t>(missions.size());
    missions.push_back(std::move(current));
    current = Mission{};
  };
  for (Planned& p : drawn) {
    const bool terminal_fault = is_terminal(p.kind);
    current.faults.push_back(std::move(p));
    if (terminal_fault || current.faults.size() >= per_mission) close();
  }
  close();
  return missions;
}

// ---- the verdict ----

Verdict judge(const VerdictInput& in) {
  Verdict v;
  if (!in.back && (in.ended || in.next_fault)) {
    v.not_judged = (in.ended ? "the mission ended" : "the next fault came") + std::string(" before '") + in.target +
                   "' was seen back";
  } else {
    v.recovered = in.back && (in.ended || !in.stopped);
    if (!in.back) v.note += "; '" + in.target + "' not back within 10 s of flight";
  }
  // The cheapest safe recovery (docs/design.md §7 "Faults"): one image of one generation lost leaves another intact
  // generation when the store held another when it fired, so a cold restart after it is a finding, not a recovery.
  // With only the hit generation in the store (after a cold restart or a fallback; a checkpoint by written pages in
  // flight depends on the newest image too), a cold restart is the recovery.
  const bool one_image = in.kind == FaultKind::KillImage || in.kind == FaultKind::StopImage;
  if (one_image && in.path == "cold restart") {
    if (in.keep >= 2 && in.others_at_fire > 0) {
      v.recovered = false;
      v.note += "; a cold restart although an intact generation was left";
    } else {
      v.note += "; no other generation was in the store";
    }
  }
  if (in.max_v >= 1.0 && in.max_v_at_fire < 1.0) {
    v.unsafe = true;
    v.note += "; max V " + std::to_string(in.max_v);
  }
  return v;
}

// ---- encoding (job → parent) ----

namespace {
std::string clean(std::string s) {
  std::replace(s.begin(), s.end(), '\t', ' ');
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}
}  // namespace

std::string encode(const Outcome& o) {
  std::ostringstream out;
  out << o.mission << '\t' << static_cast<int>(o.fault.kind) << '\t' << static_cast<int>(o.fault.where) << '\t'
      << clean(o.fault.target) << '\t' << o.fault.at.count() << '\t' << o.fired << '\t' << o.fired_at_s << '\t'
      << clean(o.path) << '\t' << o.recovered << '\t' << o.unsafe << '\t' << o.leaked << '\t' << o.hung << '\t'
      << o.recovery_ms << '\t' << clean(o.note) << '\t' << clean(o.not_judged) << '\n';
  return out.str();
}

bool decode(std::string_view line, Outcome& o) {
  std::vector<std::string> f;
  std::string cur;
  for (const char c : line) {
    if (c == '\t') {
      f.push_back(std::move(cur));
      cur.clear();
    } else if (c != '\n') {
      cur += c;
    }
  }
  f.push_back(std::move(cur));
  if (f.size() != 15) return false;
  const auto kind = std::stoi(f[1]), where = std::stoi(f[2]);
  if (kind < 0 || kind >= static_cast<int>(kAllFaultKinds.size()) || where < 0 ||
      where >= static_cast<int>(kAllWheres.size())) {
    return false;
  }
  o.mission = static_cast<std::uint32_t>(std::stoul(f[0]));
  o.fault.kind = kAllFaultKinds[static_cast<std::size_t>(kind)];
  o.fault.where = kAllWheres[static_cast<std::size_t>(where)];
  o.fault.target = f[3];
  o.fault.at = Nanos{std::stoll(f[4])};
  o.fired = f[5] == "1";
  o.fired_at_s = std::stod(f[6]);
  o.path = f[7];
  o.recovered = f[8] == "1";
  o.unsafe = f[9] == "1";
  o.leaked = f[10] == "1";
  o.hung = f[11] == "1";
  o.recovery_ms = std::stod(f[12]);
  o.note = f[13];
  o.not_judged = f[14];
  return true;
}
}  // namespace rejuv::cli::faults
