#include "mock_device/fake_sysfs.h"

#include <filesystem>
#include <fstream>

namespace camlab::mock {

bool write_sysfs_tree(const std::string& root, int count) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (int n = 0; n < count; ++n) {
    const std::string node = "video" + std::to_string(n);
    const std::string dev = "81:" + std::to_string(n);
    for (const fs::path& dir : {fs::path(root) / "dev/char" / dev, fs::path(root) / "class/video4linux" / node}) {
      fs::create_directories(dir, ec);
      if (ec) return false;
      std::ofstream(dir / "uevent") << "MAJOR=81\nMINOR=" << n << "\nDEVNAME=" << node << "\n";
      std::ofstream(dir / "dev") << dev << "\n";
      std::ofstream(dir / "name") << "camlab virtual camera " << n << "\n";
      std::ofstream(dir / "index") << 0 << "\n";
      if (!std::ofstream(dir / "dev")) return false;
    }
  }
  return true;
}

}  // namespace camlab::mock
