#include "proto/rpc/byte_stream.h"

#include <netinet/in.h>
#include <netinet/tcp.h>

namespace touchmend::rpc {

void tune_socket(tcp::socket& socket) {
  error_code ignored;
  socket.set_option(tcp::no_delay(true), ignored);
  const unsigned int user_timeout_ms = 30'000;
  ::setsockopt(socket.native_handle(), IPPROTO_TCP, TCP_USER_TIMEOUT, &user_timeout_ms,
               sizeof(user_timeout_ms));
}

}  // namespace touchmend::rpc
