// `rejuv soak GRAPH`: a soak of a flight graph (docs/design.md §11). Kernels in this process (as `rejuv run`)
// fly the graph's mission with SR and its attacks — the closed waypoint loop repeated as often as a mission
// holds (16 waypoints: three laps of the square, ≈ 240 SR cycles) — one mission after the other, each in a new
// kernel, until N rollbacks (SR cycles) in all; with --one-kernel a single kernel flies the mission and then
// hovers at its last waypoint with SR and attacks going on. Every C cycles it samples from /proc: this process's
// (the kernel's) RSS, mappings, open fds and threads, the processes descending from it, and for the plant and
// each live service its RSS, mappings, fds and (services) the processes of its session (the live incarnation
// and its frozen images), and the bytes this process's malloc holds in use (kernel_heap_kb: a growing RSS with a
// flat heap is pages touched or fragmentation, not a leak). Progress on stderr; the samples as CSV (and a PNG through tools/plots/soak.gp when
// gnuplot is present).
//
// The verdict compares, per series, the last 20 % of the samples (at least 3) with the 20 % after a warm-up of
// 10 % of the samples and at least 15 000 steps (60 s) of flight, at most half: by their largest values, RSS may
// grow by at most --kernel-rss-kb (this process) or --service-rss-kb (each service and the plant); by their
// medians, mappings by --maps-slack beyond the baseline window's largest; by their most frequent values, fds,
// threads and processes may not rise (a leak is in every later sample, a transient in some: see judge()); with
// --one-kernel the SR cycle's length (sr_cycle_s, simulated
// seconds per rollback between samples) within 1.25x of the baseline's (a slower cycle is a vehicle that
// stays in safety control, while memory may stay flat). Exit 0 when every series stays in its bound and the
// soak reached N cycles without a failure, 1 otherwise (naming the series), 2 on bad input.
//
// What is readable: the kernel runs as root (or with CAP_SYS_PTRACE over its children's user namespaces) and
// reads every file used here even though the services are not dumpable (PR_SET_DUMPABLE 0 makes their
// /proc files root's); /proc/<pid>/status is readable by anyone. A file that cannot be read gives NaN in the
// CSV and the series is reported as unreadable instead of judged.
#include <dirent.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "args.hpp"
#include "common_options.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "run_recorder.hpp"
#include "rejuv/kernel/kernel.hpp"
#include "rejuv/launch/launch.hpp"
#include "rejuv/sys/process.hpp"
#include "rejuv/sys/sanitizer.hpp"

