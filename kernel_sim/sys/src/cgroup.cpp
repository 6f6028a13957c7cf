#include "rejuv/sys/cgroup.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

namespace rejuv::sys {

namespace {

namespace fs = std::filesystem;

constexpr std::array<std::string_view, 3> kControllers{"pids", "memory", "cpu"};
// cpu.max's period: short, so that a group over its quota waits at most this long (a throttled live
// incarnation misses less than a control period's worth), at the kernel's minimum quota of 1 ms per period.
constexpr std::uint64_t kCpuPeriodUs = 10'000;
constexpr std::uint64_t kCpuMinQuotaUs = 1'000;

// A mounted cgroup hierarchy and this process's cgroup in it.
struct Hierarchy {
  fs::path mount;                        // where it is mounted
  std::string path;                      // this process's cgroup as /proc/self/cgroup names it
  bool unified = false;                  // cgroup2
  std::vector<std::string> controllers;  // v1: the controllers it carries; v2: those its root offers
  fs::path own;                          // this process's cgroup, as a directory
};

std::vector<std::string> split(const std::string& text, char by) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, by);) out.push_back(part);
  return out;
}

bool write_file(const fs::path& path, std::string_view value) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::write(fd, value.data(), value.size()) == static_cast<ssize_t>(value.size());
  ::close(fd);
  return ok;
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

bool has(const std::vector<std::string>& list, std::string_view item) {
  return std::find(list.begin(), list.end(), item) != list.end();
}

// The hierarchies from /proc/self/mountinfo (a mount's root within its file system matters in a container)
// and this process's cgroup in each from /proc/self/cgroup.
std::vector<Hierarchy> hierarchies() {
  std::vector<std::pair<std::vector<std::string>, std::string>> own;  // (controllers, path); v2: ({}, path)
  {
    std::ifstream in("/proc/self/cgroup");
    for (std::string line; std::getline(in, line);) {
      const auto first = line.find(':');
      const auto second = line.find(':', first + 1);
      if (first == std::string::npos || second == std::string::npos) continue;
      own.emplace_back(split(line.substr(first + 1, second - first - 1), ','), line.substr(second + 1));
    }
  }
  std::vector<Hierarchy> out;
  std::ifstream in("/proc/self/mountinfo");
  for (std::string line; std::getline(in, line);) {
    const auto fields = split(line, ' ');
    const auto dash = std::find(fields.begin(), fields.end(), "-");
    if (fields.size() < 5 || dash == fields.end() || dash + 1 == fields.end()) continue;
    const std::string& type = *(dash + 1);
    if (type != "cgroup" && type != "cgroup2") continue;
    const std::string& root = fields[3];
    Hierarchy h{.mount = fields[4], .path = {}, .unified = type == "cgroup2", .controllers = {}, .own = {}};
    std::optional<std::string> path;
    if (h.unified) {
      for (const auto& [controllers, p] : own) {
        if (controllers.empty() || (controllers.size() == 1 && controllers[0].empty())) path = p;
      }
    } else {
      const std::string options = dash + 2 != fields.end() && dash + 3 != fields.end() ? *(dash + 3) : "";
      for (const std::string& o : split(options, ',')) {
        if (std::find(kControllers.begin(), kControllers.end(), o) != kControllers.end()) h.controllers.push_back(o);
      }
      if (h.controllers.empty()) continue;
      for (const auto& [controllers, p] : own) {
        if (has(controllers, h.controllers.front())) path = p;
      }
    }
    if (!path) continue;
    // This process's cgroup relative to what is mounted here (a bind mount of a subtree shows its root).
    std::string relative = *path;
    if (root != "/" && relative.rfind(root, 0) == 0) relative = relative.substr(root.size());
    if (root != "/" && path->rfind(root, 0) != 0) continue;  // our cgroup is outside this mount
    h.own = h.mount / fs::path(relative).relative_path();
    h.path = *path;
    if (h.unified) h.controllers = split(read_file(h.own / "cgroup.controllers"), ' ');
    for (std::string& c : h.controllers) std::erase(c, '\n');
    out.push_back(std::move(h));
  }
  return out;
}

