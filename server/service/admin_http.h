#pragma once

//! \file admin_http.h
//! \brief The admin listener (Boost.Beast): `GET /metrics` in the Prometheus text format
//! 0.0.4, `GET /healthz` (liveness: the event loop answers) and `GET /readyz` (readiness: 503
//! with the reason while the server takes no edits, e.g. its store's disk is full or the store
//! failed). Plain HTTP/1.1, meant for loopback or a cluster-internal address.

#include <boost/asio.hpp>
#include <functional>
#include <memory>
#include <string>

#include "proto/rpc/status.h"
#include "server/service/metrics.h"

namespace touchmend::service {

class AdminHttpServer {
 public:
  //! \p unready: why the server is not ready (empty when it is).
  AdminHttpServer(boost::asio::io_context& io, Metrics& metrics,
                  std::function<std::string()> unready);
  rpc::Status listen(const boost::asio::ip::tcp::endpoint& endpoint);
  boost::asio::ip::tcp::endpoint local_endpoint() const;
  void stop();

 private:
  void accept();
  boost::asio::io_context& io_;
  Metrics& metrics_;
  std::function<std::string()> unready_;
  boost::asio::ip::tcp::acceptor acceptor_;
};

}  // namespace touchmend::service
