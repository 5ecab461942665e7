#include "service/fleet/host_identity.h"

#include <sys/random.h>

#include <cctype>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "base/atomic_file.h"

namespace camlab::service {

namespace {

constexpr size_t kIdHexDigits = 32;

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  return s;
}

bool is_id(const std::string& s) {
  if (s.size() != kIdHexDigits) return false;
  for (char c : s)
    if (!std::isxdigit(static_cast<unsigned char>(c))) return false;
  return true;
}

}  // namespace

Result<std::string> load_host_identity(const std::filesystem::path& data_dir) {
  const std::filesystem::path path = data_dir / "host-id";
  std::error_code ec;
  std::string id;
  if (std::filesystem::exists(path, ec)) {
    id = read_text(path);
    if (!is_id(id))
      return make_error("bad_manifest", path.string() + " holds no host id (" +
                                            std::to_string(kIdHexDigits) +
                                            " hex digits); remove it to make a new one");
  } else {
    unsigned char bytes[kIdHexDigits / 2];
    if (getrandom(bytes, sizeof bytes, 0) != static_cast<ssize_t>(sizeof bytes))
      return make_error("io_error", "cannot draw a random host id");
    char hex[kIdHexDigits + 1];
    for (size_t i = 0; i < sizeof bytes; ++i) std::snprintf(hex + 2 * i, 3, "%02x", bytes[i]);
    id = hex;
    if (Status written = write_file_atomically(path, id + "\n"); !written) return written.error();
  }
  return id + "@" + read_text("/proc/sys/kernel/random/boot_id");
}

}  // namespace camlab::service