// v1 cpu: `dir`'s cpu.rt_runtime_us [us per second]; 0 where the hierarchy has none.
std::uint64_t rt_runtime_of(const fs::path& dir) {
  return std::strtoull(read_file(dir / "cpu.rt_runtime_us").c_str(), nullptr, 10);
}

// v1 cpu: the real-time budget of the service `dir` (its live leaf, then its own) returned to its kernel's
// directory, before the rmdir and not left to it: Linux releases a removed group only once nothing refers to it
// (a killed process not yet reaped, a slow release under load), and until then its budget counts against the
// machine's 950 ms/s, where the next kernel of this process, made at once, needs it. A zero is refused only
// while the group holds a live real-time task; by then it holds none.
void release_rt_budget(const fs::path& dir) {
  const std::uint64_t runtime = rt_runtime_of(dir);
  if (runtime == 0) return;
  for (const char* leaf : {"live", "images"}) (void)write_file(dir / leaf / "cpu.rt_runtime_us", "0");
  if (!write_file(dir / "cpu.rt_runtime_us", "0")) return;
  const std::uint64_t held = rt_runtime_of(dir.parent_path());
  (void)write_file(dir.parent_path() / "cpu.rt_runtime_us", std::to_string(held > runtime ? held - runtime : 0));
}

// A service's directory removed: its real-time budget returned, its two leaves, then itself.
void remove_service_dir(const fs::path& dir) {
  release_rt_budget(dir);
  for (const char* leaf : {"live", "images"}) (void)::rmdir((dir / leaf).c_str());
  (void)::rmdir(dir.c_str());
}

// Directories of kernels that are gone (their pid is free): left by a kernel that was killed. Empty by then
// (their processes died with it: PR_SET_PDEATHSIG), so rmdir takes them, their real-time budget returned first.
void remove_stale(const fs::path& own) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(own, ec)) {
    const std::string name = entry.path().filename().string();
    if (!name.starts_with("rejuv-") || !entry.is_directory(ec)) continue;
    const long pid = std::strtol(name.c_str() + 6, nullptr, 10);
    if (pid <= 0 || ::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    for (const auto& child : fs::directory_iterator(entry.path(), ec)) {
      if (child.is_directory(ec)) remove_service_dir(child.path());
    }
    (void)::rmdir(entry.path().c_str());
  }
}

std::string limit_value(std::string_view controller, bool unified, const CgroupLimits& l) {
  if (controller == "pids" && l.pids) return std::to_string(*l.pids);
  if (controller == "memory" && l.memory_bytes) return std::to_string(*l.memory_bytes);
  if (controller == "cpu" && l.cpu_percent) {
    const std::uint64_t quota = std::max(kCpuMinQuotaUs, std::uint64_t{*l.cpu_percent} * kCpuPeriodUs / 100);
    return unified ? std::to_string(quota) + " " + std::to_string(kCpuPeriodUs) : std::to_string(quota);
  }
  return "";
}

// Writes one controller's limit into `dir`; false if the file refused it.
bool apply(const fs::path& dir, std::string_view controller, bool unified, const CgroupLimits& l) {
  const std::string value = limit_value(controller, unified, l);
  if (controller == "pids") return write_file(dir / "pids.max", value);
  if (controller == "memory") return write_file(dir / (unified ? "memory.max" : "memory.limit_in_bytes"), value);
  // No quota: the group alone is the point. Its threads together get one group's share of a busy CPU (CFS
  // group scheduling), so that spinning threads or strays cost the other services no more than one service
  // does; a quota (CFS bandwidth control) slowed each resume by ≈ 1.3 ms (docs/sandbox.md).
  if (value.empty()) return true;
  if (unified) return write_file(dir / "cpu.max", value);
  return write_file(dir / "cpu.cfs_period_us", std::to_string(kCpuPeriodUs)) &&
         write_file(dir / "cpu.cfs_quota_us", value);
}

