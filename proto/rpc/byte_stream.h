#pragma once

//! \file byte_stream.h
//! \brief A TCP byte stream that is either plain or TLS (asio::ssl), behind one interface, so
//! the server's connections and the client library share their framing code.
//!
//! \details Not thread-safe: every call must come from the owning connection's strand
//! (Asio requires one write in flight per stream, and OpenSSL one thread per SSL object).

#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>

namespace touchmend::rpc {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using error_code = boost::system::error_code;

class ByteStream {
 public:
  using Handler = std::function<void(const error_code&, std::size_t)>;

  //! Plain TCP.
  explicit ByteStream(tcp::socket socket) : plain_(std::move(socket)) {}
  //! TLS over \p socket with \p context (the handshake is separate).
  ByteStream(tcp::socket socket, asio::ssl::context& context)
      : tls_(std::make_unique<asio::ssl::stream<tcp::socket>>(std::move(socket), context)) {}

  bool is_tls() const { return tls_ != nullptr; }
  tcp::socket& socket() { return tls_ ? tls_->next_layer() : *plain_; }
  asio::ssl::stream<tcp::socket>* tls() { return tls_.get(); }

  void async_handshake(asio::ssl::stream_base::handshake_type type,
                       std::function<void(const error_code&)> handler) {
    if (!tls_) {
      handler({});
      return;
    }
    tls_->async_handshake(type, std::move(handler));
  }

  void async_read_some(asio::mutable_buffer buffer, Handler handler) {
    if (tls_) {
      tls_->async_read_some(buffer, std::move(handler));
    } else {
      plain_->async_read_some(buffer, std::move(handler));
    }
  }

  //! Writes all of \p buffers (one gathered write: a frame batch is one TCP send).
  void async_write(const std::vector<asio::const_buffer>& buffers, Handler handler) {
    if (tls_) {
      asio::async_write(*tls_, buffers, std::move(handler));
    } else {
      asio::async_write(*plain_, buffers, std::move(handler));
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

//! TCP_NODELAY (SERVICE.md §1.3: Nagle costs 1 ms p50 and 40 ms stalls at 1 kHz) and
//! TCP_USER_TIMEOUT (a dead peer is noticed in 30 s instead of Linux's 15+ minutes).
void tune_socket(tcp::socket& socket);

}  // namespace touchmend::rpc
