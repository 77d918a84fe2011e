#pragma once

//! \file channel.h
//! \brief The client end of the wire protocol (proto/README.md): one connection (TCP or TLS)
//! carrying many calls, with deadlines, cancellation and PING answers. Its own network thread
//! runs all socket work; calls may be made from any thread.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <google/protobuf/message_lite.h>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "proto/rpc/byte_stream.h"
#include "proto/rpc/frame_codec.h"
#include "proto/rpc/status.h"

namespace touchmend::net {

using rpc::Status;
using rpc::StatusCode;

struct ChannelOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 7878;
  std::string token;  //!< bearer token (servers started with --tokens need one)
  bool tls = false;
  std::string tls_ca;  //!< PEM CA file to verify the server with (TLS only; empty: system CAs)
  std::string tls_server_name;  //!< expected certificate name (default: host)
  std::chrono::milliseconds connect_timeout{10'000};
  std::size_t max_frame_bytes = rpc::kDefaultMaxFrameBytes;
};

//! Parses "HOST:PORT" into \p options (host and port only).
bool parse_server_address(const std::string& text, ChannelOptions& options, std::string& error);

class Channel;

//! One call. Callbacks run on the channel's network thread and must not block.
class ClientCall : public std::enable_shared_from_this<ClientCall> {
 public:
  using MessageFn = std::function<void(std::string payload)>;
  using FinishFn = std::function<void(Status)>;

  void send(std::string payload, bool end_of_stream = false);
  void half_close();
  void cancel();
  std::uint32_t id() const { return id_; }
  ~ClientCall();
  //! Calls in memory in this process (all channels): a call is freed once it has ended and its
  //! owner let go of it (for tests and diagnostics).
  static std::int64_t alive();

 private:
  friend class Channel;
  ClientCall(std::weak_ptr<Channel> channel, std::uint32_t id, MessageFn on_message,
             FinishFn on_finish)
      : channel_(std::move(channel)),
        id_(id),
        on_message_(std::move(on_message)),
        on_finish_(std::move(on_finish)) {
    alive_.fetch_add(1, std::memory_order_relaxed);
  }
  static std::atomic<std::int64_t> alive_;
  std::weak_ptr<Channel> channel_;
  std::uint32_t id_;
  MessageFn on_message_;
  FinishFn on_finish_;
  bool done_ = false;  // network thread only
  //! The client's own deadline (start_call's timeout), cancelled when the call ends: waiting
  //! out the timeout it kept every finished call (and its callbacks) for that long, a minute by
  //! default: at the station's push rate, over a hundred thousand of them.
  std::unique_ptr<boost::asio::steady_timer> deadline_;
};

class Channel : public std::enable_shared_from_this<Channel> {
 public:
  //! Connects, handshakes (TLS), authenticates (HELLO). Blocks up to connect_timeout.
  static std::shared_ptr<Channel> connect(const ChannelOptions& options, Status& status);
  ~Channel();
  Channel(const Channel&) = delete;
  Channel& operator=(const Channel&) = delete;

  //! Closes the connection; open calls finish with UNAVAILABLE.
  void close();
  bool is_open() const;
  const std::string& principal() const { return principal_; }
  const ChannelOptions& options() const { return options_; }

  //! Opens a call for \p method ("/touchmend.v1.Repair/X" or just "X"). \p first is sent in
  //! the CALL frame. timeout 0 = no deadline.
  std::shared_ptr<ClientCall> start_call(const std::string& method,
                                         std::optional<std::string> first, bool end_of_stream,
                                         std::chrono::milliseconds timeout,
                                         ClientCall::MessageFn on_message,
                                         ClientCall::FinishFn on_finish);

  //! Blocking unary call.
  Status unary(const std::string& method, const google::protobuf::MessageLite& request,
               google::protobuf::MessageLite& response,
               std::chrono::milliseconds timeout = std::chrono::milliseconds(60'000));

  //! Sends raw bytes on the socket (tests of malformed input only).
  void send_raw_for_testing(std::string bytes);

 private:
  friend class ClientCall;
  explicit Channel(const ChannelOptions& options);
  Status do_connect();
  void read_more();
  void on_frame(v1::Frame& frame);
  void enqueue(std::string bytes);
  void flush();
  void fail_all(const Status& status);
  //! Ends \p call (network thread): out of calls_, its deadline cancelled, on_finish_ told
  //! \p status, its callbacks dropped.
  void end_call(const std::shared_ptr<ClientCall>& call, const Status& status);

  ChannelOptions options_;
  boost::asio::io_context io_;
  //! Keeps io_.run() going after the connection drops, so later calls still complete (with
  //! UNAVAILABLE) instead of waiting on a loop that has returned.
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
  std::unique_ptr<boost::asio::ssl::context> tls_context_;
  std::unique_ptr<rpc::ByteStream> stream_;
  std::thread thread_;
  std::string principal_;
  rpc::FrameDecoder decoder_;
  std::array<char, 64 * 1024> read_buffer_{};
  // Network-thread state.
  std::map<std::uint32_t, std::shared_ptr<ClientCall>> calls_;
  std::deque<std::string> queue_;
  std::vector<std::string> in_flight_;
  bool writing_ = false;
  bool closed_ = false;
  Status close_status_;
  std::atomic<bool> open_{false};
  std::atomic<std::uint32_t> next_call_id_{1};
  // Connect handshake.
  std::mutex connect_mutex_;
  std::condition_variable connect_cv_;
  std::optional<Status> connect_result_;
};

//! Collects a server stream's messages for a reader on another thread.
class StreamQueue {
 public:
  void push(std::string payload);
  void finish(Status status);
  //! Next message; false when the stream has ended (then status() says how) or on timeout.
  bool pop(std::string& payload, std::chrono::milliseconds timeout);
  bool finished() const;
  Status status() const;

 private:
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::string> items_;
  std::optional<Status> status_;
};

}  // namespace touchmend::net
