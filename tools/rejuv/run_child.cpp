#include "run_child.hpp"

#include <fcntl.h>
#include <google/protobuf/util/json_util.h>

#include <fstream>
#include <sstream>

#include "rejuv/sys/fd.hpp"

extern char** environ;  // NOLINT: the environment the runtime missions inherit (CYCLONEDDS_URI, REJUV_*)

namespace rejuv::cli {
namespace {

namespace fs = std::filesystem;

std::optional<std::string> read_text(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

Result<sys::ChildProcess, std::string> start_rejuv_run(const std::vector<std::string>& args, const fs::path& log) {
  const sys::UniqueFd log_fd(::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  if (!log_fd) return fail("cannot write " + log.string());
  const sys::UniqueFd null_fd(::open("/dev/null", O_RDONLY | O_CLOEXEC));
  if (!null_fd) return fail(std::string("cannot open /dev/null"));
  std::error_code ec;
  sys::SpawnSpec spec;
  spec.executable = fs::read_symlink("/proc/self/exe", ec).string();
  if (ec) return fail("cannot find this executable: " + ec.message());
  spec.args = {"run"};
  spec.args.insert(spec.args.end(), args.begin(), args.end());
  for (char** e = environ; *e != nullptr; ++e) spec.env.emplace_back(*e);
  spec.fds = {{0, null_fd.get()}, {1, log_fd.get()}, {2, log_fd.get()}};
  auto child = sys::spawn(spec);
  if (!child) return fail("cannot start rejuv run: " + child.error().to_string());
  return std::move(*child);
}

std::optional<proto::RunSummary> read_summary(const fs::path& path) {
  const auto text = read_text(path);
  if (!text) return std::nullopt;
  proto::RunSummary s;
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = true;
  if (!google::protobuf::util::JsonStringToMessage(*text, &s, options).ok()) return std::nullopt;
  return s;
}

std::string last_progress(const fs::path& log) {
  const auto text = read_text(log);
  if (!text) return {};
  const auto at = text->rfind("rejuv run: t =");
  if (at == std::string::npos) return {};
  const auto end = text->find('\n', at);
  return text->substr(at + 11, end == std::string::npos ? std::string::npos : end - at - 11);
}

std::string log_tail(const fs::path& log, std::size_t lines) {
  const auto text = read_text(log);
  if (!text || text->empty()) return {};
  std::size_t at = text->size();
  if ((*text)[at - 1] == '\n') --at;
  for (std::size_t n = 0; n < lines && at > 0; ++n) {
    const auto nl = text->rfind('\n', at - 1);
    at = nl == std::string::npos ? 0 : nl;
    if (at == 0) break;
  }
  std::string tail = text->substr(at == 0 ? 0 : at + 1);
  while (!tail.empty() && tail.back() == '\n') tail.pop_back();
  return tail;
}

}  // namespace rejuv::cli
