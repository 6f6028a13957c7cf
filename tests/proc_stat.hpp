// /proc/<pid>/stat as the tests read it (proc(5)): "pid (comm) state ppid …". The command name may hold
// anything, spaces and parentheses included, so the fields after it are found from the last ')'.
#pragma once

#include <sys/types.h>

#include <charconv>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace rejuv::test_support {

// What /proc/<pid>/stat says now: the state letter, the parent's pid and the fields after the command name
// ({'?', 0, {}}: the process is gone or the file unreadable).
struct ProcStat {
  char state = '?';
  pid_t parent = 0;
  std::vector<std::string> fields;  // proc(5)'s fields 3 (state) on, as text

  // Field `n` as proc(5) numbers them (3 is the state, 4 the parent, 41 the scheduling policy) as an integer;
  // nullopt when it is not there (n < 3, past the end) or not a number.
  [[nodiscard]] std::optional<long long> number(std::size_t n) const {
    if (n < 3 || n - 3 >= fields.size()) return std::nullopt;
    const std::string& f = fields[n - 3];
    long long v = 0;
    const auto [end, ec] = std::from_chars(f.data(), f.data() + f.size(), v);
    if (ec != std::errc{} || end != f.data() + f.size()) return std::nullopt;
    return v;
  }
  // Running or sleeping: not gone, not a zombie ('Z') and not dead ('X').
  [[nodiscard]] bool living() const { return state != '?' && state != 'Z' && state != 'X'; }
};

inline ProcStat proc_stat(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::stringstream text;
  text << in.rdbuf();
  const std::string stat = text.str();
  const std::size_t close = stat.rfind(')');
  if (close == std::string::npos || close + 2 >= stat.size()) return {};
  ProcStat out;
  std::istringstream rest(stat.substr(close + 2));
  for (std::string f; rest >> f;) out.fields.push_back(std::move(f));
  if (out.fields.empty() || out.fields[0].size() != 1) return {};
  out.state = out.fields[0][0];
  out.parent = static_cast<pid_t>(out.number(4).value_or(0));
  return out;
}

}  // namespace rejuv::test_support
