#include "server/service/rpc_server.h"

#include <fmt/format.h>

#include "server/service/log.h"

namespace touchmend::service {

using namespace std::chrono_literals;

namespace {

v1::Frame trailers(std::uint32_t call_id, const Status& status) {
  v1::Frame f;
  f.set_call_id(call_id);
  f.set_kind(v1::TRAILERS);
  f.mutable_status()->set_code(static_cast<int>(status.code));
  f.mutable_status()->set_message(status.message);
  return f;
}

v1::Frame message_frame(std::uint32_t call_id, std::string payload) {
  v1::Frame f;
  f.set_call_id(call_id);
  f.set_kind(v1::MESSAGE);
  f.set_payload(std::move(payload));
  return f;
}

}  // namespace

// ---------------------------------------------------------------------------------------
// ServerCall

ServerCall::ServerCall(std::uint32_t id, const rpc::MethodInfo* method, std::string principal,
                       std::weak_ptr<Connection> connection, Metrics* metrics)
    : id_(id),
      method_(method),
      principal_(std::move(principal)),
      connection_(std::move(connection)),
      metrics_(metrics) {
  if (metrics_) metrics_->calls_alive.fetch_add(1, std::memory_order_relaxed);
}

ServerCall::~ServerCall() {
  if (metrics_) metrics_->calls_alive.fetch_sub(1, std::memory_order_relaxed);
}

void ServerCall::send(std::string payload) {
  if (finished()) return;
  if (auto c = connection_.lock()) {
    asio::post(c->strand_, [c, self = shared_from_this(), p = std::move(payload)]() mutable {
      c->call_send(self, std::move(p), false);
    });
  }
}

void ServerCall::send_droppable(std::string payload) {
  if (finished()) return;
  if (auto c = connection_.lock()) {
    asio::post(c->strand_, [c, self = shared_from_this(), p = std::move(payload)]() mutable {
      c->call_send(self, std::move(p), true);
    });
  }
}

void ServerCall::finish(Status status, std::optional<std::string> last_payload) {
  if (finished_.exchange(true, std::memory_order_acq_rel)) return;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  if (metrics_) {
    auto& m = metrics_->method(method_->full_name);
    (status.is_ok() ? m.ok : m.failed).fetch_add(1, std::memory_order_relaxed);
    m.latency.observe(seconds);
  }
  if (auto c = connection_.lock()) {
    asio::post(c->strand_, [c, self = shared_from_this(), s = std::move(status),
                            p = std::move(last_payload)]() mutable {
      c->call_finish(self, std::move(s), std::move(p));
    });
  }
}

void ServerCall::set_producer(std::function<std::optional<std::string>()> next) {
  if (auto c = connection_.lock()) {
    asio::post(c->strand_, [c, self = shared_from_this(), n = std::move(next)]() mutable {
      if (self->finished()) return;
      self->producer_ = std::move(n);
      c->pump();
      c->flush();
    });
  }
}

// ---------------------------------------------------------------------------------------
// Connection

Connection::Connection(std::uint64_t id, rpc::ByteStream stream, const ConnectionLimits& limits,
                       CallDispatcher& dispatcher, const Authenticator& auth, Metrics& metrics,
                       std::function<void(std::uint64_t)> on_closed)
    : id_(id),
      stream_(std::move(stream)),
      strand_(asio::make_strand(stream_.socket().get_executor())),
      limits_(limits),
      dispatcher_(dispatcher),
      auth_(auth),
      metrics_(metrics),
      on_closed_(std::move(on_closed)),
      decoder_(limits.max_frame_bytes),
      hello_timer_(strand_),
      keepalive_timer_(strand_) {
  rpc::error_code ec;
  peer_ = stream_.socket().remote_endpoint(ec);
}

void Connection::start() {
  asio::dispatch(strand_, [self = shared_from_this()] {
    // A peer that stops reading is the slow-consumer policy's (the queue limits) and the
    // keepalive's to drop: the kernel's own limit on a shut window is made no shorter than the
    // keepalive timeout (a raw subscriber in the service test, not reading for 30 s under ASan
    // and load, had its connection reset by the kernel while the server meant to keep it).
    rpc::tune_socket(self->stream_.socket(),
                     std::max(self->limits_.keepalive_timeout, rpc::kDefaultUserTimeout));
    if (self->limits_.socket_send_buffer_bytes > 0) {
      rpc::error_code ignored;
      self->stream_.socket().set_option(asio::socket_base::send_buffer_size(static_cast<int>(
                                            self->limits_.socket_send_buffer_bytes)),
                                        ignored);
    }
    // Slowloris defence: the TLS handshake and HELLO must both arrive within hello_timeout.
    self->hello_timer_.expires_after(self->limits_.hello_timeout);
    self->hello_timer_.async_wait([self](const rpc::error_code& ec) {
      if (ec || self->authenticated_ || self->closed_) return;
      self->metrics_.connections_rejected.fetch_add(1);
      log_event(spdlog::level::info, "hello_timeout",
                {{"conn_id", self->id_}, {"peer", self->peer_.address().to_string()}});
      self->close("no HELLO within the timeout");
    });
    self->stream_.async_handshake(
        asio::ssl::stream_base::server,
        asio::bind_executor(self->strand_, [self](const rpc::error_code& ec) {
          if (ec) {
            self->metrics_.connections_rejected.fetch_add(1);
            log_event(spdlog::level::info, "tls_handshake_failed",
                      {{"conn_id", self->id_}, {"error", ec.message()}});
            self->close("TLS handshake failed");
            return;
          }
          self->read_more();
          self->on_keepalive_tick();
        }));
  });
}

void Connection::read_more() {
  if (closed_ || closing_) return;
  stream_.async_read_some(
      asio::buffer(read_buffer_),
      asio::bind_executor(strand_,
                          [self = shared_from_this()](const rpc::error_code& ec, std::size_t n) {
                            self->on_read(ec, n);
                          }));
}

void Connection::on_read(const rpc::error_code& ec, std::size_t bytes) {
  if (closed_) return;
  if (ec) {
    close(ec == asio::error::eof ? "peer closed" : ec.message());
    return;
  }
  metrics_.bytes_received.fetch_add(bytes, std::memory_order_relaxed);
  last_received_ = std::chrono::steady_clock::now();
  decoder_.feed(std::string_view(read_buffer_.data(), bytes));
  v1::Frame frame;
  while (!closed_ && !closing_) {
    const auto result = decoder_.next(frame);
    if (result == rpc::FrameDecoder::Result::NeedMore) break;
    if (result == rpc::FrameDecoder::Result::Error) {
      protocol_error(decoder_.error());
      return;
    }
    metrics_.frames_received.fetch_add(1, std::memory_order_relaxed);
    handle_frame(frame);
  }
  read_more();
}

void Connection::protocol_error(Status status) {
  metrics_.protocol_errors.fetch_add(1);
  log_event(spdlog::level::warn, "protocol_error",
            {{"conn_id", id_},
             {"peer", peer_.address().to_string()},
             {"code", rpc::to_string(status.code)},
             {"msg", status.message}});
  go_away(std::move(status));
}

void Connection::handle_frame(v1::Frame& frame) {
  if (Status s = rpc::validate_frame(frame); !s.is_ok()) {
    protocol_error(std::move(s));
    return;
  }
  if (!authenticated_) {
    if (frame.kind() != v1::HELLO) {
      protocol_error({StatusCode::Unauthenticated, "the first frame must be HELLO"});
      return;
    }
    handle_hello(frame);
    return;
  }
  switch (frame.kind()) {
    case v1::HELLO:
      protocol_error({StatusCode::InvalidArgument, "HELLO sent twice"});
      return;
    case v1::PING: {
      v1::Frame pong;
      pong.set_kind(v1::PONG);
      pong.set_ping_id(frame.ping_id());
      enqueue(pong, true);
      flush();
      return;
    }
    case v1::PONG:
      return;  // last_received_ already updated
    case v1::CALL:
      handle_call(frame);
      return;
    case v1::MESSAGE: {
      auto it = calls_.find(frame.call_id());
      if (it == calls_.end()) return;  // a call that just ended or was cancelled: not an error
      CallPtr call = it->second;
      if (call->half_closed_) {
        protocol_error({StatusCode::InvalidArgument, "MESSAGE after end of stream"});
        return;
      }
      if (frame.has_payload() && call->on_message) call->on_message(frame.payload());
      if (frame.end_of_stream() && !call->half_closed_) {
        call->half_closed_ = true;
        if (call->on_half_close) call->on_half_close();
      }
      return;
    }
    case v1::CANCEL: {
      auto it = calls_.find(frame.call_id());
      if (it != calls_.end())
        cancel_call(it->second, {StatusCode::Cancelled, "cancelled by the client"}, true);
      return;
    }
    default:
      protocol_error(
          {StatusCode::InvalidArgument, std::string("unexpected frame kind from a client: ") +
                                            v1::FrameKind_Name(frame.kind())});
      return;
  }
}

void Connection::handle_hello(const v1::Frame& frame) {
  v1::Frame ack;
  ack.set_kind(v1::HELLO_ACK);
  ack.set_protocol_version(1);
  ack.set_max_frame_bytes(static_cast<std::uint32_t>(limits_.max_frame_bytes));
  if (frame.protocol_version() != 1) {
    ack.mutable_status()->set_code(static_cast<int>(StatusCode::FailedPrecondition));
    ack.mutable_status()->set_message("unsupported protocol version " +
                                      std::to_string(frame.protocol_version()) +
                                      " (server speaks 1)");
    enqueue(ack, true);
    closing_ = true;
    flush();
    return;
  }
  std::string principal;
  Status s = auth_.authenticate(frame.token(), peer_, principal);
  if (!s.is_ok()) {
    metrics_.auth_failures.fetch_add(1);
    log_event(spdlog::level::warn, "auth_failed",
              {{"conn_id", id_}, {"peer", peer_.address().to_string()}, {"msg", s.message}});
    ack.mutable_status()->set_code(static_cast<int>(s.code));
    ack.mutable_status()->set_message(s.message);
    enqueue(ack, true);
    closing_ = true;
    flush();
    return;
  }
  authenticated_ = true;
  principal_ = principal;
  call_tokens_ = limits_.max_call_burst;
  call_tokens_at_ = std::chrono::steady_clock::now();
  hello_timer_.cancel();
  ack.set_principal(principal);
  enqueue(ack, true);
  flush();
  log_event(spdlog::level::info, "connected",
            {{"conn_id", id_},
             {"peer", peer_.address().to_string()},
             {"principal", principal_},
             {"tls", stream_.is_tls()}});
}

void Connection::handle_call(v1::Frame& frame) {
  const std::uint32_t call_id = frame.call_id();
  if (calls_.count(call_id)) {
    protocol_error(
        {StatusCode::InvalidArgument, "call id " + std::to_string(call_id) + " is in use"});
    return;
  }
  const rpc::MethodInfo* method = rpc::find_method(frame.method());
  if (method == nullptr) {
    metrics_.method("unknown").started.fetch_add(1);
    enqueue(trailers(call_id, {StatusCode::Unimplemented, "unknown method " + frame.method()}));
    flush();
    return;
  }
  // The bucket fills at max_call_rate up to max_call_burst; each call takes a token.
  const auto now = std::chrono::steady_clock::now();
  call_tokens_ =
      std::min(limits_.max_call_burst,
               call_tokens_ + limits_.max_call_rate *
                                  std::chrono::duration<double>(now - call_tokens_at_).count());
  call_tokens_at_ = now;
  if (call_tokens_ < 1) {
    metrics_.call_rate_disconnects.fetch_add(1);
    log_event(spdlog::level::warn, "call_rate_exceeded",
              {{"conn_id", id_}, {"peer", peer_.address().to_string()}, {"principal", principal_}});
    // At once, so the frames read after this call are not handled (the read loop stops).
    go_away_on_strand({StatusCode::ResourceExhausted,
                       fmt::format("more than {:.0f} calls per second started on this connection",
                                   limits_.max_call_rate)});
    return;
  }
  call_tokens_ -= 1;
  if (calls_.size() >= limits_.max_concurrent_calls) {
    enqueue(trailers(call_id, {StatusCode::ResourceExhausted,
                               "more than " + std::to_string(limits_.max_concurrent_calls) +
                                   " calls open on this connection"}));
    flush();
    return;
  }
  metrics_.method(method->full_name).started.fetch_add(1, std::memory_order_relaxed);
  auto call =
      std::make_shared<ServerCall>(call_id, method, principal_, weak_from_this(), &metrics_);
  call->connection_id_ = id_;
  calls_[call_id] = call;
  if (frame.timeout_ms() > 0) {
    const auto timeout = std::min<std::chrono::milliseconds>(
        std::chrono::milliseconds(frame.timeout_ms()), limits_.max_deadline);
    call->deadline_ = std::make_unique<asio::steady_timer>(strand_, timeout);
    call->deadline_->async_wait([self = shared_from_this(), weak = std::weak_ptr<ServerCall>(call)](
                                    const rpc::error_code& ec) {
      if (ec) return;
      if (auto c = weak.lock())
        self->cancel_call(c, {StatusCode::DeadlineExceeded, "deadline exceeded"}, true);
    });
  }
  dispatcher_.start_call(call);
  if (call->finished()) return;
  if (frame.has_payload() && call->on_message) call->on_message(frame.payload());
  if (frame.end_of_stream() && !call->half_closed_) {
    call->half_closed_ = true;
    if (call->on_half_close) call->on_half_close();
  }
}

void Connection::end_call(std::uint32_t call_id) {
  auto it = calls_.find(call_id);
  if (it == calls_.end()) return;
  const CallPtr call = std::move(it->second);
  calls_.erase(it);
  if (call->deadline_) call->deadline_->cancel();
  // The handlers mostly hold the call itself (lambdas capturing it): kept, they would keep the
  // call, what they captured (an upload's bytes) and, through the call's weak reference, its
  // connection's memory for ever.
  call->producer_ = nullptr;
  call->on_message = nullptr;
  call->on_half_close = nullptr;
  call->on_cancel = nullptr;
}

void Connection::cancel_call(const CallPtr& call, Status status, bool send_trailers) {
  if (call->cancelled_.exchange(true)) return;
  auto on_cancel = std::move(call->on_cancel);
  call->on_message = nullptr;
  call->on_half_close = nullptr;
  if (on_cancel) on_cancel();
  // The call is over for the client whatever the handler still does.
  if (!call->finished_.exchange(true)) {
    metrics_.method(call->method().full_name).failed.fetch_add(1);
    if (send_trailers && !closed_) {
      enqueue(trailers(call->id(), status));
      flush();
    }
  }
  end_call(call->id());
}

void Connection::call_send(const CallPtr& call, std::string payload, bool droppable) {
  if (closed_ || !calls_.count(call->id())) return;
  if (droppable && queued_bytes_ > limits_.soft_queue_bytes) {
    metrics_.deltas_dropped.fetch_add(1, std::memory_order_relaxed);
    call->resync_pending_ = true;
    return;
  }
  enqueue(message_frame(call->id(), std::move(payload)));
  flush();
}

void Connection::call_finish(const CallPtr& call, Status status, std::optional<std::string> last) {
  if (closed_ || !calls_.count(call->id())) return;
  if (last) enqueue(message_frame(call->id(), std::move(*last)));
  enqueue(trailers(call->id(), status));
  end_call(call->id());
  flush();
}

void Connection::enqueue(const v1::Frame& frame, bool control) {
  enqueue_encoded(rpc::encode_frame(frame), control);
}

void Connection::enqueue_encoded(std::string bytes, bool control) {
  if (closed_) return;
  queued_bytes_ += bytes.size();
  (control ? control_queue_ : queue_).push_back(std::move(bytes));
  metrics_.frames_sent.fetch_add(1, std::memory_order_relaxed);
  if (queued_bytes_ > limits_.hard_queue_bytes && !closing_) {
    // A peer that does not read: stop buffering for it (SERVICE.md §1.3 slow consumer).
    metrics_.slow_consumer_disconnects.fetch_add(1);
    log_event(spdlog::level::warn, "slow_consumer_disconnect",
              {{"conn_id", id_}, {"queued_bytes", queued_bytes_}});
    queue_.clear();
    control_queue_.clear();
    queued_bytes_ = 0;
    v1::Frame goaway;
    goaway.set_kind(v1::GOAWAY);
    goaway.mutable_status()->set_code(static_cast<int>(StatusCode::ResourceExhausted));
    goaway.mutable_status()->set_message(
        "outbound queue over its limit: the client reads too slowly");
    std::string encoded = rpc::encode_frame(goaway);
    queued_bytes_ = encoded.size();
    control_queue_.push_back(std::move(encoded));
    closing_ = true;
  }
}

void Connection::flush() {
  if (writing_ || closed_) return;
  if (control_queue_.empty() && queue_.empty()) {
    if (closing_) close("closed after GOAWAY");
    return;
  }
  in_flight_.clear();
  while (!control_queue_.empty()) {
    in_flight_.push_back(std::move(control_queue_.front()));
    control_queue_.pop_front();
  }
  std::size_t batch = 0;
  while (!queue_.empty() && batch < 1 << 20) {
    batch += queue_.front().size();
    in_flight_.push_back(std::move(queue_.front()));
    queue_.pop_front();
  }
  std::vector<asio::const_buffer> buffers;
  buffers.reserve(in_flight_.size());
  for (const auto& b : in_flight_) buffers.push_back(asio::buffer(b));
  writing_ = true;
  stream_.async_write(
      buffers, asio::bind_executor(
                   strand_, [self = shared_from_this()](const rpc::error_code& ec, std::size_t) {
                     self->on_written(ec);
                   }));
}

void Connection::on_written(const rpc::error_code& ec) {
  writing_ = false;
  std::size_t written = 0;
  for (const auto& b : in_flight_) written += b.size();
  in_flight_.clear();
  queued_bytes_ = written > queued_bytes_ ? 0 : queued_bytes_ - written;
  metrics_.bytes_sent.fetch_add(written, std::memory_order_relaxed);
  if (ec) {
    close(ec.message());
    return;
  }
  if (!closing_) {
    // Subscribers whose events were dropped learn it once the queue has drained.
    if (queued_bytes_ < limits_.soft_queue_bytes / 2) {
      for (auto& [id, call] : calls_) {
        if (!call->resync_pending_ || !call->make_resync) continue;
        call->resync_pending_ = false;
        metrics_.slow_consumer_resyncs.fetch_add(1);
        enqueue(message_frame(id, call->make_resync()));
      }
    }
    pump();
  }
  flush();
}

void Connection::pump() {
  // Pull the next chunk of each producing call while the queue has room (a download never
  // holds more than a quarter of the soft limit in the queue).
  bool progress = true;
  while (progress && !closed_ && !closing_ && queued_bytes_ < limits_.soft_queue_bytes / 4) {
    progress = false;
    for (auto it = calls_.begin(); it != calls_.end();) {
      CallPtr call = it->second;
      ++it;
      if (!call->producer_) continue;
      std::optional<std::string> next = call->producer_();
      if (next) {
        enqueue(message_frame(call->id(), std::move(*next)));
        progress = true;
      } else {
        call->producer_ = nullptr;
      }
    }
  }
}

void Connection::on_keepalive_tick() {
  if (closed_) return;
  const auto now = std::chrono::steady_clock::now();
  const auto silent = now - last_received_;
  if (silent > limits_.keepalive_timeout) {
    log_event(spdlog::level::info, "keepalive_timeout", {{"conn_id", id_}});
    close("no frame from the peer within the keepalive timeout");
    return;
  }
  if (silent >= limits_.ping_interval) {
    v1::Frame ping;
    ping.set_kind(v1::PING);
    ping.set_ping_id(next_ping_id_++);
    enqueue(ping, true);
    flush();
  }
  keepalive_timer_.expires_after(limits_.ping_interval);
  keepalive_timer_.async_wait([self = shared_from_this()](const rpc::error_code& ec) {
    if (!ec) self->on_keepalive_tick();
  });
}

void Connection::go_away(Status status) {
  asio::dispatch(
      strand_, [self = shared_from_this(), s = std::move(status)] { self->go_away_on_strand(s); });
}

void Connection::go_away_on_strand(const Status& status) {
  if (closed_ || closing_) return;
  v1::Frame goaway;
  goaway.set_kind(v1::GOAWAY);
  goaway.mutable_status()->set_code(static_cast<int>(status.code));
  goaway.mutable_status()->set_message(status.message);
  enqueue(goaway, true);
  closing_ = true;
  flush();
}

void Connection::close(const std::string& reason) {
  if (closed_) return;
  closed_ = true;
  hello_timer_.cancel();
  keepalive_timer_.cancel();
  auto calls = std::move(calls_);
  calls_.clear();
  for (auto& [id, call] : calls) {
    if (call->cancelled_.exchange(true)) continue;
    call->on_message = nullptr;
    call->on_half_close = nullptr;
    if (call->deadline_) call->deadline_->cancel();
    call->producer_ = nullptr;
    if (auto on_cancel = std::move(call->on_cancel)) on_cancel();
    call->finished_.store(true);
  }
  stream_.close();
  queue_.clear();
  control_queue_.clear();
  if (authenticated_) {
    log_event(spdlog::level::info, "disconnected", {{"conn_id", id_}, {"reason", reason}});
  }
  if (on_closed_) on_closed_(id_);
}

// ---------------------------------------------------------------------------------------
// RpcServer

RpcServer::RpcServer(asio::io_context& io, CallDispatcher& dispatcher, const Authenticator& auth,
                     Metrics& metrics, ConnectionLimits limits)
    : io_(io),
      dispatcher_(dispatcher),
      auth_(auth),
      metrics_(metrics),
      limits_(limits),
      acceptor_(io) {}

Status RpcServer::listen(const tcp::endpoint& endpoint, const std::optional<TlsConfig>& tls) {
  if (tls && !tls->cert_file.empty()) {
    tls_ = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_server);
    rpc::error_code ec;
    tls_->set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                      asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                      asio::ssl::context::no_tlsv1_1 | asio::ssl::context::single_dh_use);
    tls_->use_certificate_chain_file(tls->cert_file, ec);
    if (ec)
      return {StatusCode::InvalidArgument,
              "TLS certificate " + tls->cert_file + ": " + ec.message()};
    tls_->use_private_key_file(tls->key_file, asio::ssl::context::pem, ec);
    if (ec) return {StatusCode::InvalidArgument, "TLS key " + tls->key_file + ": " + ec.message()};
  }
  rpc::error_code ec;
  acceptor_.open(endpoint.protocol(), ec);
  if (!ec) acceptor_.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor_.bind(endpoint, ec);
  if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    return {StatusCode::Unavailable, "cannot listen on " + endpoint.address().to_string() + ":" +
                                         std::to_string(endpoint.port()) + ": " + ec.message()};
  }
  accept();
  return {};
}

