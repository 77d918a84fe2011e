#pragma once

//! \file rpc_server.h
//! \brief The server side of the wire protocol (proto/README.md): accepting TCP or TLS
//! connections, the HELLO handshake, multiplexed calls with deadlines and cancellation,
//! heartbeats, frame limits and a bounded outbound queue per connection.
//!
//! \details Each connection runs on its own strand of the network io_context. The service
//! layer sees only ServerCall: it installs callbacks on it and answers through it from any
//! thread (answers are posted to the connection's strand). Limits follow SERVICE.md §7.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <string_view>

#include "proto/rpc/byte_stream.h"
#include "proto/rpc/frame_codec.h"
#include "proto/rpc/method_table.h"
#include "proto/rpc/status.h"
#include "server/service/metrics.h"

namespace touchmend::service {

using rpc::Status;
using rpc::StatusCode;
namespace asio = boost::asio;
using tcp = asio::ip::tcp;

struct ConnectionLimits {
  std::size_t max_frame_bytes = rpc::kDefaultMaxFrameBytes;
  std::size_t max_concurrent_calls = 100;
  //! Calls a connection may start per second, sustained, and in a burst (a token bucket,
  //! SERVICE.md §5.3 "Open/cancel storm"): past them the connection gets GOAWAY
  //! RESOURCE_EXHAUSTED and is closed. Far above the station's pushes (one per tool step, each
  //! a round trip) and a batch client's calls; an open/cancel storm passes them within a second.
  double max_call_rate = 5'000;
  double max_call_burst = 10'000;
  std::chrono::milliseconds hello_timeout{10'000};
  std::chrono::milliseconds ping_interval{5'000};
  std::chrono::milliseconds keepalive_timeout{20'000};
  std::chrono::milliseconds max_deadline{30'000 * 20};   //!< cap on a client's timeout_ms
  std::size_t soft_queue_bytes = std::size_t{4} << 20;   //!< above: droppable events are dropped
  std::size_t hard_queue_bytes = std::size_t{16} << 20;  //!< above: the connection is closed
  std::size_t max_connections = 10'000;
  //! SO_SNDBUF of each connection (0: the kernel's autotuning, which lets several MiB per
  //! connection pile up in the kernel, out of reach of the slow-consumer policy).
  std::size_t socket_send_buffer_bytes = std::size_t{1} << 20;
};

//! Decides who a HELLO's token belongs to.
class Authenticator {
 public:
  virtual ~Authenticator() = default;
  //! Returns the principal, or an UNAUTHENTICATED status.
  virtual Status authenticate(const std::string& token, const tcp::endpoint& peer,
                              std::string& principal) const = 0;
};

class Connection;

class ServerCall : public std::enable_shared_from_this<ServerCall> {
 public:
  ServerCall(std::uint32_t id, const rpc::MethodInfo* method, std::string principal,
             std::weak_ptr<Connection> connection, Metrics* metrics);

  ~ServerCall();
  ServerCall(const ServerCall&) = delete;
  ServerCall& operator=(const ServerCall&) = delete;
  std::uint32_t id() const { return id_; }
  const rpc::MethodInfo& method() const { return *method_; }
  const std::string& principal() const { return principal_; }
  std::uint64_t connection_id() const { return connection_id_; }

  // ---- answers: callable from any thread; ignored once the call is over ----
  void send(std::string payload);
  //! An event that may be dropped when the connection's queue is over its soft limit; the
  //! subscriber then gets make_resync()'s payload once the queue has drained.
  void send_droppable(std::string payload);
  void finish(Status status, std::optional<std::string> last_payload = std::nullopt);
  //! Pull-based streaming: \p next is called on the connection's strand whenever the queue
  //! has room; it returns the next payload, or nullopt when it has finished the call.
  void set_producer(std::function<std::optional<std::string>()> next);

  bool cancelled() const { return cancelled_.load(std::memory_order_acquire); }
  bool finished() const { return finished_.load(std::memory_order_acquire); }

  // ---- set by the handler when the call starts (called on the connection's strand) ----
  std::function<void(std::string_view payload)> on_message;
  std::function<void()> on_half_close;
  std::function<void()> on_cancel;  //!< client CANCEL, deadline, or the connection closed
  std::function<std::string()> make_resync;

 private:
  friend class Connection;
  std::uint32_t id_;
  const rpc::MethodInfo* method_;
  std::string principal_;
  std::weak_ptr<Connection> connection_;
  Metrics* metrics_;
  std::uint64_t connection_id_ = 0;
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  std::atomic<bool> cancelled_{false};
  std::atomic<bool> finished_{false};
  // Connection-strand state.
  bool half_closed_ = false;
  bool resync_pending_ = false;
  std::function<std::optional<std::string>()> producer_;
  std::unique_ptr<asio::steady_timer> deadline_;
};

using CallPtr = std::shared_ptr<ServerCall>;

//! What the connection hands new calls to (the repair service).
class CallDispatcher {
 public:
  virtual ~CallDispatcher() = default;
  //! Installs the call's callbacks (on the connection's strand, before any message).
  virtual void start_call(const CallPtr& call) = 0;
};

class Connection : public std::enable_shared_from_this<Connection> {
 public:
  Connection(std::uint64_t id, rpc::ByteStream stream, const ConnectionLimits& limits,
             CallDispatcher& dispatcher, const Authenticator& auth, Metrics& metrics,
             std::function<void(std::uint64_t)> on_closed);
  void start();
  //! Graceful close: GOAWAY with \p status, then close once written. Any thread.
  void go_away(Status status);
  std::uint64_t id() const { return id_; }

 private:
  friend class ServerCall;
  using Strand = asio::strand<asio::any_io_executor>;
  //! go_away from the strand: the GOAWAY is queued before the caller goes on.
  void go_away_on_strand(const Status& status);

  void read_more();
  void on_read(const rpc::error_code& ec, std::size_t bytes);
  void handle_frame(v1::Frame& frame);
  void handle_hello(const v1::Frame& frame);
  void handle_call(v1::Frame& frame);
  void end_call(std::uint32_t call_id);
  void cancel_call(const CallPtr& call, Status status, bool send_trailers);
  void protocol_error(Status status);
  void enqueue(const v1::Frame& frame, bool control = false);
  void enqueue_encoded(std::string bytes, bool control);
  void flush();
  void on_written(const rpc::error_code& ec);
  void pump();
  void on_keepalive_tick();
  void close(const std::string& reason);

  // From ServerCall (posted onto the strand).
  void call_send(const CallPtr& call, std::string payload, bool droppable);
  void call_finish(const CallPtr& call, Status status, std::optional<std::string> last);

  std::uint64_t id_;
  rpc::ByteStream stream_;
  Strand strand_;
  ConnectionLimits limits_;
  CallDispatcher& dispatcher_;
  const Authenticator& auth_;
  Metrics& metrics_;
  std::function<void(std::uint64_t)> on_closed_;
  tcp::endpoint peer_;

  rpc::FrameDecoder decoder_;
  std::array<char, 64 * 1024> read_buffer_{};
  bool authenticated_ = false;
  std::string principal_;
  bool closing_ = false;  // GOAWAY queued: stop reading, close after the write
  bool closed_ = false;
  std::map<std::uint32_t, CallPtr> calls_;

  std::deque<std::string> control_queue_;
  std::deque<std::string> queue_;
  std::vector<std::string> in_flight_;
  std::size_t queued_bytes_ = 0;
  bool writing_ = false;

  asio::steady_timer hello_timer_;
  asio::steady_timer keepalive_timer_;
  std::chrono::steady_clock::time_point last_received_ = std::chrono::steady_clock::now();
  std::uint64_t next_ping_id_ = 1;
  double call_tokens_ = 0;  // the call-rate bucket (ConnectionLimits::max_call_rate), set at HELLO
  std::chrono::steady_clock::time_point call_tokens_at_;
};

struct TlsConfig {
  std::string cert_file;
  std::string key_file;
};

class RpcServer {
 public:
  RpcServer(asio::io_context& io, CallDispatcher& dispatcher, const Authenticator& auth,
            Metrics& metrics, ConnectionLimits limits);
  //! Binds and starts accepting. TLS when \p tls has a certificate.
  Status listen(const tcp::endpoint& endpoint, const std::optional<TlsConfig>& tls);
  tcp::endpoint local_endpoint() const;
  //! Stops accepting and sends GOAWAY on every connection.
  void shutdown(Status status);

 private:
  void accept();
  void on_accept(const rpc::error_code& ec, tcp::socket socket);
  void start_connection(rpc::ByteStream stream);

  asio::io_context& io_;
  CallDispatcher& dispatcher_;
  const Authenticator& auth_;
  Metrics& metrics_;
  ConnectionLimits limits_;
  tcp::acceptor acceptor_;
  std::unique_ptr<asio::ssl::context> tls_;
  std::mutex mutex_;
  std::map<std::uint64_t, std::weak_ptr<Connection>> connections_;
  std::uint64_t next_id_ = 1;
  bool stopped_ = false;
};

}  // namespace touchmend::service
