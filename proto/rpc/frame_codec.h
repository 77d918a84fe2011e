#pragma once

//! \file frame_codec.h
//! \brief The wire framing: each frame is a touchmend.v1.Frame preceded by its length as a
//! base-128 varint (protobuf's delimited format). Socket-free so it can be unit-tested and
//! fuzzed on its own.
//!
//! \details Protobuf 3.21's ParseDelimitedFrom* helpers neither cap the length nor work
//! incrementally, so the decoder here reads the varint itself, rejects it before allocating
//! anything when it exceeds the configured maximum (SERVICE.md §1.1), and only then waits
//! for the body.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "proto/rpc/status.h"
#include "touchmend/v1/frame.pb.h"

namespace touchmend::rpc {

inline constexpr std::size_t kDefaultMaxFrameBytes = std::size_t{1} << 20;  // 1 MiB
inline constexpr std::size_t kMaxVarintBytes = 5;      // a uint32 length never needs more
inline constexpr std::size_t kChunkBytes = 64 * 1024;  //!< bulk payloads travel in these

//! Appends the varint length and the serialized frame to \p out.
void encode_frame(const v1::Frame& frame, std::string& out);
std::string encode_frame(const v1::Frame& frame);

//! Appends \p value as a base-128 varint.
void append_varint(std::uint64_t value, std::string& out);

class FrameDecoder {
 public:
  explicit FrameDecoder(std::size_t max_frame_bytes = kDefaultMaxFrameBytes)
      : max_frame_bytes_(max_frame_bytes) {}

  enum class Result { NeedMore, Frame, Error };

  //! Adds received bytes. Never buffers more than one maximal frame plus what was fed.
  void feed(std::string_view bytes);
  //! Extracts the next complete frame. After Error the decoder stays failed (the connection
  //! cannot be re-synchronised); error() says why.
  Result next(v1::Frame& frame);

  const Status& error() const { return error_; }
  std::size_t buffered_bytes() const { return buffer_.size() - consumed_; }
  std::size_t max_frame_bytes() const { return max_frame_bytes_; }

 private:
  Result fail(StatusCode code, std::string message);

  std::size_t max_frame_bytes_;
  std::string buffer_;
  std::size_t consumed_ = 0;
  bool failed_ = false;
  Status error_;
};

//! Checks the fields a frame of its kind must have (call id, method, payload...).
Status validate_frame(const v1::Frame& frame);

}  // namespace touchmend::rpc
