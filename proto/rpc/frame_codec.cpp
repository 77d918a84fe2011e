#include "proto/rpc/frame_codec.h"

#include <google/protobuf/io/coded_stream.h>

namespace touchmend::rpc {

void append_varint(std::uint64_t value, std::string& out) {
  while (value >= 0x80) {
    out.push_back(static_cast<char>((value & 0x7F) | 0x80));
    value >>= 7;
  }
  out.push_back(static_cast<char>(value));
}

void encode_frame(const v1::Frame& frame, std::string& out) {
  const std::size_t size = frame.ByteSizeLong();
  append_varint(size, out);
  const std::size_t start = out.size();
  out.resize(start + size);
  frame.SerializeWithCachedSizesToArray(reinterpret_cast<std::uint8_t*>(out.data() + start));
}

std::string encode_frame(const v1::Frame& frame) {
  std::string out;
  encode_frame(frame, out);
  return out;
}

void FrameDecoder::feed(std::string_view bytes) {
  if (failed_) return;
  // Compact once the consumed prefix dominates, so the buffer stays about one frame long.
  if (consumed_ > 0 && consumed_ >= buffer_.size() / 2) {
    buffer_.erase(0, consumed_);
    consumed_ = 0;
  }
  buffer_.append(bytes.data(), bytes.size());
}

FrameDecoder::Result FrameDecoder::fail(StatusCode code, std::string message) {
  failed_ = true;
  error_ = Status(code, std::move(message));
  buffer_.clear();
  buffer_.shrink_to_fit();
  consumed_ = 0;
  return Result::Error;
}

FrameDecoder::Result FrameDecoder::next(v1::Frame& frame) {
  if (failed_) return Result::Error;
  const std::size_t available = buffer_.size() - consumed_;
  const auto* data = reinterpret_cast<const std::uint8_t*>(buffer_.data() + consumed_);
  std::uint64_t length = 0;
  std::size_t varint_bytes = 0;
  bool complete = false;
  for (std::size_t i = 0; i < available && i < kMaxVarintBytes; ++i) {
    length |= std::uint64_t{data[i] & 0x7Fu} << (7 * i);
    if ((data[i] & 0x80u) == 0) {
      varint_bytes = i + 1;
      complete = true;
      break;
    }
  }
  if (!complete) {
    if (available >= kMaxVarintBytes) {
      return fail(StatusCode::InvalidArgument, "frame length prefix longer than 5 bytes");
    }
    return Result::NeedMore;
  }
  if (length > max_frame_bytes_) {
    return fail(StatusCode::ResourceExhausted, "frame of " + std::to_string(length) +
                                                   " bytes exceeds the limit of " +
                                                   std::to_string(max_frame_bytes_));
  }
  if (available - varint_bytes < length) return Result::NeedMore;

  google::protobuf::io::CodedInputStream input(data + varint_bytes, static_cast<int>(length));
  input.SetRecursionLimit(32);
  frame.Clear();
  if (!frame.MergeFromCodedStream(&input) || !input.ConsumedEntireMessage()) {
    return fail(StatusCode::InvalidArgument, "frame body is not a valid touchmend.v1.Frame");
  }
  consumed_ += varint_bytes + length;
  return Result::Frame;
}

Status validate_frame(const v1::Frame& frame) {
  switch (frame.kind()) {
    case v1::HELLO:
    case v1::HELLO_ACK:
    case v1::PING:
    case v1::PONG:
    case v1::GOAWAY:
      return {};
    case v1::CALL:
      if (frame.call_id() == 0) return {StatusCode::InvalidArgument, "CALL frame with call id 0"};
      if (frame.method().empty()) return {StatusCode::InvalidArgument, "CALL frame without method"};
      if (frame.method().size() > 256) return {StatusCode::InvalidArgument, "method name too long"};
      return {};
    case v1::MESSAGE:
      if (frame.call_id() == 0)
        return {StatusCode::InvalidArgument, "MESSAGE frame with call id 0"};
      if (!frame.has_payload() && !frame.end_of_stream()) {
        return {StatusCode::InvalidArgument, "MESSAGE frame without payload or end of stream"};
      }
      return {};
    case v1::TRAILERS:
    case v1::CANCEL:
      if (frame.call_id() == 0) return {StatusCode::InvalidArgument, "frame needs a call id"};
      return {};
    default:
      return {StatusCode::Unimplemented,
              "unknown frame kind " + std::to_string(static_cast<int>(frame.kind()))};
  }
}

}  // namespace touchmend::rpc
