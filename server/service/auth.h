#pragma once

//! \file auth.h
//! \brief Bearer-token authentication (SERVICE.md §2.2).
//!
//! \details Without a tokens file the server is in "protected mode" (like Redis): it accepts
//! loopback peers only, as principal "local", and asks no token. With a tokens file every
//! connection must present one of its tokens. Tokens are kept only as SHA-256 digests and
//! compared in constant time; they are never logged.

#include <array>
#include <string>
#include <vector>

#include "server/service/rpc_server.h"

namespace touchmend::service {

class TokenAuthenticator final : public Authenticator {
 public:
  //! Protected mode: loopback only, no tokens.
  TokenAuthenticator() = default;
  //! Reads "PRINCIPAL TOKEN" lines ('#' starts a comment). Tokens must be at least 16
  //! characters; principals are [A-Za-z0-9_.@-]+.
  static Status from_file(const std::string& path, TokenAuthenticator& out);
  void add(const std::string& principal, const std::string& token);

  bool requires_tokens() const { return !entries_.empty(); }
  Status authenticate(const std::string& token, const tcp::endpoint& peer,
                      std::string& principal) const override;

 private:
  struct Entry {
    std::string principal;
    std::array<unsigned char, 32> digest;
  };
  std::vector<Entry> entries_;
};

}  // namespace touchmend::service
