#include "client/net/channel.h"

#include <openssl/ssl.h>

#include "proto/rpc/method_table.h"

namespace touchmend::net {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

bool parse_server_address(const std::string& text, ChannelOptions& options, std::string& error) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0) {
    error = "expected HOST:PORT, got '" + text + "'";
    return false;
  }
  std::string host = text.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  try {
    std::size_t used = 0;
    const unsigned long port = std::stoul(text.substr(colon + 1), &used);
    if (used != text.size() - colon - 1 || port == 0 || port > 65535)
      throw std::out_of_range("port");
    options.port = static_cast<std::uint16_t>(port);
  } catch (const std::exception&) {
    error = "bad port in '" + text + "'";
    return false;
  }
  options.host = host;
  return true;
}

// ---------------------------------------------------------------------------------------

void ClientCall::send(std::string payload, bool end_of_stream) {
  auto channel = channel_.lock();
  if (!channel) return;
  v1::Frame frame;
  frame.set_call_id(id_);
  frame.set_kind(v1::MESSAGE);
  frame.set_payload(std::move(payload));
  frame.set_end_of_stream(end_of_stream);
  channel->enqueue(rpc::encode_frame(frame));
}

void ClientCall::half_close() {
  auto channel = channel_.lock();
  if (!channel) return;
  v1::Frame frame;
  frame.set_call_id(id_);
  frame.set_kind(v1::MESSAGE);
  frame.set_end_of_stream(true);
  channel->enqueue(rpc::encode_frame(frame));
}

std::atomic<std::int64_t> ClientCall::alive_{0};

ClientCall::~ClientCall() {
  alive_.fetch_sub(1, std::memory_order_relaxed);
}

std::int64_t ClientCall::alive() {
  return alive_.load(std::memory_order_relaxed);
}

void ClientCall::cancel() {
  auto channel = channel_.lock();
  if (!channel) return;
  v1::Frame frame;
  frame.set_call_id(id_);
  frame.set_kind(v1::CANCEL);
  channel->enqueue(rpc::encode_frame(frame));
  // Handlers hold the channel by raw pointer: only the channel's owner may destroy it, and
  // its destructor stops and joins the network thread first (a handler owning the channel
  // would destroy the io_context from inside its own run()).
  asio::post(channel->io_, [ch = channel.get(), self = shared_from_this()] {
    if (self->done_) return;
    ch->end_call(self, {StatusCode::Cancelled, "cancelled by the client"});
  });
}

// ---------------------------------------------------------------------------------------

Channel::Channel(const ChannelOptions& options)
    : options_(options), decoder_(options.max_frame_bytes) {}

Channel::~Channel() {
  close();
  if (thread_.joinable()) {
    if (thread_.get_id() == std::this_thread::get_id()) {
      thread_.detach();
    } else {
      thread_.join();
    }
  }
}

std::shared_ptr<Channel> Channel::connect(const ChannelOptions& options, Status& status) {
  std::shared_ptr<Channel> channel(new Channel(options));
  status = channel->do_connect();
  if (!status.is_ok()) {
    channel->close();
    return nullptr;
  }
  return channel;
}

Status Channel::do_connect() {
  if (options_.tls) {
    tls_context_ = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_client);
    rpc::error_code ec;
    if (options_.tls_ca.empty()) {
      tls_context_->set_default_verify_paths(ec);
    } else {
      tls_context_->load_verify_file(options_.tls_ca, ec);
    }
    if (ec) return {StatusCode::InvalidArgument, "TLS CA " + options_.tls_ca + ": " + ec.message()};
    tls_context_->set_verify_mode(asio::ssl::verify_peer);
  }
  tcp::socket socket(io_);
  if (tls_context_) {
    stream_ = std::make_unique<rpc::ByteStream>(std::move(socket), *tls_context_);
    const std::string name =
        options_.tls_server_name.empty() ? options_.host : options_.tls_server_name;
    stream_->tls()->set_verify_callback(asio::ssl::host_name_verification(name));
    SSL_set_tlsext_host_name(stream_->tls()->native_handle(), name.c_str());
  } else {
    stream_ = std::make_unique<rpc::ByteStream>(std::move(socket));
  }
  auto done = [this](Status s) {
    std::lock_guard lock(connect_mutex_);
    if (!connect_result_) connect_result_ = std::move(s);
    connect_cv_.notify_all();
  };
  auto resolver = std::make_shared<tcp::resolver>(io_);
  resolver->async_resolve(
      options_.host, std::to_string(options_.port),
      [this, done, resolver](const rpc::error_code& ec, tcp::resolver::results_type results) {
        if (ec)
          return done(
              {StatusCode::Unavailable, "cannot resolve " + options_.host + ": " + ec.message()});
        asio::async_connect(
            stream_->socket(), results,
            [this, done](const rpc::error_code& ec2, const tcp::endpoint&) {
              if (ec2) {
                return done({StatusCode::Unavailable, "cannot connect to " + options_.host + ":" +
                                                          std::to_string(options_.port) + ": " +
                                                          ec2.message()});
              }
              rpc::tune_socket(stream_->socket());
              stream_->async_handshake(asio::ssl::stream_base::client, [this,
                                                                        done](const rpc::error_code&
                                                                                  ec3) {
                if (ec3)
                  return done({StatusCode::Unavailable, "TLS handshake failed: " + ec3.message()});
                v1::Frame hello;
                hello.set_kind(v1::HELLO);
                hello.set_protocol_version(1);
                hello.set_token(options_.token);
                enqueue(rpc::encode_frame(hello));
                read_more();
              });
            });
      });
  work_.emplace(io_.get_executor());
  thread_ = std::thread([this] { io_.run(); });
  std::unique_lock lock(connect_mutex_);
  if (!connect_cv_.wait_for(lock, options_.connect_timeout,
                            [this] { return connect_result_.has_value(); })) {
    return {StatusCode::DeadlineExceeded, "no answer from " + options_.host + ":" +
                                              std::to_string(options_.port) +
                                              " within the connect timeout"};
  }
  if (connect_result_->is_ok()) open_ = true;
  return *connect_result_;
}

