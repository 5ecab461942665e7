// A capture folder as a reader finds it (src/image/capture_folder.h): manifest.json,
// frames.jsonl and a frame's JSON sidecar, from a camlab that crashed, another version or
// anyone with write access to the data folder. The input is the three files, separated by
// "\n--8<--\n" lines (fuzz_check.h), written to a scratch folder; the harness opens it,
// reads every listed sidecar, runs crash recovery on it and opens it again.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "image/capture_folder.h"
#include "image/capture_folder_recovery.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

namespace fs = std::filesystem;

// scripts/fuzz.sh gives a scratch folder (CAMLAB_FUZZ_SCRATCH, on tmpfs when there is one:
// recovery syncs what it cuts, and syncs to a disk would bound the harness to a few hundred
// inputs a second) and removes it afterwards: libFuzzer ends with _Exit, so the harness
// itself cannot clean up. Run by hand without it, the harness uses the temp directory.
const fs::path& scratch_root() {
  static const fs::path root = [] {
    if (const char* given = std::getenv("CAMLAB_FUZZ_SCRATCH"); given && *given)
      return fs::path(given);
    std::string pattern = (fs::temp_directory_path() / "camlab-fuzz-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) std::abort();
    return fs::path(pattern);
  }();
  return root;
}

void write_file(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

void read_folder(const fs::path& dir) {
  auto folder = camlab::image::CaptureFolder::open(dir);
  if (!folder) {
    camlab::fuzz::check_error(folder.error());
    return;
  }
  for (size_t i = 0; i < folder->frames().size(); ++i) {
    auto sidecar = folder->load_sidecar(static_cast<int>(i));
    if (!sidecar) camlab::fuzz::check_error(sidecar.error());
  }
  (void)folder->complete();
  (void)folder->version();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto parts =
      camlab::fuzz::split_parts(std::string_view(reinterpret_cast<const char*>(data), size), 3);
  const fs::path dir = scratch_root() / "capture";
  std::error_code ec;
  fs::remove_all(dir, ec);
  fs::create_directory(dir);
  write_file(dir / "manifest.json", parts[0]);
  if (!parts[1].empty()) write_file(dir / "frames.jsonl", parts[1]);
  write_file(dir / "frame_000000.json", parts[2]);
  write_file(dir / "frame_000000.png", "");

  read_folder(dir);
  auto recovered = camlab::image::recover_capture_folder(dir);
  if (!recovered) camlab::fuzz::check_error(recovered.error());
  read_folder(dir);
  return 0;
}
