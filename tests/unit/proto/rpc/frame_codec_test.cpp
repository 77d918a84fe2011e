#include "proto/rpc/frame_codec.h"

#include <random>

#include <gtest/gtest.h>

#include "proto/rpc/method_table.h"

namespace touchmend::rpc {
namespace {

v1::Frame message(std::uint32_t call, std::string payload) {
  v1::Frame f;
  f.set_call_id(call);
  f.set_kind(v1::MESSAGE);
  f.set_payload(std::move(payload));
  return f;
}

TEST(FrameCodec, RoundTripsFramesFedOneByteAtATime) {
  std::string wire;
  for (std::uint32_t i = 1; i <= 20; ++i)
    encode_frame(message(i, std::string(i * 37, 'a' + i % 26)), wire);
  FrameDecoder decoder;
  std::vector<v1::Frame> frames;
  for (char c : wire) {
    decoder.feed(std::string_view(&c, 1));
    v1::Frame f;
    while (decoder.next(f) == FrameDecoder::Result::Frame) frames.push_back(f);
  }
  ASSERT_EQ(frames.size(), 20u);
  for (std::uint32_t i = 1; i <= 20; ++i) {
    EXPECT_EQ(frames[i - 1].call_id(), i);
    EXPECT_EQ(frames[i - 1].payload().size(), i * 37);
  }
  EXPECT_EQ(decoder.buffered_bytes(), 0u);
}

TEST(FrameCodec, TheLengthPrefixIsProtobufsDelimitedVarint) {
  const std::string wire = encode_frame(message(1, std::string(300, 'x')));
  const v1::Frame f = message(1, std::string(300, 'x'));
  const std::size_t body = f.ByteSizeLong();
  ASSERT_GT(body, 127u);  // a two-byte varint
  EXPECT_EQ(static_cast<unsigned char>(wire[0]), (body & 0x7F) | 0x80);
  EXPECT_EQ(static_cast<unsigned char>(wire[1]), body >> 7);
  EXPECT_EQ(wire.size(), body + 2);
}

TEST(FrameCodec, RejectsAnOversizedLengthBeforeReadingTheBody) {
  FrameDecoder decoder(1024);
  std::string wire;
  append_varint(1025, wire);
  decoder.feed(wire);
  v1::Frame f;
  EXPECT_EQ(decoder.next(f), FrameDecoder::Result::Error);
  EXPECT_EQ(decoder.error().code, StatusCode::ResourceExhausted);
  EXPECT_EQ(decoder.buffered_bytes(), 0u);
  // Stays failed.
  decoder.feed(encode_frame(message(1, "x")));
  EXPECT_EQ(decoder.next(f), FrameDecoder::Result::Error);
}

TEST(FrameCodec, RejectsAVarintLongerThanFiveBytes) {
  FrameDecoder decoder;
  decoder.feed(std::string("\x80\x80\x80\x80\x80\x01", 6));
  v1::Frame f;
  EXPECT_EQ(decoder.next(f), FrameDecoder::Result::Error);
  EXPECT_EQ(decoder.error().code, StatusCode::InvalidArgument);
}

TEST(FrameCodec, ATruncatedFrameWaitsForMore) {
  const std::string wire = encode_frame(message(3, "hello"));
  FrameDecoder decoder;
  decoder.feed(std::string_view(wire).substr(0, wire.size() - 1));
  v1::Frame f;
  EXPECT_EQ(decoder.next(f), FrameDecoder::Result::NeedMore);
  decoder.feed(std::string_view(wire).substr(wire.size() - 1));
  EXPECT_EQ(decoder.next(f), FrameDecoder::Result::Frame);
  EXPECT_EQ(f.payload(), "hello");
}

TEST(FrameCodec, RandomBytesNeverCrashAndNeverBufferPastTheLimit) {
  std::mt19937 rng(12345);
  for (int trial = 0; trial < 2000; ++trial) {
    FrameDecoder decoder(4096);
    std::string bytes(rng() % 600, '\0');
    for (auto& c : bytes) c = static_cast<char>(rng());
    decoder.feed(bytes);
    v1::Frame f;
    for (int i = 0; i < 100; ++i) {
      const auto r = decoder.next(f);
      if (r != FrameDecoder::Result::Frame) break;
      (void)validate_frame(f);
    }
    EXPECT_LE(decoder.buffered_bytes(), bytes.size());
  }
}

TEST(FrameCodec, ValidationNamesWhatIsMissing) {
  v1::Frame call;
  call.set_kind(v1::CALL);
  EXPECT_EQ(validate_frame(call).code, StatusCode::InvalidArgument);
  call.set_call_id(1);
  EXPECT_EQ(validate_frame(call).code, StatusCode::InvalidArgument);  // no method
  call.set_method("/touchmend.v1.Repair/Health");
  EXPECT_TRUE(validate_frame(call).is_ok());
  v1::Frame empty_message;
  empty_message.set_kind(v1::MESSAGE);
  empty_message.set_call_id(1);
  EXPECT_FALSE(validate_frame(empty_message).is_ok());
  v1::Frame unknown;
  unknown.set_kind(static_cast<v1::FrameKind>(77));
  EXPECT_EQ(validate_frame(unknown).code, StatusCode::Unimplemented);
}

TEST(MethodTable, ComesFromTheServiceDescriptor) {
  const auto* fill = find_method("/touchmend.v1.Repair/FillHoles");
  ASSERT_NE(fill, nullptr);
  EXPECT_FALSE(fill->client_streaming);
  EXPECT_FALSE(fill->server_streaming);
  const auto* interact = find_method(method_path("Interact"));
  ASSERT_NE(interact, nullptr);
  EXPECT_TRUE(interact->client_streaming);
  EXPECT_TRUE(interact->server_streaming);
  const auto* upload = find_method(method_path("UploadMesh"));
  ASSERT_NE(upload, nullptr);
  EXPECT_TRUE(upload->client_streaming);
  EXPECT_FALSE(upload->server_streaming);
  EXPECT_EQ(find_method("/touchmend.v1.Repair/Nope"), nullptr);
  EXPECT_EQ(repair_methods().size(), 27u);
}

TEST(Status, SpellsTheGrpcNames) {
  EXPECT_STREQ(to_string(StatusCode::ResourceExhausted), "RESOURCE_EXHAUSTED");
  EXPECT_EQ(status_code_from_int(99), StatusCode::Unknown);
  EXPECT_EQ(Status(StatusCode::NotFound, "no hole 3").to_string(), "NOT_FOUND: no hole 3");
}

}  // namespace
}  // namespace touchmend::rpc