namespace rejuv::cli {
namespace {

namespace fs = std::filesystem;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---- /proc ----

// "VmRSS:" and "Threads:" of /proc/<pid>/status [kB, count]; NaN when unreadable.
struct Status {
  double rss_kb = kNaN;
  double threads = kNaN;
};
Status read_status(const std::string& proc) {
  std::ifstream in(proc + "/status");
  Status s;
  std::string line;
  while (std::getline(in, line)) {
    if (line.starts_with("VmRSS:")) s.rss_kb = std::strtod(line.c_str() + 6, nullptr);
    if (line.starts_with("Threads:")) s.threads = std::strtod(line.c_str() + 8, nullptr);
  }
  return s;
}

double count_lines(const std::string& file) {
  std::ifstream in(file);
  if (!in) return kNaN;
  double n = 0;
  std::string line;
  while (std::getline(in, line)) ++n;
  return n;
}

double count_entries(const std::string& dir) {
  std::error_code ec;
  double n = 0;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) ++n;
  return ec ? kNaN : n;
}

// Every process of the machine: pid, parent, session (from /proc/<pid>/stat), and its command name.
struct Proc {
  pid_t pid = 0, ppid = 0, session = 0;
  std::string comm;
};
std::vector<Proc> all_processes() {
  std::vector<Proc> out;
  std::error_code ec;
  for (auto it = fs::directory_iterator("/proc", ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream stat(it->path() / "stat");
    std::string line;
    if (!std::getline(stat, line)) continue;
    // pid (comm) state ppid pgrp session ...: comm may hold spaces and parentheses; parse from the last ')'.
    const auto open = line.find('('), close = line.rfind(')');
    if (open == std::string::npos || close == std::string::npos || close + 4 > line.size()) continue;
    if (line[close + 2] == 'X' || line[close + 2] == 'Z') continue;  // dead, or a zombie not yet reaped
    Proc p;
    p.pid = static_cast<pid_t>(std::strtol(line.c_str(), nullptr, 10));
    p.comm = line.substr(open + 1, close - open - 1);
    char* end = nullptr;
    p.ppid = static_cast<pid_t>(std::strtol(line.c_str() + close + 4, &end, 10));
    const long pgrp = std::strtol(end, &end, 10);
    (void)pgrp;
    p.session = static_cast<pid_t>(std::strtol(end, nullptr, 10));
    out.push_back(std::move(p));
  }
  return out;
}

int descendants_of(pid_t root, const std::vector<Proc>& procs) {
  std::vector<pid_t> frontier{root};
  int n = 0;
  while (!frontier.empty()) {
    const pid_t parent = frontier.back();
    frontier.pop_back();
    for (const Proc& p : procs) {
      if (p.ppid == parent) {
        ++n;
        frontier.push_back(p.pid);
      }
    }
  }
  return n;
}

// ---- samples ----

// The columns of the CSV, in groups that tools/plots/soak.gp plots together.
struct Series {
  std::string name;   // CSV column, e.g. "ekf2_rss_kb"
  // CycleLength: simulated seconds per SR cycle since the last sample; judged with --one-kernel,
  // where one kernel flies the whole soak (a new kernel per mission restarts the flight, so the length there is
  // reported, not judged).
  // KernelHeap: malloc's bytes in use in this process, judged like the kernel's RSS.
  // Timing: real time of the window since the last sample (`--realtime`: the control intervals' p99.9 and max
  // [ms], the estimate catch-ups): reported, never judged (a timing says what this machine did, not a leak).
  enum class Kind : std::uint8_t { KernelRss, KernelHeap, ServiceRss, Maps, Count, CycleLength, Timing } kind = Kind::Count;
  std::vector<double> values{};
};

// Samples beyond cycles / every that a soak can take: the first sample of each kernel (a soak of missions starts
// one per mission), more than any soak here flies.
constexpr std::size_t kSampleSlack = 64;

class Soak final : public kernel::Observer {
 public:
  Soak(std::uint64_t cycles, std::uint64_t every, bool realtime = false)
      : cycles_(cycles), every_(every), started_(std::chrono::steady_clock::now()) {
    realtime_ = realtime;
  }

  // The recorder of the mission about to start (one per kernel).
  void record_with(RunRecorder& recorder) { recorder_ = &recorder; }
  // A booted kernel; its rollbacks count on from the cycles of the kernels before it.
  void attach(kernel::Kernel& k, std::uint64_t cycles_before) {
    k_ = &k;
    offset_ = cycles_before;
    if (!series_.empty()) return;  // the same graph: the same services and series
    for (std::size_t i = 0; i < k.service_count(); ++i) {
      const kernel::ServiceStats st = k.stats(ServiceId{static_cast<std::uint32_t>(i)});
      if (st.started) services_.push_back({ServiceId{static_cast<std::uint32_t>(i)}, st.name});
    }
    const auto add = [&](std::string name, Series::Kind kind) { series_.push_back({std::move(name), kind}); };
    add("sr_cycle_s", Series::Kind::CycleLength);
    add("kernel_rss_kb", Series::Kind::KernelRss);
    add("kernel_heap_kb", Series::Kind::KernelHeap);
    add("plant_rss_kb", Series::Kind::ServiceRss);
    for (const auto& s : services_) add(s.name + "_rss_kb", Series::Kind::ServiceRss);
    add("kernel_fds", Series::Kind::Count);
    add("plant_fds", Series::Kind::Count);
    for (const auto& s : services_) add(s.name + "_fds", Series::Kind::Count);
    add("kernel_maps", Series::Kind::Maps);
    add("plant_maps", Series::Kind::Maps);
    for (const auto& s : services_) add(s.name + "_maps", Series::Kind::Maps);
    add("kernel_threads", Series::Kind::Count);
    add("kernel_children", Series::Kind::Count);
    add("processes", Series::Kind::Count);
    for (const auto& s : services_) add(s.name + "_procs", Series::Kind::Count);
    if (realtime_) {
      add("interval_p999_ms", Series::Kind::Timing);
      add("interval_max_ms", Series::Kind::Timing);
      add("catch_ups", Series::Kind::Timing);
      add("catch_ups_cut_short", Series::Kind::Timing);
    }
    // Room for every sample up front (one every `every_` cycles, and the first of each kernel): the soak's own
    // samples, 8 bytes per series each, would otherwise grow this process's heap and RSS by doubling vectors
    // while they measure them (≈ 60 B per cycle on the square at a sample every 10 cycles).
    const std::size_t room = static_cast<std::size_t>(cycles_ / std::max<std::uint64_t>(every_, 1)) + kSampleSlack;
    cycle_.reserve(room);
    t_sim_.reserve(room);
    wall_.reserve(room);
    for (Series& x : series_) x.values.reserve(room);
  }

  void detach() { k_ = nullptr; }
  void stop_recording() { recorder_ = nullptr; }

  void on_publication(const kernel::Publication& p) override {
    if (recorder_ != nullptr) recorder_->on_publication(p);
  }

  void on_step(std::uint64_t step, Nanos t, SrMode mode) override {
    if (recorder_ != nullptr) recorder_->on_step(step, t, mode);
    if (k_ == nullptr || done_) return;
    const std::uint64_t rollbacks = offset_ + k_->sr_stats().rollbacks;
    // Sample at one phase of the cycle — in MC once the count is due, 100 ms after the checkpoint's image work
    // was done — so that what a cycle holds for a moment (the patches and spares on their way) does not decide
    // a sample.
    if (rollbacks >= next_ && mode == SrMode::MC && !k_->image_work_pending() && !settle_until_) {
      settle_until_ = t + std::chrono::milliseconds{100};
    }
    if (mode != SrMode::MC) settle_until_.reset();
    if (rollbacks >= next_ && settle_until_ && t >= *settle_until_) {
      settle_until_.reset();
      sample(rollbacks, t);
      next_ = (rollbacks / every_ + 1) * every_;
      if (rollbacks >= cycles_) {
        done_ = true;
        k_->request_stop();
      }
    }
  }

  [[nodiscard]] bool done() const { return done_; }
  [[nodiscard]] const std::vector<Series>& series() const { return series_; }
  [[nodiscard]] std::size_t samples() const { return cycle_.size(); }
  // The first sample taken after `flight` of simulated time since the first sample, over every kernel of the
  // soak (a new kernel's clock starts again: its time is added to what the ones before flew); samples() if none.
  [[nodiscard]] std::size_t sample_after(Nanos flight) const {
    double before = 0, offset = 0;
    for (std::size_t i = 0; i < t_sim_.size(); ++i) {
      if (i > 0 && t_sim_[i] < t_sim_[i - 1]) offset += t_sim_[i - 1];  // a new kernel
      if (i == 0) before = t_sim_[0];
      if (offset + t_sim_[i] - before >= to_seconds(flight).count()) return i;
    }
    return t_sim_.size();
  }

  void write_csv(std::FILE* f) const {
    std::fprintf(f, "cycle,t_sim_s,wall_s");
    for (const Series& s : series_) std::fprintf(f, ",%s", s.name.c_str());
    std::fprintf(f, "\n");
    for (std::size_t i = 0; i < cycle_.size(); ++i) {
      std::fprintf(f, "%llu,%.3f,%.3f", static_cast<unsigned long long>(cycle_[i]), t_sim_[i], wall_[i]);
      for (const Series& s : series_) {
        if (std::isnan(s.values[i])) {
          std::fprintf(f, ",NaN");
        } else if (s.kind == Series::Kind::CycleLength || s.kind == Series::Kind::Timing) {
          std::fprintf(f, ",%.3f", s.values[i]);
        } else {
          std::fprintf(f, ",%.0f", s.values[i]);
        }
      }
      std::fprintf(f, "\n");
    }
  }

 private:
  struct Service {
    ServiceId id;
    std::string name;
  };

  void sample(std::uint64_t rollbacks, Nanos t) {
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    cycle_.push_back(rollbacks);
    t_sim_.push_back(to_seconds(t).count());
    wall_.push_back(wall);
    const std::vector<Proc> procs = all_processes();
    const pid_t self = ::getpid();
    std::optional<pid_t> plant;
    for (const Proc& p : procs) {
      if (p.ppid == self && p.comm.starts_with("rejuv_plant")) plant = p.pid;
    }
    std::map<std::string, double> v;
    // Simulated seconds per SR cycle since the previous sample of this kernel (NaN at a kernel's first).
    const std::size_t n = cycle_.size();
    if (n >= 2 && cycle_[n - 1] > cycle_[n - 2] && t_sim_[n - 1] > t_sim_[n - 2]) {
      v["sr_cycle_s"] = (t_sim_[n - 1] - t_sim_[n - 2]) / static_cast<double>(cycle_[n - 1] - cycle_[n - 2]);
    }
    const auto per_process = [&](const std::string& who, std::optional<pid_t> pid) {
      const std::string proc = pid ? "/proc/" + std::to_string(*pid) : std::string("/proc/none");
      v[who + "_rss_kb"] = read_status(proc).rss_kb;
      v[who + "_fds"] = count_entries(proc + "/fd");
      v[who + "_maps"] = count_lines(proc + "/maps");
    };
    per_process("kernel", self);
    v["kernel_heap_kb"] = static_cast<double>(sys::heap_in_use_bytes()) / 1024.0;
    v["kernel_threads"] = read_status("/proc/self").threads;
    per_process("plant", plant);
    int children = 0;
    for (const Proc& p : procs) children += p.ppid == self ? 1 : 0;
    v["kernel_children"] = children;
    v["processes"] = descendants_of(self, procs);
    for (const Service& s : services_) {
      const kernel::ServiceStats st = k_->stats(s.id);
      const std::optional<pid_t> pid = st.alive && st.pid > 0 ? std::optional<pid_t>(st.pid) : std::nullopt;
      per_process(s.name, pid);
      double in_session = kNaN;
      if (pid) {
        if (const auto sid = sys::session_of(*pid)) {
          in_session = 0;
          for (const Proc& p : procs) in_session += p.session == *sid ? 1 : 0;
        }
      }
      v[s.name + "_procs"] = in_session;
    }
    if (realtime_) {
      // The window's control intervals (from a histogram: nothing allocated while the soak measures) and
      // the estimate catch-ups since the last sample.
      if (window_count_ > 0) {
        v["interval_p999_ms"] = intervals_->quantile(0.999);
        v["interval_max_ms"] = intervals_->max_ms();
      }
      const kernel::CatchUpStats& c = k_->catch_up_stats();
      v["catch_ups"] = static_cast<double>(c.replays - catch_ups_before_);
      v["catch_ups_cut_short"] = static_cast<double>(c.cut_short - cut_short_before_);
      catch_ups_before_ = c.replays;
      cut_short_before_ = c.cut_short;
      intervals_->clear();
      window_count_ = 0;
    }
    for (Series& s : series_) s.values.push_back(v.contains(s.name) ? v[s.name] : kNaN);

    const double done = static_cast<double>(std::min(rollbacks, cycles_)) / static_cast<double>(cycles_);
    const double eta = done > 0 ? wall * (1 - done) / done : 0;
    std::fprintf(stderr, "rejuv soak: cycle %llu/%llu (%.0f %%), t = %.0f s, kernel RSS %.0f kB, %.0f processes, ETA %.0f s\n",
                 static_cast<unsigned long long>(rollbacks), static_cast<unsigned long long>(cycles_), 100 * done,
                 to_seconds(t).count(), v["kernel_rss_kb"], v["processes"], eta);
  }

  // Control intervals of a window in 10 µs bins up to 100 ms (and the exact max): a fixed histogram.
  class Intervals {
   public:
    void add(double ms) {
      const auto bin = static_cast<std::size_t>(std::clamp(ms * 100.0, 0.0, static_cast<double>(kBins - 1)));
      ++bins_[bin];
      ++n_;
      max_ = std::max(max_, ms);
    }
    [[nodiscard]] double quantile(double q) const {
      const auto rank = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(n_)));
      std::uint64_t seen = 0;
      for (std::size_t i = 0; i < kBins; ++i) {
        seen += bins_[i];
        if (seen >= rank && seen > 0) return static_cast<double>(i + 1) / 100.0;
      }
      return max_;
    }
    [[nodiscard]] double max_ms() const { return max_; }
    void clear() {
      bins_.fill(0);
      n_ = 0;
      max_ = 0;
    }

   private:
    static constexpr std::size_t kBins = 10'000;
    std::array<std::uint32_t, kBins> bins_{};
    std::uint64_t n_ = 0;
    double max_ = 0;
  };

