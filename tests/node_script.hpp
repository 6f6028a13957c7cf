// The tests' independent readers and clients on Node.js (tests/ulog_reader, tests/mavlink_client; installed by
// ./rejuv's set-up into build/<preset>/<name>/node_modules): start one, read what it printed as JSON.
#pragma once

#include <fcntl.h>
#include <google/protobuf/struct.pb.h>
#include <spawn.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace rejuv::test_support {

// Starts `node script args…` with `modules` as its NODE_PATH, its stdout into `out` (created or truncated).
// The child's pid, or -1.
inline pid_t start_node_script(const std::filesystem::path& script, const std::filesystem::path& modules,
                               const std::vector<std::string>& args, const std::filesystem::path& out) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  std::vector<std::string> argv_strings{"node", script.string()};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : argv_strings) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_strings{"NODE_PATH=" + modules.string()};
  for (char** e = environ; *e != nullptr; ++e) {
    if (std::string_view(*e).starts_with("NODE_PATH=")) continue;
    env_strings.emplace_back(*e);
  }
  std::vector<char*> envp;
  for (std::string& e : env_strings) envp.push_back(e.data());
  envp.push_back(nullptr);
  pid_t pid = -1;
  if (posix_spawnp(&pid, "node", &actions, nullptr, argv.data(), envp.data()) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

// A field of the script's JSON output (null when absent).
inline const google::protobuf::Value& json_at(const google::protobuf::Struct& s, const std::string& key) {
  static const google::protobuf::Value kNull;
  const auto it = s.fields().find(key);
  return it == s.fields().end() ? kNull : it->second;
}

}  // namespace rejuv::test_support
