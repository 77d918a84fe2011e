#pragma once

//! \file admin_http.h
//! \brief The admin listener (Boost.Beast): `GET /metrics` in the Prometheus text format
//! 0.0.4 and `GET /healthz` (liveness: the event loop answers). Plain HTTP/1.1, meant for
//! loopback or a cluster-internal address.

#include <boost/asio.hpp>
#include <functional>
#include <memory>
#include <string>

#include "proto/rpc/status.h"
#include "server/service/metrics.h"

namespace touchmend::service {

class AdminHttpServer {
 public:
  AdminHttpServer(boost::asio::io_context& io, Metrics& metrics, std::function<bool()> healthy);
  rpc::Status listen(const boost::asio::ip::tcp::endpoint& endpoint);
  boost::asio::ip::tcp::endpoint local_endpoint() const;
  void stop();

 private:
  void accept();
  boost::asio::io_context& io_;
  Metrics& metrics_;
  std::function<bool()> healthy_;
  boost::asio::ip::tcp::acceptor acceptor_;
};

}  // namespace touchmend::service