 public:
  // Every control update (real time `wall`): the interval since the one before, into the window's histogram.
  void on_control_update(Nanos t, Nanos wall) override {
    if (recorder_ != nullptr) recorder_->on_control_update(t, wall);
    if (!realtime_ || k_ == nullptr) return;
    if (last_update_ && wall > *last_update_) {
      intervals_->add(std::chrono::duration<double, std::milli>(wall - *last_update_).count());
      ++window_count_;
    }
    last_update_ = wall;
  }

 private:
  bool realtime_ = false;
  std::unique_ptr<Intervals> intervals_ = std::make_unique<Intervals>();  // 40 kB: not on the stack of a copy
  std::optional<Nanos> last_update_{};
  std::uint64_t window_count_ = 0, catch_ups_before_ = 0, cut_short_before_ = 0;
  RunRecorder* recorder_ = nullptr;
  kernel::Kernel* k_ = nullptr;
  std::uint64_t cycles_, every_, next_ = 0, offset_ = 0;
  std::optional<Nanos> settle_until_{};  // the sample waits until then (kernel time)
  bool done_ = false;
  std::chrono::steady_clock::time_point started_;
  std::vector<Service> services_;
  std::vector<Series> series_;
  std::vector<std::uint64_t> cycle_;
  std::vector<double> t_sim_, wall_;
};

