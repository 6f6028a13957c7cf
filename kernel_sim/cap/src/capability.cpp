#include "rejuv/cap/capability.hpp"

namespace rejuv::cap {

std::string_view to_string(Operation op) {
  switch (op) {
    case Operation::Publish: return "Publish";
    case Operation::Subscribe: return "Subscribe";
    case Operation::CheckpointCreate: return "CheckpointCreate";
    case Operation::CheckpointRollback: return "CheckpointRollback";
    case Operation::TimerArm: return "TimerArm";
    case Operation::NetSend: return "NetSend";
    case Operation::NetReceive: return "NetReceive";
    case Operation::LimitsWrite: return "LimitsWrite";
    case Operation::LimitsRead: return "LimitsRead";
    case Operation::PersistentRead: return "PersistentRead";
    case Operation::PersistentWrite: return "PersistentWrite";
    case Operation::ModeRequest: return "ModeRequest";
    case Operation::Copy: return "Copy";
    case Operation::Mint: return "Mint";
    case Operation::Revoke: return "Revoke";
    case Operation::Delete: return "Delete";
  }
  return "?";
}

std::optional<Operation> operation_from_wire(std::uint8_t value) {
  if (value >= kOperationCount) {
    return std::nullopt;
  }
  return kAllOperations[value];
}

std::string_view to_string(CapError error) {
  switch (error) {
    case CapError::NoSuchService: return "NoSuchService";
    case CapError::SlotOutOfRange: return "SlotOutOfRange";
    case CapError::EmptySlot: return "EmptySlot";
    case CapError::SlotOccupied: return "SlotOccupied";
    case CapError::ReservedSlot: return "ReservedSlot";
    case CapError::CSpaceFull: return "CSpaceFull";
    case CapError::WrongObject: return "WrongObject";
    case CapError::InsufficientRights: return "InsufficientRights";
    case CapError::BadArgument: return "BadArgument";
    case CapError::NoSuchObject: return "NoSuchObject";
  }
  return "?";
}

}  // namespace rejuv::cap