tcp::endpoint RpcServer::local_endpoint() const {
  rpc::error_code ec;
  return acceptor_.local_endpoint(ec);
}

void RpcServer::accept() {
  acceptor_.async_accept(io_, [this](const rpc::error_code& ec, tcp::socket socket) {
    on_accept(ec, std::move(socket));
  });
}

void RpcServer::on_accept(const rpc::error_code& ec, tcp::socket socket) {
  if (ec == asio::error::operation_aborted) return;
  {
    std::lock_guard lock(mutex_);
    if (stopped_) return;
  }
  if (!ec) {
    std::size_t open = 0;
    {
      std::lock_guard lock(mutex_);
      open = connections_.size();
    }
    if (open >= limits_.max_connections) {
      metrics_.connections_rejected.fetch_add(1);
      rpc::error_code ignored;
      socket.close(ignored);
    } else if (tls_) {
      start_connection(rpc::ByteStream(std::move(socket), *tls_));
    } else {
      start_connection(rpc::ByteStream(std::move(socket)));
    }
  }
  accept();
}

void RpcServer::start_connection(rpc::ByteStream stream) {
  std::uint64_t id;
  {
    std::lock_guard lock(mutex_);
    id = next_id_++;
  }
  metrics_.connections_accepted.fetch_add(1);
  metrics_.connections_open.fetch_add(1);
  auto connection = std::make_shared<Connection>(id, std::move(stream), limits_, dispatcher_, auth_,
                                                 metrics_, [this](std::uint64_t closed_id) {
                                                   metrics_.connections_open.fetch_sub(1);
                                                   std::lock_guard lock(mutex_);
                                                   connections_.erase(closed_id);
                                                 });
  {
    std::lock_guard lock(mutex_);
    connections_[id] = connection;
  }
  connection->start();
}

void RpcServer::shutdown(Status status) {
  std::vector<std::shared_ptr<Connection>> live;
  {
    std::lock_guard lock(mutex_);
    stopped_ = true;
    for (auto& [id, weak] : connections_) {
      if (auto c = weak.lock()) live.push_back(c);
    }
  }
  rpc::error_code ignored;
  acceptor_.close(ignored);
  for (auto& c : live) c->go_away(status);
}

}  // namespace touchmend::service