// ---- the verdict ----

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  return v.size() % 2 == 1 ? v[v.size() / 2] : (v[v.size() / 2 - 1] + v[v.size() / 2]) / 2;
}

// The value most samples hold (the smaller of equally frequent ones).
double most_frequent(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  double best = kNaN;
  std::size_t best_run = 0;
  for (std::size_t i = 0; i < v.size();) {
    std::size_t j = i;
    while (j < v.size() && v[j] == v[i]) ++j;
    if (j - i > best_run) best = v[i], best_run = j - i;
    i = j;
  }
  return best;
}

struct Verdict {
  std::string name;
  double baseline = kNaN, last = kNaN, growth = kNaN, bound = kNaN;
  bool readable = true, ok = true;
};

// The warm-up before the baseline, in lockstep steps (15 000 steps of 4 ms: 60 s of flight): what the graph's
// processes allocate once (the plant's and the services' DDS and allocator state) settles by the steps flown,
// not by the SR cycles counted — on a loaded machine the plant's memory had not settled 10 % of a short soak's
// cycles in, and the series "grew" from a baseline taken too early.
constexpr Nanos kSettleFlight = 15'000 * std::chrono::milliseconds{4};

// Where the baseline starts: after 10 % of the samples and after kSettleFlight, but no later than half-way.
std::size_t baseline_start(const Soak& soak) {
  const std::size_t n = soak.samples();
  return std::min(n / 2, std::max(n / 10, soak.sample_after(kSettleFlight)));
}

