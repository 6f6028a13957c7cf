#include "rejuv/core/vocabulary.hpp"

namespace rejuv {

std::string_view to_string(ObjectKind kind) {
  switch (kind) {
    case ObjectKind::Topic: return "Topic";
    case ObjectKind::Checkpoint: return "Checkpoint";
    case ObjectKind::Network: return "Network";
    case ObjectKind::Limits: return "Limits";
    case ObjectKind::Persistent: return "Persistent";
    case ObjectKind::Mode: return "Mode";
  }
  return "?";
}

std::string_view to_string(SrMode mode) {
  switch (mode) {
    case SrMode::MC: return "MC";
    case SrMode::RB: return "RB";
    case SrMode::SC: return "SC";
    case SrMode::Update: return "UPDATE";
    case SrMode::CP: return "CP";
  }
  return "?";
}

std::optional<Rights> Rights::parse(std::string_view letters) {
  if (letters.empty()) {
    return std::nullopt;
  }
  Rights result;
  for (const char c : letters) {
    Right r{};
    switch (c) {
      case 'R': r = Right::Read; break;
      case 'W': r = Right::Write; break;
      case 'G': r = Right::Grant; break;
      default: return std::nullopt;
    }
    if (result.has(r)) {
      return std::nullopt;  // "RR": a typo, not a right
    }
    result = result | r;
  }
  return result;
}

std::string Rights::to_string() const {
  std::string s = "---";
  if (has(Right::Read)) s[0] = 'R';
  if (has(Right::Write)) s[1] = 'W';
  if (has(Right::Grant)) s[2] = 'G';
  return s;
}

std::string Rights::letters() const {
  std::string s;
  if (has(Right::Read)) s += 'R';
  if (has(Right::Write)) s += 'W';
  if (has(Right::Grant)) s += 'G';
  return s;
}

std::string ModeSet::to_string() const {
  std::string s;
  for (const SrMode m : kAllModes) {
    if (has(m)) {
      if (!s.empty()) s += ',';
      s += rejuv::to_string(m);
    }
  }
  return s;
}

}  // namespace rejuv
