#include "base/atomic_file.h"

#include "base/file_mode.h"
#include "base/io_error.h"
#include "base/unique_fd.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

namespace camlab {

Status write_file_atomically(const std::filesystem::path& path,
                             std::span<const unsigned char> bytes) {
  // mkstemp in the target's own directory, so the rename never crosses filesystems.
  std::string temp_name =
      (path.parent_path() / ("." + path.filename().string() + ".XXXXXX")).string();
  if (path.parent_path().empty()) temp_name = "." + path.filename().string() + ".XXXXXX";
  UniqueFd fd(::mkstemp(temp_name.data()));
  if (!fd) return io_error(path, "cannot create a temporary file for", errno);

  size_t written = 0;
  while (written < bytes.size()) {
    ssize_t n = ::write(fd.get(), bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      int err = errno;
      ::unlink(temp_name.c_str());
      return io_error(path, "cannot write", err);
    }
    written += static_cast<size_t>(n);
  }
  // Data must be on disk before the rename makes it visible, or a power cut could leave
  // an empty file under the final name.
  // mkstemp made it 0600: it gets the mode of camlab's data files (base/file_mode.h).
  if (::fsync(fd.get()) != 0 || ::fchmod(fd.get(), data_file_mode()) != 0) {
    int err = errno;
    ::unlink(temp_name.c_str());
    return io_error(path, "cannot flush", err);
  }
  fd.reset();
  if (::rename(temp_name.c_str(), path.c_str()) != 0) {
    int err = errno;
    ::unlink(temp_name.c_str());
    return io_error(path, "cannot rename into place", err);
  }
  return {};
}

Status write_file_atomically(const std::filesystem::path& path, std::string_view text) {
  return write_file_atomically(
      path, std::span(reinterpret_cast<const unsigned char*>(text.data()), text.size()));
}

bool is_atomic_write_temporary(const std::string& name) {
  // "." + target + "." + the six characters mkstemp chose (letters and digits).
  constexpr size_t kSuffix = 6;
  if (name.size() < 1 + 1 + 1 + kSuffix || name[0] != '.') return false;
  const size_t dot = name.size() - kSuffix - 1;
  if (name[dot] != '.') return false;
  for (size_t i = dot + 1; i < name.size(); ++i)
    if (!std::isalnum(static_cast<unsigned char>(name[i]))) return false;
  return true;
}

Result<std::vector<std::string>> remove_atomic_write_temporaries(const std::filesystem::path& dir) {
  std::vector<std::string> removed;
  std::error_code ec;
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (!is_atomic_write_temporary(name) || !it->is_regular_file(ec)) continue;
    if (::unlink(it->path().c_str()) != 0) return io_error(it->path(), "cannot remove", errno);
    removed.push_back(name);
  }
  if (ec) return make_error("io_error", "cannot list " + dir.string() + ": " + ec.message());
  return removed;
}

Result<std::string> read_text_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return io_error(path, "cannot open", errno ? errno : ENOENT);
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return io_error(path, "cannot read", errno);
  return text.str();
}

}  // namespace camlab