// Baseline: 20 % of the samples from b0 (after the warm-up); last: the last 20 %, at least 3, none in the baseline.
Verdict judge(const Series& s, std::size_t b0, double kernel_rss_kb, double service_rss_kb, double maps_slack,
              bool one_kernel) {
  Verdict v{.name = s.name};
  const std::size_t n = s.values.size();
  const std::size_t b1 = std::max(b0 + 1, b0 + (n * 2) / 10);
  const std::size_t after_base = n > b1 ? n - b1 : 0;
  const std::size_t l0 = n - std::min(after_base, std::max<std::size_t>(3, n / 5));  // at least 3, after the baseline
  std::vector<double> base, last;
  for (std::size_t i = 0; i < n; ++i) {
    if (std::isnan(s.values[i])) continue;
    if (i >= b0 && i < b1) base.push_back(s.values[i]);
    if (i >= l0) last.push_back(s.values[i]);
  }
  if (base.empty() || last.empty()) {
    v.readable = false;
    return v;
  }
  // Each window reduced to what a leak moves and a transient does not. What leaked is in every sample after it;
  // a transient is in some samples only, in either direction, because a sample's phase in the cycle is not
  // fixed (in real time, and in lockstep on a loaded machine):
  //  - a count (fds, threads, processes) by its most frequent value: an fd or process on its way (an image
  //    being forked, a generation trimmed, an image's fd replaced) raises or lowers a few samples;
  //  - RSS by its largest value: a process's resident memory dips when its allocator gives a burst's pages back
  //    (glibc trims a thread's arena once Cyclone's receive thread frees what a backlog held: the plant's fell
  //    by up to 760 kB beside other busy processes) and comes back at the next burst, milliseconds or several
  //    samples later; a leak raises the highest value as well as the lowest.
  using Kind = Series::Kind;
  const auto reduce = [&](const std::vector<double>& w) {
    if (s.kind == Kind::Count) return most_frequent(w);
    if (s.kind == Kind::KernelRss || s.kind == Kind::ServiceRss) return *std::max_element(w.begin(), w.end());
    return median(w);
  };
  v.baseline = reduce(base);
  v.last = reduce(last);
  v.growth = v.last - v.baseline;
  switch (s.kind) {
    // A sanitizer build's RSS holds its shadow of every address a run touches, and its runtime maps more shadow
    // and metadata regions as they are touched: both grow with the pages touched, not with what is kept, so
    // they are reported, not judged there (the kernel's heap, fds, threads and processes still are).
    case Series::Kind::KernelRss: v.bound = sys::kSanitizerBuild ? kNaN : kernel_rss_kb; break;
    case Series::Kind::KernelHeap: v.bound = kernel_rss_kb; break;
    case Series::Kind::ServiceRss: v.bound = sys::kSanitizerBuild ? kNaN : service_rss_kb; break;
    case Series::Kind::Maps:
      v.bound = sys::kSanitizerBuild ? kNaN : *std::max_element(base.begin(), base.end()) - v.baseline + maps_slack;
      break;
    case Series::Kind::Count: v.bound = 0; break;  // the most frequent value may not rise
    // The last 20 % within 1.25x of the early cycles.
    case Series::Kind::CycleLength: v.bound = one_kernel ? 0.25 * v.baseline : kNaN; break;
    case Series::Kind::Timing: v.bound = kNaN; break;  // reported: what this machine did, not a leak
  }
  if (std::isnan(v.bound)) return v;  // reported, not judged
  v.ok = v.growth <= v.bound;
  return v;
}

// The graph's closed waypoint loop (first == last) repeated while the mission holds it.
void repeat_the_loop(proto::Mission& m) {
  const int n = m.waypoints_size();
  if (n < 3) return;
  const auto& a = m.waypoints(0);
  const auto& z = m.waypoints(n - 1);
  if (a.north_m() != z.north_m() || a.east_m() != z.east_m() || a.down_m() != z.down_m()) return;
  while (m.waypoints_size() + (n - 1) <= 16) {
    for (int i = 1; i < n; ++i) *m.add_waypoints() = m.waypoints(i);
  }
}

// Long enough for any --cycles (an SR cycle is seconds of simulated time); the soak stops itself.
constexpr double kLimitS = launch::defaults::kMaxDurationS / 2;

// The graph as the soak flies it: the loop repeated, no mission timeout within reach.
Result<launch::LoadedLaunch, std::string> soak_graph(const std::string& path) {
  auto loaded = launch::load_launch(path);
  if (!loaded) return std::unexpected(loaded.error().to_string());
  if (!loaded->graph.sr().enabled()) return std::unexpected("rejuv soak: " + path + ": the graph has sr.enabled false");
  repeat_the_loop(*loaded->graph.mutable_mission());
  loaded->graph.mutable_mission()->set_timeout_s(2 * kLimitS);
  return std::move(*loaded);
}

