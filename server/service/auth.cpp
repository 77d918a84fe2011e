#include "server/service/auth.h"

#include <fstream>
#include <openssl/crypto.h>
#include <openssl/sha.h>
#include <sstream>

namespace touchmend::service {

namespace {
std::array<unsigned char, 32> sha256(const std::string& text) {
  std::array<unsigned char, 32> digest{};
  SHA256(reinterpret_cast<const unsigned char*>(text.data()), text.size(), digest.data());
  return digest;
}
bool valid_principal(const std::string& p) {
  if (p.empty() || p.size() > 128) return false;
  for (char c : p) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '@' ||
          c == '-')) {
      return false;
    }
  }
  return true;
}
}  // namespace

Status TokenAuthenticator::from_file(const std::string& path, TokenAuthenticator& out) {
  std::ifstream in(path);
  if (!in) return {StatusCode::InvalidArgument, "cannot read tokens file " + path};
  out.entries_.clear();
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream fields(line);
    std::string principal, token, extra;
    if (!(fields >> principal)) continue;
    if (!(fields >> token) || (fields >> extra)) {
      return {StatusCode::InvalidArgument,
              path + ":" + std::to_string(number) + ": expected 'PRINCIPAL TOKEN'"};
    }
    if (!valid_principal(principal)) {
      return {StatusCode::InvalidArgument,
              path + ":" + std::to_string(number) + ": bad principal name"};
    }
    if (token.size() < 16) {
      return {StatusCode::InvalidArgument,
              path + ":" + std::to_string(number) + ": token shorter than 16 characters"};
    }
    out.add(principal, token);
  }
  if (out.entries_.empty())
    return {StatusCode::InvalidArgument, "tokens file " + path + " has no tokens"};
  return {};
}

void TokenAuthenticator::add(const std::string& principal, const std::string& token) {
  entries_.push_back({principal, sha256(token)});
}

Status TokenAuthenticator::authenticate(const std::string& token, const tcp::endpoint& peer,
                                        std::string& principal) const {
  if (entries_.empty()) {
    if (!peer.address().is_loopback()) {
      return {StatusCode::Unauthenticated,
              "this server accepts loopback clients only (no --tokens)"};
    }
    principal = "local";
    return {};
  }
  if (token.empty()) return {StatusCode::Unauthenticated, "a bearer token is required"};
  const auto digest = sha256(token);
  const Entry* match = nullptr;
  for (const auto& e : entries_) {
    // Check every entry (constant time per entry) so timing does not reveal which matched.
    if (CRYPTO_memcmp(e.digest.data(), digest.data(), digest.size()) == 0) match = &e;
  }
  if (match == nullptr) return {StatusCode::Unauthenticated, "invalid token"};
  principal = match->principal;
  return {};
}

}  // namespace touchmend::service