std::string describe(std::string_view controller, const CgroupLimits& l) {
  if (controller == "pids") return "pids.max " + std::to_string(*l.pids);
  if (controller == "memory") return "memory " + std::to_string(*l.memory_bytes >> 20U) + " MiB";
  if (!l.cpu_percent) return "cpu share";
  return "cpu " + std::to_string(*l.cpu_percent) + " % of one CPU";
}

// The kernel's directory weighs as much as its services would without cgroups: one default weight per service
// group (cpu.shares 1024 in v1, cpu.weight 100 in v2). With the default weight the services together weighed
// one process against the kernel and the rest of the machine, and on a busy CPU every rollback's resume waited
// ≈ 1 ms longer (rejuv bench images: rollback p50 1.65 ms against 0.40 ms with this weight, same build).
void weigh_kernel_group(const fs::path& parent, bool unified) {
  std::error_code ec;
  std::uint64_t groups = 0;
  for (const auto& entry : fs::directory_iterator(parent, ec)) groups += entry.is_directory(ec) ? 1 : 0;
  if (groups == 0) return;
  if (unified) {
    (void)write_file(parent / "cpu.weight", std::to_string(std::min<std::uint64_t>(10000, 100 * groups)));
  } else {
    (void)write_file(parent / "cpu.shares", std::to_string(std::min<std::uint64_t>(262144, 1024 * groups)));
  }
}

// pids and memory when limited; cpu always (its share, and a quota when one is set).
bool wanted(std::string_view controller, const CgroupLimits& l) {
  return (controller == "pids" && l.pids) || (controller == "memory" && l.memory_bytes) || controller == "cpu";
}

// The two leaves of a service's directory (the header says why) and their cgroup.procs, opened for joining. The
// errno of the failed step, the leaves and the directory removed again, when either cannot be made or opened.
struct Leaves {
  UniqueFd live_procs;
  UniqueFd images_procs;
};
Result<Leaves, int> make_leaves(const fs::path& dir) {
  const fs::path live = dir / "live";
  const fs::path kept = dir / "images";
  Leaves leaves;
  if ((::mkdir(live.c_str(), 0755) == 0 || errno == EEXIST) && (::mkdir(kept.c_str(), 0755) == 0 || errno == EEXIST)) {
    leaves.live_procs = UniqueFd(::open((live / "cgroup.procs").c_str(), O_WRONLY | O_CLOEXEC));
    if (leaves.live_procs) leaves.images_procs = UniqueFd(::open((kept / "cgroup.procs").c_str(), O_WRONLY | O_CLOEXEC));
  }
  if (leaves.live_procs && leaves.images_procs) return leaves;
  const int failed = errno;
  (void)::rmdir(live.c_str());
  (void)::rmdir(kept.c_str());
  (void)::rmdir(dir.c_str());
  return std::unexpected(failed);
}

// v1 cpu: `runtime_us` of SCHED_FIFO per second for the service `dir`, noted; false when refused (other real-time
// kernels on this machine hold the rest of its budget).
bool reserve_rt_budget(const fs::path& dir, std::uint64_t runtime_us, std::vector<std::string>& notes) {
  // The parent first (a child's budget must fit in it), then the service's own.
  const fs::path parent = dir.parent_path();
  const std::uint64_t before = rt_runtime_of(parent);
  (void)write_file(parent / "cpu.rt_runtime_us", std::to_string(std::min<std::uint64_t>(900000, before + runtime_us)));
  // And the live leaf's, where the incarnation runs: a task in a v1 group whose budget is 0 cannot be made
  // SCHED_FIFO at all (EPERM). The images leaf keeps 0: images run SCHED_OTHER (SCHED_RESET_ON_FORK).
  if (write_file(dir / "cpu.rt_runtime_us", std::to_string(runtime_us)) &&
      write_file(dir / "live" / "cpu.rt_runtime_us", std::to_string(runtime_us))) {
    notes.push_back("SCHED_FIFO " + std::to_string(runtime_us / 1000) + " ms/s (v1 cpu)");
    return true;
  }
  notes.push_back("no real-time budget (cpu.rt_runtime_us refused)");
  return false;
}