// What `rejuv soak` was asked for.
struct SoakRequest {
  std::string graph_path;
  std::uint64_t cycles = 1000, every = 10, maps_slack = 2;
  double kernel_rss = 512, service_rss = 256;
  std::filesystem::path out = "out/soak";
  bool one_kernel = false, realtime = false;
  KernelFlags flags{.net_port = 0};
};

void declare_soak_options(Options& opts, SoakRequest& r) {
  opts.positional("GRAPH", r.graph_path, "the launch graph (*.launch.pbtxt)")
      .integer("--cycles", "N", r.cycles, {1, 10'000'000}, "SR cycles (rollbacks) to fly")
      .integer("--sample-every", "C", r.every, {1, 10'000'000}, "cycles between samples, at most --cycles");
  seed_option(opts, r.flags.seed, "seed of the plant and the services")
      .path("--out", "DIR", r.out, "where soak.csv and soak.png go")
      .real("--kernel-rss-kb", "K", r.kernel_rss, {.min = 0}, "allowed growth of the kernel's RSS [kB]")
      .real("--service-rss-kb", "K", r.service_rss, {.min = 0}, "allowed growth of a service's or the plant's RSS [kB]")
      .integer("--maps-slack", "M", r.maps_slack, {},
               "mappings a process may gain beyond the baseline's jitter (2: a new process of each\n"
               "mission may get one more malloc arena or thread stack than the first; a leak keeps growing)");
  domain_option(opts, r.flags.domain, "DDS domain id", kLeasedDomainHelp);
  charge_option(opts, r.flags.charge);
  net_port_option(opts, r.flags.net_port, "UDP port of the network gate", "0, any free port")
      .flag("--one-kernel", r.one_kernel,
            "one kernel for the whole soak (the mission, then a hover at its last waypoint) instead of a new\n"
            "kernel in this process for each mission")
      .flag("--insecure-sandbox", r.flags.insecure_sandbox, "as `rejuv run --insecure-sandbox`")
      .flag("--realtime", r.realtime,
            "one kernel on the wall clock with the graph's real-time plan (as `rejuv run --realtime`; implies\n"
            "--one-kernel): also samples per window the control intervals' p99.9 and max [ms] and the estimate\n"
            "catch-ups (replays, cut short), reported and not judged");
}

// What the soak's missions add up to.
struct SoakTotals {
  std::uint64_t missions = 0, cycles_done = 0, checkpoints = 0, fallbacks = 0, cold = 0, attacked = 0;
  double max_v = 0, sim_s = 0, wall_s = 0;
  bool left = false, failed = false;
  std::string stopped;  // how the last mission stopped

  void add(const kernel::SrStats& sr, const proto::RunSummary& s, const kernel::RunOutcome& outcome, std::uint64_t attacked_windows) {
    ++missions;
    cycles_done += sr.rollbacks;
    checkpoints += sr.checkpoints;
    fallbacks += sr.fallbacks;
    cold += sr.cold_restarts;
    attacked += attacked_windows;
    max_v = std::max(max_v, s.max_v());
    left = left || s.left_safety_set();
    sim_s += to_seconds(outcome.sim_time).count();
    wall_s += to_seconds(outcome.wall_time).count();
    stopped = std::string(kernel::to_string(outcome.reason)) + (outcome.detail.empty() ? "" : ": ") + outcome.detail;
  }
};

// One mission in a new kernel, sampled by `soak`, added to `t` (t.failed when it did not end as a soak's
// mission should). An exit code when the soak cannot go on (said on stderr).
std::optional<int> fly_mission(const SoakRequest& r, const kernel::KernelOptions& options, Soak& soak, SoakTotals& t) {
  auto graph = soak_graph(r.graph_path);
  if (!graph) return refuse(graph.error());
  auto reference = run_reference(*graph, options.seed);
  if (!reference) return refuse(reference.error());
  kernel::KernelOptions o = options;
  if (r.one_kernel) o.duration = to_nanos(Seconds{kLimitS}) + reference->alignment;
  RunRecorder recorder(std::move(*reference), nullptr, RunRecorder::Progress::Off);
  soak.record_with(recorder);
  auto k = kernel::Kernel::create(std::move(*graph), o, &soak);
  if (!k) {
    std::fprintf(stderr, "rejuv soak: %s\n", k.error().to_string().c_str());
    return static_cast<int>(k.error().is_bad_input() ? Exit::BadInput : Exit::Findings);
  }
  recorder.on_vehicle_lost([kernel = k->get()] { kernel->request_stop(); });
  if (auto booted = (*k)->boot(); !booted) {
    std::fprintf(stderr, "rejuv soak: %s\n", booted.error().to_string().c_str());
    soak.stop_recording();
    t.failed = true;
    t.stopped = booted.error().to_string();
    return std::nullopt;
  }
  soak.attach(**k, t.cycles_done);
  auto outcome = (*k)->run();
  (*k)->shutdown();
  soak.detach();
  soak.stop_recording();  // before this mission's recorder goes; the next mission gets its own
  if (!outcome) {
    t.failed = true;
    t.stopped = outcome.error().to_string();
    return std::nullopt;
  }
  const kernel::SrStats& sr = (*k)->sr_stats();
  proto::RunSummary s;
  recorder.fill(s, outcome->sim_time);
  t.add(sr, s, *outcome, recorder.attacked_windows());
  const bool mission_done = outcome->reason == kernel::StopReason::MissionDone && !r.one_kernel;
  const bool soak_done = outcome->reason == kernel::StopReason::Requested && soak.done();
  if (recorder.lost() || !(mission_done || soak_done)) t.failed = true;
  std::fprintf(stderr, "rejuv soak: mission %llu: %s (%llu rollbacks, %llu in all)\n",
               static_cast<unsigned long long>(t.missions), t.stopped.c_str(),
               static_cast<unsigned long long>(sr.rollbacks), static_cast<unsigned long long>(t.cycles_done));
  return std::nullopt;
}

