#pragma once

//! \file byte_stream.h
//! \brief A TCP byte stream that is either plain or TLS (asio::ssl), behind one interface, so
//! the server's connections and the client library share their framing code.
//!
//! \details Not thread-safe: every call must come from the owning connection's strand
//! (Asio requires one write in flight per stream, and OpenSSL one thread per SSL object).

#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>
#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

namespace touchmend::rpc {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using error_code = boost::system::error_code;

class ByteStream {
 public:
  //! Plain TCP.
  explicit ByteStream(tcp::socket socket) : plain_(std::move(socket)) {}
  //! TLS over \p socket with \p context (the handshake is separate).
  ByteStream(tcp::socket socket, asio::ssl::context& context)
      : tls_(std::make_unique<asio::ssl::stream<tcp::socket>>(std::move(socket), context)) {}

  bool is_tls() const { return tls_ != nullptr; }
  tcp::socket& socket() { return tls_ ? tls_->next_layer() : *plain_; }
  asio::ssl::stream<tcp::socket>* tls() { return tls_.get(); }

  // The operations are templates, not std::function, so a handler bound to a strand
  // (asio::bind_executor) keeps its associated executor: a std::function wrapper would drop
  // it and let completions of one connection run concurrently on several I/O threads.

  template <class Handler>
  void async_handshake(asio::ssl::stream_base::handshake_type type, Handler&& handler) {
    if (!tls_) {
      asio::post(
          socket().get_executor(),
          asio::bind_executor(asio::get_associated_executor(handler, socket().get_executor()),
                              [h = std::forward<Handler>(handler)]() mutable { h(error_code{}); }));
      return;
    }
    tls_->async_handshake(type, std::forward<Handler>(handler));
  }

  template <class Handler>
  void async_read_some(asio::mutable_buffer buffer, Handler&& handler) {
    if (tls_) {
      tls_->async_read_some(buffer, std::forward<Handler>(handler));
    } else {
      plain_->async_read_some(buffer, std::forward<Handler>(handler));
    }
  }

  //! Writes all of \p buffers (one gathered write: a frame batch is one TCP send).
  template <class Handler>
  void async_write(const std::vector<asio::const_buffer>& buffers, Handler&& handler) {
    if (tls_) {
      asio::async_write(*tls_, buffers, std::forward<Handler>(handler));
    } else {
      asio::async_write(*plain_, buffers, std::forward<Handler>(handler));
    }
  }

  //! Closes the socket at once (no TLS close_notify: its shutdown can hang on a dead peer,
  //! SERVICE.md §2.1).
  void close() {
    error_code ignored;
    socket().shutdown(tcp::socket::shutdown_both, ignored);
    socket().close(ignored);
  }

 private:
  std::optional<tcp::socket> plain_;
  std::unique_ptr<asio::ssl::stream<tcp::socket>> tls_;
};

//! How long sent data may stay unacknowledged before the kernel gives up on the peer, unless
//! the caller asks for longer.
inline constexpr std::chrono::milliseconds kDefaultUserTimeout{30'000};

//! TCP_NODELAY (SERVICE.md §1.3: Nagle costs 1 ms p50 and 40 ms stalls at 1 kHz) and
//! TCP_USER_TIMEOUT \p user_timeout (a dead peer is noticed in 30 s instead of Linux's 15+
//! minutes). The kernel counts a peer that stops reading (a zero window) against it too: it
//! resets the connection once the window has stayed shut that long.
void tune_socket(tcp::socket& socket, std::chrono::milliseconds user_timeout = kDefaultUserTimeout);

}  // namespace touchmend::rpc