// The limits of the controllers hierarchy `h` offers that no earlier hierarchy served (`served`, `notes` grow).
// The memory controller's event file when this hierarchy limits memory.
std::optional<fs::path> apply_limits(const Hierarchy& h, const fs::path& dir, const CgroupLimits& limits,
                                     std::vector<std::string>& served, std::vector<std::string>& notes) {
  const fs::path live = dir / "live";
  std::optional<fs::path> oom_events;
  for (const auto c : kControllers) {
    if (!wanted(c, limits) || has(served, c) || !has(h.controllers, c)) continue;
    // Memory on the live leaf alone: the OOM killer of a group out of memory picks among that group's
    // processes, which are then the live incarnation and its strays, never an image.
    const bool memory = c == std::string_view("memory");
    if (!apply(memory ? live : dir, c, h.unified, limits)) continue;
    served.emplace_back(c);
    notes.push_back(describe(c, limits) + (memory ? " on the live leaf" : "") +
                    (h.unified ? " (v2)" : " (v1 " + std::string(c) + ")"));
    if (memory) {
      // v2: the live leaf out of memory loses all its processes together (the incarnation and its strays).
      if (h.unified) (void)write_file(live / "memory.oom.group", "1");
      oom_events = live / (h.unified ? "memory.events" : "memory.oom_control");
    }
  }
  return oom_events;
}

}  // namespace

ServiceCgroup& ServiceCgroup::operator=(ServiceCgroup&& other) noexcept {
  if (this != &other) {
    remove();
    dirs_ = std::move(other.dirs_);
    names_ = std::move(other.names_);
    unified_ = std::move(other.unified_);
    oom_events_ = std::move(other.oom_events_);
    join_ = std::move(other.join_);
    join_fds_ = std::move(other.join_fds_);
    images_ = std::move(other.images_);
    images_fds_ = std::move(other.images_fds_);
    description_ = std::move(other.description_);
    rt_budget_refused_ = other.rt_budget_refused_;
    other.dirs_.clear();
    other.names_.clear();
    other.unified_.reset();
    other.oom_events_.reset();
  }
  return *this;
}

