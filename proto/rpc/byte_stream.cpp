#include "proto/rpc/byte_stream.h"

#include <algorithm>
#include <netinet/in.h>
#include <netinet/tcp.h>

namespace touchmend::rpc {

void tune_socket(tcp::socket& socket, std::chrono::milliseconds user_timeout) {
  error_code ignored;
  socket.set_option(tcp::no_delay(true), ignored);
  const auto user_timeout_ms = static_cast<unsigned int>(
      std::clamp<std::chrono::milliseconds::rep>(user_timeout.count(), 1, 0x7fffffff));
  ::setsockopt(socket.native_handle(), IPPROTO_TCP, TCP_USER_TIMEOUT, &user_timeout_ms,
               sizeof(user_timeout_ms));
}

}  // namespace touchmend::rpc