void print_totals(const std::string& graph_name, const SoakTotals& t) {
  std::printf("%s (soak): %llu missions, the last stopped with: %s\n", graph_name.c_str(),
              static_cast<unsigned long long>(t.missions), t.stopped.c_str());
  std::printf("  flight      %.1f s simulated in %.1f s wall, max V = %.4f (%s)\n", t.sim_s, t.wall_s, t.max_v,
              t.left ? "LEFT THE SAFETY SET" : "safe");
  std::printf("  images      %llu checkpoints, %llu rollbacks (%llu fallbacks, %llu cold restarts), %llu attacked MC windows\n",
              static_cast<unsigned long long>(t.checkpoints), static_cast<unsigned long long>(t.cycles_done),
              static_cast<unsigned long long>(t.fallbacks), static_cast<unsigned long long>(t.cold),
              static_cast<unsigned long long>(t.attacked));
}

// DIR/soak.png through tools/plots/soak.gp, when gnuplot is there.
void plot(const Soak& soak, const fs::path& out, const fs::path& csv_path) {
  const std::string gp = std::string(REJUV_SOURCE_DIR) + "/tools/plots/soak.gp";
  if (soak.samples() < 2 || std::system("command -v gnuplot >/dev/null 2>&1") != 0 || !fs::exists(gp)) return;
  std::size_t rss = 0, fds = 0, maps = 0;
  for (const Series& x : soak.series()) {
    rss += x.name.ends_with("_kb") ? 1 : 0;  // the RSS and the kernel's heap: one memory panel
    fds += x.name.ends_with("_fds") ? 1 : 0;
    maps += x.name.ends_with("_maps") ? 1 : 0;
  }
  const fs::path png = out / "soak.png";
  const std::string cmd = "gnuplot -e \"csv='" + csv_path.string() + "'; png='" + png.string() +
                          "'; nrss=" + std::to_string(rss) + "; nfds=" + std::to_string(fds) +
                          "; nmaps=" + std::to_string(maps) + "; ncols=" + std::to_string(3 + soak.series().size()) +
                          "\" '" + gp + "'";
  if (std::system(cmd.c_str()) == 0) std::printf("  plot        %s\n", png.c_str());
}

// The verdict, one line per series; whether every judged series stayed in its bound.
bool print_verdict(const Soak& soak, const SoakRequest& r) {
  bool flat = true;
  const std::size_t b0 = baseline_start(soak);
  std::printf("  baseline    from sample %zu of %zu (after 10 %% of them and %.0f s of flight, %lld steps of 4 ms)\n", b0,
              soak.samples(), to_seconds(kSettleFlight).count(),
              static_cast<long long>(kSettleFlight / std::chrono::milliseconds{4}));
  std::printf("  %-26s %12s %12s %10s %10s\n", "series", "baseline", "last 20 %", "growth", "bound");
  for (const Series& x : soak.series()) {
    const Verdict v = judge(x, b0, r.kernel_rss, r.service_rss, static_cast<double>(r.maps_slack), r.one_kernel);
    if (!v.readable) {
      std::printf("  %-26s %12s\n", v.name.c_str(), "unreadable");
      continue;
    }
    if (x.kind == Series::Kind::Timing) {
      std::printf("  %-26s %12.2f %12.2f %+10.2f %10s\n", v.name.c_str(), v.baseline, v.last, v.growth, "(reported)");
      continue;
    }
    if (x.kind == Series::Kind::CycleLength) {  // seconds: two decimals
      char bound[48] = "(not judged: a kernel per mission)";
      if (!std::isnan(v.bound)) std::snprintf(bound, sizeof bound, "%10.2f", v.bound);
      std::printf("  %-26s %12.2f %12.2f %+10.2f %10s%s\n", v.name.c_str(), v.baseline, v.last, v.growth, bound,
                  v.ok ? "" : "  GREW");
      flat = flat && v.ok;
      continue;
    }
    if (std::isnan(v.bound)) {
      std::printf("  %-26s %12.0f %12.0f %+10.0f %10s\n", v.name.c_str(), v.baseline, v.last, v.growth,
                  "(not judged: sanitizer build)");
      continue;
    }
    std::printf("  %-26s %12.0f %12.0f %+10.0f %10.0f%s\n", v.name.c_str(), v.baseline, v.last, v.growth, v.bound,
                v.ok ? "" : "  GREW");
    flat = flat && v.ok;
  }
  return flat;
}