SysResult<ServiceCgroup> ServiceCgroup::create(std::string_view scope, const std::string& name,
                                               const CgroupLimits& limits) {
  ServiceCgroup group;
  std::vector<std::string> served;
  std::vector<std::string> notes;
  const std::string kernel_dir = "rejuv-" + std::to_string(::getpid()) + "-" + std::string(scope);
  const auto make = [&](const Hierarchy& h) -> std::optional<fs::path> {
    remove_stale(h.own);
    const fs::path parent = h.own / kernel_dir;
    if (::mkdir(parent.c_str(), 0755) != 0 && errno != EEXIST) return std::nullopt;
    const fs::path dir = parent / name;
    if (::mkdir(dir.c_str(), 0755) != 0 && errno != EEXIST) return std::nullopt;
    return dir;
  };
  int last_errno = 0;
  auto found = hierarchies();
  // The unified hierarchy first: membership and cgroup.kill, and whichever controllers it offers.
  std::stable_partition(found.begin(), found.end(), [](const Hierarchy& h) { return h.unified; });
  for (const Hierarchy& h : found) {
    const bool useful = h.unified || std::any_of(h.controllers.begin(), h.controllers.end(), [&](const std::string& c) {
                          return wanted(c, limits) && !has(served, c);
                        });
    if (!useful) continue;
    if (h.unified) {
      // Controllers reach a child only through each parent's subtree_control (refused where the parent has
      // processes of its own and is not the root: then the v1 hierarchies or nothing).
      for (const auto c : kControllers) {
        if (!wanted(c, limits) || !has(h.controllers, c)) continue;
        (void)write_file(h.own / "cgroup.subtree_control", "+" + std::string(c));
      }
    }
    const auto dir = make(h);
    if (!dir) {
      last_errno = errno;
      notes.push_back("no cgroup in " + h.mount.string() + " (" + SysError{"mkdir", last_errno}.to_string() + ")");
      continue;
    }
    // The two leaves (the header says why). In v2 a controller reaches the leaves only through the service
    // directory's subtree_control, and the directory itself then holds no process (it has none: every
    // process joins or is moved into a leaf).
    if (h.unified && wanted("memory", limits) && !has(served, "memory") && has(h.controllers, "memory")) {
      (void)write_file(*dir / "cgroup.subtree_control", "+memory");
    }
    auto leaves = make_leaves(*dir);
    if (!leaves) {
      last_errno = leaves.error();
      continue;
    }
    if (h.unified) {
      group.unified_ = *dir;
      const fs::path parent = dir->parent_path();
      for (const auto c : kControllers) {
        if (!wanted(c, limits) || has(served, c) || !has(h.controllers, c)) continue;
        (void)write_file(parent / "cgroup.subtree_control", "+" + std::string(c));
      }
    }
    if (has(h.controllers, "cpu") && !has(served, "cpu")) {
      weigh_kernel_group(dir->parent_path(), h.unified);
      if (!h.unified && limits.rt_runtime_us) group.rt_budget_refused_ = !reserve_rt_budget(*dir, *limits.rt_runtime_us, notes);
    }
    if (auto oom_events = apply_limits(h, *dir, limits, served, notes)) group.oom_events_ = std::move(*oom_events);
    group.dirs_.push_back(*dir);
    group.names_.emplace_back(h.unified ? std::string() : h.controllers.front(),
                              (fs::path(h.path) / kernel_dir / name).string());
    group.join_fds_.push_back(leaves->live_procs.get());
    group.join_.push_back(std::move(leaves->live_procs));
    group.images_fds_.push_back(leaves->images_procs.get());
    group.images_.push_back(std::move(leaves->images_procs));
  }
  if (group.dirs_.empty()) {
    return std::unexpected(SysError{"cgroup", last_errno != 0 ? last_errno : ENOENT});
  }
  for (const auto c : kControllers) {
    if (wanted(c, limits) && !has(served, c)) notes.push_back("no " + std::string(c) + " controller");
  }
  group.description_ = std::string(group.unified_ ? "cgroup v2 (cgroup.kill)" : "cgroup v1 (no cgroup.kill)");
  for (const std::string& n : notes) group.description_ += ", " + n;
  return group;
}

SysResult<void> CgroupMove::run() const {
  const std::string text = std::to_string(pid_);
  for (const UniqueFd& procs : procs_) {
    if (::write(procs.get(), text.data(), text.size()) != static_cast<ssize_t>(text.size())) {
      return std::unexpected(SysError{"cgroup.procs", errno});
    }
  }
  return {};
}

SysResult<CgroupMove> ServiceCgroup::prepare_move(pid_t pid, CgroupLeaf leaf) const {
  std::vector<UniqueFd> procs;
  for (const int fd : procs_fds(leaf)) {
    UniqueFd copy(::fcntl(fd, F_DUPFD_CLOEXEC, 0));
    if (!copy) return std::unexpected(SysError{"dup cgroup.procs", errno});
    procs.push_back(std::move(copy));
  }
  return CgroupMove(std::move(procs), pid);
}

SysResult<void> ServiceCgroup::move(pid_t pid, CgroupLeaf leaf) const {
  const std::string text = std::to_string(pid);
  for (const int fd : procs_fds(leaf)) {
    if (::write(fd, text.data(), text.size()) != static_cast<ssize_t>(text.size())) {
      return std::unexpected(SysError{"cgroup.procs", errno});
    }
  }
  return {};
}

std::vector<pid_t> ServiceCgroup::members(CgroupLeaf leaf) const {
  std::vector<pid_t> out;
  if (dirs_.empty()) return out;
  std::ifstream in(dirs_.front() / (leaf == CgroupLeaf::Live ? "live" : "images") / "cgroup.procs");
  for (long pid = 0; in >> pid;) out.push_back(static_cast<pid_t>(pid));
  return out;
}

