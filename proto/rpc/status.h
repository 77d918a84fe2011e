#pragma once

//! \file status.h
//! \brief gRPC status codes (grpc/doc/statuscodes.md) and a small status value used as the
//! result type of every call, on both sides of the wire.

#include <cstdint>
#include <string>
#include <utility>

namespace touchmend::rpc {

enum class StatusCode : std::int32_t {
  Ok = 0,
  Cancelled = 1,
  Unknown = 2,
  InvalidArgument = 3,
  DeadlineExceeded = 4,
  NotFound = 5,
  AlreadyExists = 6,
  PermissionDenied = 7,
  ResourceExhausted = 8,
  FailedPrecondition = 9,
  Aborted = 10,
  OutOfRange = 11,
  Unimplemented = 12,
  Internal = 13,
  Unavailable = 14,
  DataLoss = 15,
  Unauthenticated = 16,
};

//! "OK", "INVALID_ARGUMENT", ... (the spelling of grpc/doc/statuscodes.md).
const char* to_string(StatusCode code);
//! A code read off the wire; unknown numbers become Unknown.
StatusCode status_code_from_int(std::int32_t value);

struct Status {
  StatusCode code = StatusCode::Ok;
  std::string message;

  Status() = default;
  Status(StatusCode c, std::string m) : code(c), message(std::move(m)) {}
  static Status ok() { return {}; }
  bool is_ok() const { return code == StatusCode::Ok; }
  //! "INVALID_ARGUMENT: hole 12 does not exist"
  std::string to_string() const;
};

}  // namespace touchmend::rpc
