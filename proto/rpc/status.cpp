#include "proto/rpc/status.h"

namespace touchmend::rpc {

const char* to_string(StatusCode code) {
  switch (code) {
    case StatusCode::Ok:
      return "OK";
    case StatusCode::Cancelled:
      return "CANCELLED";
    case StatusCode::Unknown:
      return "UNKNOWN";
    case StatusCode::InvalidArgument:
      return "INVALID_ARGUMENT";
    case StatusCode::DeadlineExceeded:
      return "DEADLINE_EXCEEDED";
    case StatusCode::NotFound:
      return "NOT_FOUND";
    case StatusCode::AlreadyExists:
      return "ALREADY_EXISTS";
    case StatusCode::PermissionDenied:
      return "PERMISSION_DENIED";
    case StatusCode::ResourceExhausted:
      return "RESOURCE_EXHAUSTED";
    case StatusCode::FailedPrecondition:
      return "FAILED_PRECONDITION";
    case StatusCode::Aborted:
      return "ABORTED";
    case StatusCode::OutOfRange:
      return "OUT_OF_RANGE";
    case StatusCode::Unimplemented:
      return "UNIMPLEMENTED";
    case StatusCode::Internal:
      return "INTERNAL";
    case StatusCode::Unavailable:
      return "UNAVAILABLE";
    case StatusCode::DataLoss:
      return "DATA_LOSS";
    case StatusCode::Unauthenticated:
      return "UNAUTHENTICATED";
  }
  return "UNKNOWN";
}

StatusCode status_code_from_int(std::int32_t value) {
  if (value < 0 || value > static_cast<std::int32_t>(StatusCode::Unauthenticated)) {
    return StatusCode::Unknown;
  }
  return static_cast<StatusCode>(value);
}

std::string Status::to_string() const {
  std::string text = rpc::to_string(code);
  if (!message.empty()) {
    text += ": ";
    text += message;
  }
  return text;
}

}  // namespace touchmend::rpc
