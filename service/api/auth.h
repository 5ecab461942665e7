// The API token: a random bearer token generated on first start into DATA/token (mode
// 0600, created with O_EXCL so two daemons never race to different tokens), reused on
// later starts. Requests carry it as "Authorization: Bearer TOKEN".
//
// TokenAuth is immutable after creation: thread-safe.
#pragma once

#include <filesystem>
#include <string>

#include "base/result.h"

namespace camlab::service {

struct TokenFile {
  std::string token;
  bool created = false;  // true on first start: print it once
  std::string warning;   // e.g. the file's mode was too open and was fixed
};

// Reads DATA/token, or creates it with 32 random bytes as 64 hex digits.
Result<TokenFile> load_or_create_token(const std::filesystem::path& data_dir);

class TokenAuth {
 public:
  explicit TokenAuth(std::string token) : token_(std::move(token)) {}
  // Whether an Authorization header value carries the token (compared in constant time,
  // so the comparison leaks no prefix length).
  bool accepts(const std::string& authorization) const;

 private:
  std::string token_;
};

}  // namespace camlab::service
