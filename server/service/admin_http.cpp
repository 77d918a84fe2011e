#include "server/service/admin_http.h"

#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

namespace touchmend::service {

namespace beast = boost::beast;
namespace http = beast::http;
namespace asio = boost::asio;
using tcp = asio::ip::tcp;

namespace {

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket socket, Metrics& metrics, std::function<std::string()> unready)
      : stream_(std::move(socket)), metrics_(metrics), unready_(std::move(unready)) {}

  void start() { read(); }

 private:
  void read() {
    request_ = {};
    stream_.expires_after(std::chrono::seconds(10));
    http::async_read(stream_, buffer_, request_,
                     [self = shared_from_this()](beast::error_code ec, std::size_t) {
                       if (ec) {
                         self->stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
                         return;
                       }
                       self->respond();
                     });
  }

  void respond() {
    auto response = std::make_shared<http::response<http::string_body>>();
    response->version(request_.version());
    response->keep_alive(request_.keep_alive());
    response->set(http::field::server, "touchmend-server");
    const std::string target(request_.target());
    if (request_.method() != http::verb::get && request_.method() != http::verb::head) {
      response->result(http::status::method_not_allowed);
      response->set(http::field::content_type, "text/plain");
      response->body() = "only GET\n";
    } else if (target == "/metrics") {
      response->result(http::status::ok);
      response->set(http::field::content_type, "text/plain; version=0.0.4");
      response->body() = metrics_.render();
    } else if (target == "/healthz") {
      // Liveness: the event loop answered.
      response->result(http::status::ok);
      response->set(http::field::content_type, "text/plain");
      response->body() = "ok\n";
    } else if (target == "/readyz") {
      const std::string reason = unready_ ? unready_() : std::string();
      response->result(reason.empty() ? http::status::ok : http::status::service_unavailable);
      response->set(http::field::content_type, "text/plain");
      response->body() = reason.empty() ? "ready\n" : "not ready: " + reason + "\n";
    } else {
      response->result(http::status::not_found);
      response->set(http::field::content_type, "text/plain");
      response->body() = "not found (try /metrics, /healthz or /readyz)\n";
    }
    response->prepare_payload();
    http::async_write(stream_, *response,
                      [self = shared_from_this(), response](beast::error_code ec, std::size_t) {
                        if (ec || !response->keep_alive()) {
                          self->stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
                          return;
                        }
                        self->read();
                      });
  }

  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  http::request<http::string_body> request_;
  Metrics& metrics_;
  std::function<std::string()> unready_;
};

}  // namespace

AdminHttpServer::AdminHttpServer(asio::io_context& io, Metrics& metrics,
                                 std::function<std::string()> unready)
    : io_(io), metrics_(metrics), unready_(std::move(unready)), acceptor_(io) {}

rpc::Status AdminHttpServer::listen(const tcp::endpoint& endpoint) {
  beast::error_code ec;
  acceptor_.open(endpoint.protocol(), ec);
  if (!ec) acceptor_.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor_.bind(endpoint, ec);
  if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    return {rpc::StatusCode::Unavailable,
            "cannot listen for metrics on " + endpoint.address().to_string() + ":" +
                std::to_string(endpoint.port()) + ": " + ec.message()};
  }
  accept();
  return {};
}

tcp::endpoint AdminHttpServer::local_endpoint() const {
  beast::error_code ec;
  return acceptor_.local_endpoint(ec);
}

void AdminHttpServer::stop() {
  beast::error_code ec;
  acceptor_.close(ec);
}

void AdminHttpServer::accept() {
  acceptor_.async_accept(asio::make_strand(io_), [this](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted) return;
    if (!ec) std::make_shared<HttpSession>(std::move(socket), metrics_, unready_)->start();
    accept();
  });
}

}  // namespace touchmend::service