std::vector<pid_t> ServiceCgroup::members() const {
  std::vector<pid_t> out = members(CgroupLeaf::Live);
  const std::vector<pid_t> images = members(CgroupLeaf::Images);
  out.insert(out.end(), images.begin(), images.end());
  return out;
}

std::optional<std::uint64_t> ServiceCgroup::live_oom_kills() const {
  if (!oom_events_) return std::nullopt;
  std::ifstream in(*oom_events_);
  for (std::string key; in >> key;) {
    std::uint64_t value = 0;
    if (!(in >> value)) break;
    if (key == "oom_kill") return value;
  }
  return std::nullopt;  // a kernel older than the counter (v1 before 4.13)
}

namespace {

// The hierarchies /proc/<pid>/cgroup lists the process in ("<id>:<controllers>:<path>"): its controllers (none
// for v2) and its path.
std::vector<std::pair<std::vector<std::string>, std::string>> cgroups_of(pid_t pid) {
  std::vector<std::pair<std::vector<std::string>, std::string>> out;
  std::ifstream in("/proc/" + std::to_string(pid) + "/cgroup");
  for (std::string line; std::getline(in, line);) {
    const auto first = line.find(':');
    const auto second = first == std::string::npos ? first : line.find(':', first + 1);
    if (second == std::string::npos) continue;
    const std::string controllers = line.substr(first + 1, second - first - 1);
    out.emplace_back(controllers.empty() ? std::vector<std::string>{} : split(controllers, ','), line.substr(second + 1));
  }
  return out;
}

// Whether `cgroups` (cgroups_of) lists `name` — a controller of its hierarchy ("" for v2) and the service's
// directory — at its `leaf`.
bool listed(const std::vector<std::pair<std::vector<std::string>, std::string>>& cgroups,
            const std::pair<std::string, std::string>& name, CgroupLeaf leaf) {
  const auto& [controller, path] = name;
  const std::string want = path + (leaf == CgroupLeaf::Live ? "/live" : "/images");
  return std::any_of(cgroups.begin(), cgroups.end(), [&](const auto& c) {
    return (controller.empty() ? c.first.empty() : has(c.first, controller)) && c.second == want;
  });
}

}  // namespace

bool ServiceCgroup::in_leaf(pid_t pid, CgroupLeaf leaf) const {
  const auto v2 = std::find_if(names_.begin(), names_.end(), [](const auto& n) { return n.first.empty(); });
  return v2 != names_.end() && listed(cgroups_of(pid), *v2, leaf);
}

bool ServiceCgroup::settled_in(pid_t pid, CgroupLeaf leaf) const {
  if (names_.empty()) return false;
  const auto cgroups = cgroups_of(pid);
  return std::all_of(names_.begin(), names_.end(), [&](const auto& n) { return listed(cgroups, n, leaf); });
}

bool ServiceCgroup::kill_live() const {
  return unified_ && write_file(*unified_ / "live" / "cgroup.kill", "1");
}

void ServiceCgroup::kill_all() const {
  if (unified_ && write_file(*unified_ / "cgroup.kill", "1")) return;  // the directory and both leaves
  for (const pid_t pid : members()) ::kill(pid, SIGKILL);
}

void ServiceCgroup::remove() noexcept {
  if (dirs_.empty()) return;
  kill_all();
  join_.clear();
  join_fds_.clear();
  images_.clear();
  images_fds_.clear();
  // A killed process leaves its cgroup when it exits, before it is reaped: wait for that briefly (its exit
  // tears down its memory), then remove the directories, then the kernel's own if this was its last.
  for (int i = 0; i < 1000 && !members().empty(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  for (const fs::path& dir : dirs_) {
    remove_service_dir(dir);
    (void)::rmdir(dir.parent_path().c_str());  // fails while another service's group is there
  }
  dirs_.clear();
  unified_.reset();
  oom_events_.reset();
}

}  // namespace rejuv::sys
