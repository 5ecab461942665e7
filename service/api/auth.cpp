#include "service/api/auth.h"

#include <fcntl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>

#include "base/atomic_file.h"
#include "base/unique_fd.h"

namespace camlab::service {

namespace {

Result<std::string> random_hex(size_t bytes) {
  std::string raw(bytes, '\0');
  size_t filled = 0;
  while (filled < bytes) {
    const ssize_t n = getrandom(raw.data() + filled, bytes - filled, 0);
    if (n < 0) {
      if (errno == EINTR) continue;
      return make_error("io_error", std::string("getrandom failed: ") + std::strerror(errno));
    }
    filled += static_cast<size_t>(n);
  }
  static const char* kHex = "0123456789abcdef";
  std::string hex;
  for (unsigned char c : raw) {
    hex.push_back(kHex[c >> 4]);
    hex.push_back(kHex[c & 15]);
  }
  return hex;
}

std::string trim(std::string s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  size_t start = 0;
  while (start < s.size() && std::isspace(static_cast<unsigned char>(s[start]))) ++start;
  return s.substr(start);
}

}  // namespace

Result<TokenFile> load_or_create_token(const std::filesystem::path& data_dir) {
  const std::filesystem::path path = data_dir / "token";
  TokenFile result;
  for (int attempt = 0; attempt < 2; ++attempt) {
    // Closed on every way out of this attempt (unlinking an open file is fine).
    UniqueFd fd(::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600));
    if (fd) {
      auto token = random_hex(32);
      if (!token) {
        ::unlink(path.c_str());
        return token.error();
      }
      const std::string text = *token + "\n";
      const bool written =
          ::write(fd.get(), text.data(), text.size()) == static_cast<ssize_t>(text.size());
      const bool synced = ::fsync(fd.get()) == 0;
      if (!written || !synced) {
        ::unlink(path.c_str());
        return make_error("io_error", "cannot write the token file " + path.string());
      }
      result.token = *token;
      result.created = true;
      return result;
    }
    if (errno != EEXIST)
      return make_error("io_error", "cannot create " + path.string() + ": " + std::strerror(errno));
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0 && (st.st_mode & 077) != 0) {
      if (::chmod(path.c_str(), 0600) != 0)
        return make_error("io_error",
                          path.string() + " is readable by others and cannot be made 0600");
      result.warning = path.string() + " was readable by group or others; its mode is now 0600";
    }
    auto text = read_text_file(path);
    if (!text) return text.error();
    result.token = trim(*text);
    if (result.token.size() >= 16) return result;
    // An empty or truncated file (a crash between create and write): make a new one.
    ::unlink(path.c_str());
  }
  return make_error("io_error", "cannot create a usable token in " + path.string());
}

bool TokenAuth::accepts(const std::string& authorization) const {
  static const std::string kScheme = "Bearer ";
  if (authorization.size() < kScheme.size()) return false;
  for (size_t i = 0; i < kScheme.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(authorization[i])) !=
        std::tolower(static_cast<unsigned char>(kScheme[i])))
      return false;
  const std::string given = trim(authorization.substr(kScheme.size()));
  if (given.size() != token_.size()) return false;
  unsigned char difference = 0;
  for (size_t i = 0; i < given.size(); ++i)
    difference |= static_cast<unsigned char>(given[i] ^ token_[i]);
  return difference == 0;
}

}  // namespace camlab::service