// The totals, the samples (CSV, plot) and the verdict; the exit code.
int report_soak(const SoakRequest& r, const std::string& graph_name, const SoakTotals& t, const Soak& soak,
                UniqueFile csv, const fs::path& csv_path) {
  print_totals(graph_name, t);
  soak.write_csv(csv.get());
  csv.reset();
  std::printf("  samples     %zu, written to %s\n", soak.samples(), csv_path.c_str());
  plot(soak, r.out, csv_path);
  const bool flat = print_verdict(soak, r);
  const bool reached = soak.done() && !t.failed;
  const bool safe = !t.left;
  if (!reached) std::printf("rejuv soak: FAILED: the run stopped before %llu cycles\n", static_cast<unsigned long long>(r.cycles));
  if (!safe) std::printf("rejuv soak: FAILED: the vehicle left the safety set\n");
  if (!flat) std::printf("rejuv soak: FAILED: a series grew beyond its bound (GREW above)\n");
  if (reached && safe && flat) std::printf("rejuv soak: flat over %llu cycles\n", static_cast<unsigned long long>(r.cycles));
  return static_cast<int>(reached && safe && flat ? Exit::Ok : Exit::Findings);
}

}  // namespace

int run_soak(std::span<const std::string_view> args) {
  SoakRequest r;
  Options opts("soak",
               "Soak a launch graph (docs/design.md §11): kernels in this process fly the mission with SR and its attacks\n"
               "(the closed waypoint loop repeated as often as a mission holds), one mission after the other, until\n"
               "--cycles rollbacks in all, sampling every --sample-every cycles the RSS, mappings and fds of the kernel,\n"
               "the plant and every service, the kernel's threads and children, the processes under it and in\n"
               "each service's session. Writes DIR/soak.csv (and DIR/soak.png with gnuplot). Compares the last\n"
               "20 % of the samples (at least 3) with the 20 % after a warm-up (10 % of the samples and at least\n"
               "15 000 steps, 60 s, of flight; at most half of them): the largest RSS may grow by the bounds\n"
               "below; the most frequent count (fds, threads, processes) may not rise. Exit 0 when flat, 1 when a\n"
               "series grew or the run failed (the series are named), 2 on bad input.");
  declare_soak_options(opts, r);
  if (auto exit = opts.parse_or_exit(args)) return *exit;
  if (r.every > r.cycles) {
    return refuse("rejuv soak: --sample-every: expected 1..--cycles (" + std::to_string(r.cycles) + "), got " +
                     std::to_string(r.every));
  }
  if (r.realtime && opts.given("--charge")) {
    return refuse("rejuv soak: --charge is lockstep's: in real time nothing is charged");
  }
  if (r.realtime) r.one_kernel = true;
  kernel::KernelOptions options = kernel_options(r.flags);
  if (r.realtime) options.clock = kernel::ClockMode::Realtime;
  auto domain = lease_domain(options);  // held until the soak has ended
  if (!domain) {
    std::fprintf(stderr, "rejuv soak: %s\n", domain.error().c_str());
    return 1;
  }
  auto loaded = soak_graph(r.graph_path);
  if (!loaded) return refuse(loaded.error());
  std::error_code ec;
  fs::create_directories(r.out, ec);
  const fs::path csv_path = r.out / "soak.csv";
  UniqueFile csv(std::fopen(csv_path.c_str(), "w"));
  if (!csv) return refuse("rejuv soak: cannot write " + csv_path.string());
  // One mission per kernel (default) or one kernel for the whole soak (--one-kernel: the mission, then a hover).
  if (r.one_kernel) options.stop_on_mission_done = false;
  Soak soak(r.cycles, r.every, r.realtime);
  const std::string graph_name = loaded->graph.name();
  std::fprintf(stderr, "rejuv soak: %s, %llu SR cycles, a sample every %llu, seed %llu, %s\n", graph_name.c_str(),
               static_cast<unsigned long long>(r.cycles), static_cast<unsigned long long>(r.every),
               static_cast<unsigned long long>(options.seed.value_or(loaded->graph.seed())),
               r.realtime ? "one kernel in real time" : r.one_kernel ? "one kernel" : "a new kernel for each mission");
  SoakTotals totals;
  while (!soak.done() && !totals.failed) {
    if (auto exit = fly_mission(r, options, soak, totals)) return *exit;
  }
  return report_soak(r, graph_name, totals, soak, std::move(csv), csv_path);
}

}  // namespace rejuv::cli