void Channel::read_more() {
  stream_->async_read_some(asio::buffer(read_buffer_), [this](const rpc::error_code& ec,
                                                              std::size_t n) {
    if (closed_) return;
    if (ec) {
      Status s{StatusCode::Unavailable, ec == asio::error::eof
                                            ? "the server closed the connection"
                                            : "connection lost: " + ec.message()};
      if (!close_status_.is_ok()) s = close_status_;
      {
        std::lock_guard lock(connect_mutex_);
        if (!connect_result_) {
          connect_result_ = s;
          connect_cv_.notify_all();
        }
      }
      fail_all(s);
      return;
    }
    decoder_.feed(std::string_view(read_buffer_.data(), n));
    v1::Frame frame;
    for (;;) {
      const auto r = decoder_.next(frame);
      if (r == rpc::FrameDecoder::Result::NeedMore) break;
      if (r == rpc::FrameDecoder::Result::Error) {
        fail_all({StatusCode::Internal, "bad frame from the server: " + decoder_.error().message});
        return;
      }
      on_frame(frame);
      if (closed_) return;
    }
    read_more();
  });
}

void Channel::on_frame(v1::Frame& frame) {
  switch (frame.kind()) {
    case v1::HELLO_ACK: {
      Status s{rpc::status_code_from_int(frame.status().code()), frame.status().message()};
      principal_ = frame.principal();
      std::lock_guard lock(connect_mutex_);
      if (!connect_result_) {
        connect_result_ = s;
        connect_cv_.notify_all();
      }
      if (!s.is_ok()) close_status_ = s;
      return;
    }
    case v1::PING: {
      v1::Frame pong;
      pong.set_kind(v1::PONG);
      pong.set_ping_id(frame.ping_id());
      enqueue(rpc::encode_frame(pong));
      return;
    }
    case v1::GOAWAY:
      close_status_ = {StatusCode::Unavailable, "server: " + frame.status().message()};
      if (frame.status().code() != 0) {
        close_status_.code = rpc::status_code_from_int(frame.status().code());
      }
      return;
    case v1::MESSAGE: {
      auto it = calls_.find(frame.call_id());
      if (it == calls_.end()) return;
      if (it->second->on_message_) it->second->on_message_(std::move(*frame.mutable_payload()));
      return;
    }
    case v1::TRAILERS: {
      auto it = calls_.find(frame.call_id());
      if (it == calls_.end()) return;
      const auto call = it->second;
      end_call(call, {rpc::status_code_from_int(frame.status().code()), frame.status().message()});
      return;
    }
    default:
      return;
  }
}

void Channel::enqueue(std::string bytes) {
  asio::post(io_, [this, b = std::move(bytes)]() mutable {
    if (closed_) return;
    queue_.push_back(std::move(b));
    flush();
  });
}

void Channel::flush() {
  if (writing_ || queue_.empty() || closed_) return;
  in_flight_.clear();
  while (!queue_.empty()) {
    in_flight_.push_back(std::move(queue_.front()));
    queue_.pop_front();
  }
  std::vector<asio::const_buffer> buffers;
  for (const auto& b : in_flight_) buffers.push_back(asio::buffer(b));
  writing_ = true;
  stream_->async_write(buffers, [this](const rpc::error_code& ec, std::size_t) {
    writing_ = false;
    in_flight_.clear();
    if (ec) {
      fail_all({StatusCode::Unavailable, "connection lost: " + ec.message()});
      return;
    }
    flush();
  });
}

void Channel::fail_all(const Status& status) {
  if (closed_) return;
  closed_ = true;
  open_ = false;
  auto calls = std::move(calls_);
  calls_.clear();
  for (auto& [id, call] : calls) end_call(call, status);
  if (stream_) stream_->close();
}

void Channel::end_call(const std::shared_ptr<ClientCall>& call, const Status& status) {
  call->done_ = true;
  calls_.erase(call->id_);
  if (call->deadline_) call->deadline_->cancel();
  if (auto on_finish = std::move(call->on_finish_)) on_finish(status);
  call->on_finish_ = nullptr;
  call->on_message_ = nullptr;
}

void Channel::close() {
  if (!thread_.joinable()) return;
  asio::post(io_, [this] {
    fail_all({StatusCode::Cancelled, "the channel was closed"});
    io_.stop();
  });
  if (thread_.get_id() != std::this_thread::get_id()) thread_.join();
}

bool Channel::is_open() const {
  return open_.load();
}

std::shared_ptr<ClientCall> Channel::start_call(const std::string& method,
                                                std::optional<std::string> first,
                                                bool end_of_stream,
                                                std::chrono::milliseconds timeout,
                                                ClientCall::MessageFn on_message,
                                                ClientCall::FinishFn on_finish) {
  // Odd ids for client-opened calls (the HTTP/2 / ttrpc convention).
  const std::uint32_t id = next_call_id_.fetch_add(2);
  std::shared_ptr<ClientCall> call(
      new ClientCall(weak_from_this(), id, std::move(on_message), std::move(on_finish)));
  v1::Frame frame;
  frame.set_call_id(id);
  frame.set_kind(v1::CALL);
  frame.set_method(method.empty() || method[0] == '/' ? method : rpc::method_path(method));
  if (first) frame.set_payload(std::move(*first));
  frame.set_end_of_stream(end_of_stream);
  if (timeout.count() > 0) frame.set_timeout_ms(static_cast<std::uint32_t>(timeout.count()));
  std::string bytes = rpc::encode_frame(frame);
  if (io_.stopped()) {  // closed: answer at once rather than post to a loop that has ended
    call->done_ = true;
    if (call->on_finish_) call->on_finish_({StatusCode::Unavailable, "the channel is closed"});
    return call;
  }
  asio::post(io_, [this, call, b = std::move(bytes), timeout]() mutable {
    if (closed_) {
      call->done_ = true;
      if (call->on_finish_) {
        call->on_finish_(close_status_.is_ok() ? Status{StatusCode::Unavailable, "not connected"}
                                               : close_status_);
      }
      return;
    }
    calls_[call->id_] = call;
    queue_.push_back(std::move(b));
    flush();
    if (timeout.count() > 0) {
      // The server enforces the deadline too; this covers a server that never answers.
      call->deadline_ =
          std::make_unique<asio::steady_timer>(io_, timeout + std::chrono::milliseconds(500));
      call->deadline_->async_wait(
          [this, weak = std::weak_ptr<ClientCall>(call)](const rpc::error_code& ec) {
            const auto expired = weak.lock();
            if (ec || !expired || expired->done_) return;
            end_call(expired, {StatusCode::DeadlineExceeded, "deadline exceeded"});
          });
    }
  });
  return call;
}

Status Channel::unary(const std::string& method, const google::protobuf::MessageLite& request,
                      google::protobuf::MessageLite& response, std::chrono::milliseconds timeout) {
  struct Result {
    std::mutex mutex;
    std::condition_variable cv;
    std::optional<Status> status;
    std::optional<std::string> payload;
  };
  auto result = std::make_shared<Result>();
  start_call(
      method, request.SerializeAsString(), true, timeout,
      [result](std::string payload) {
        std::lock_guard lock(result->mutex);
        result->payload = std::move(payload);
      },
      [result](Status status) {
        std::lock_guard lock(result->mutex);
        result->status = std::move(status);
        result->cv.notify_all();
      });
  std::unique_lock lock(result->mutex);
  result->cv.wait(lock, [&] { return result->status.has_value(); });
  if (!result->status->is_ok()) return *result->status;
  if (!result->payload) return {StatusCode::Internal, "the server sent no response message"};
  if (!response.ParseFromString(*result->payload)) {
    return {StatusCode::Internal, "the server's response does not parse"};
  }
  return {};
}

void Channel::send_raw_for_testing(std::string bytes) {
  enqueue(std::move(bytes));
}

// ---------------------------------------------------------------------------------------

void StreamQueue::push(std::string payload) {
  std::lock_guard lock(mutex_);
  items_.push_back(std::move(payload));
  cv_.notify_all();
}

void StreamQueue::finish(Status status) {
  std::lock_guard lock(mutex_);
  if (!status_) status_ = std::move(status);
  cv_.notify_all();
}

bool StreamQueue::pop(std::string& payload, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  cv_.wait_for(lock, timeout, [this] { return !items_.empty() || status_.has_value(); });
  if (items_.empty()) return false;
  payload = std::move(items_.front());
  items_.pop_front();
  return true;
}

bool StreamQueue::finished() const {
  std::lock_guard lock(mutex_);
  return status_.has_value() && items_.empty();
}

Status StreamQueue::status() const {
  std::lock_guard lock(mutex_);
  return status_.value_or(Status{StatusCode::Unknown, "the stream has not ended"});
}

}  // namespace touchmend::net
