// `camlab vcam run`: run a command with virtual cameras present as /dev/video0.. .
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "mock_device/camera_spec.h"
#include "mock_device/fake_sysfs.h"
#include "mock_device/scene_spec.h"

extern char** environ;

namespace camlab::cli {

namespace {

namespace fs = std::filesystem;

struct VcamArgs {
  std::string camera;
  std::string scene;
  int count = 1;
  std::vector<std::string> command;
};

[[noreturn]] void fail(const std::string& message) {
  std::fprintf(stderr, "camlab vcam run: %s\n", message.c_str());
  throw CLI::RuntimeError(2);
}

// The default camera when none is given: 640x480, 10 bits, an 8 mm lens at f/2.8
// focused near 1 m, 3 frames of control latency.
const char* kDefaultCamera = R"({
  "name": "camlab virtual 640x480",
  "sensor": {"width_px": 640, "height_px": 480, "pixel_pitch_um": 4.0, "bit_depth": 10,
             "black_level_dn": 32, "full_well_e": 12000, "read_noise_e": 3.0, "quantum_efficiency": 0.65},
  "lens": {"focal_mm": 8.0, "model": "LENSMODEL_OPENCV4", "distortion": [-0.05, 0.01, 0.0, 0.0],
           "f_number_min": 1.4, "f_number_max": 16.0,
           "focus": {"position_min": 0, "position_max": 1000, "extension_mm_per_step": 0.001}},
  "timing": {"frame_interval_us": 33333, "control_latency_frames": 3},
  "controls": {"exposure_time_absolute": {"min": 1, "max": 333, "default": 50},
               "focus_absolute": {"default": 65}}
})";

// The preload library: CAMLAB_VCAM_PRELOAD, else beside this executable in the build
// tree (cli/ -> mock_device/) or an install (bin/ -> lib/camlab/).
std::string find_preload_library() {
  if (const char* given = std::getenv("CAMLAB_VCAM_PRELOAD")) return given;
  char exe[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0) return {};
  exe[n] = '\0';
  const fs::path dir = fs::path(exe).parent_path();
  for (const fs::path& candidate : {dir / "../mock_device/libcamlab_vcam_preload.so",
                                   dir / "../lib/camlab/libcamlab_vcam_preload.so"}) {
    std::error_code ec;
    if (fs::exists(candidate, ec)) return fs::canonical(candidate, ec).string();
  }
  return {};
}

int run_vcam(const VcamArgs& args) {
  if (args.command.empty()) fail("give the command to run after --, e.g. camlab vcam run -- v4l2-ctl --all");
  const std::string preload = find_preload_library();
  if (preload.empty())
    fail("libcamlab_vcam_preload.so not found beside camlab; set CAMLAB_VCAM_PRELOAD to its path");

  char dir_template[] = "/tmp/camlab-vcam-XXXXXX";
  if (!mkdtemp(dir_template)) fail(std::string("cannot create a temporary folder: ") + std::strerror(errno));
  const fs::path work(dir_template);
  struct Cleanup {
    fs::path dir;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(dir, ec);
    }
  } cleanup{work};

  // Check the specs here, where an error can be printed clearly, not in every process.
  std::string camera_path = args.camera;
  if (camera_path.empty()) {
    camera_path = (work / "camera.json").string();
    std::ofstream(camera_path) << kDefaultCamera;
  }
  if (auto camera = mock::load_camera_spec(camera_path); !camera) fail(camera.error().message);
  if (!args.scene.empty())
    if (auto scene = mock::load_scene_spec(args.scene); !scene) fail(scene.error().message);
  const fs::path sysfs = work / "sys";
  fs::create_directories(sysfs);
  if (!mock::write_sysfs_tree(sysfs.string(), args.count)) fail("cannot write the fake sysfs in " + sysfs.string());

  std::vector<std::string> env_strings;
  for (char** e = environ; *e; ++e) {
    const std::string entry = *e;
    if (entry.rfind("LD_PRELOAD=", 0) == 0 || entry.rfind("CAMLAB_VCAM_", 0) == 0) continue;
    env_strings.push_back(entry);
  }
  const char* existing_preload = std::getenv("LD_PRELOAD");
  env_strings.push_back("LD_PRELOAD=" + preload + (existing_preload ? std::string(" ") + existing_preload : ""));
  env_strings.push_back("CAMLAB_VCAM_CAMERA=" + fs::absolute(camera_path).string());
  if (!args.scene.empty()) env_strings.push_back("CAMLAB_VCAM_SCENE=" + fs::absolute(args.scene).string());
  env_strings.push_back("CAMLAB_VCAM_COUNT=" + std::to_string(args.count));
  env_strings.push_back("CAMLAB_VCAM_SYSFS=" + sysfs.string());
  std::vector<char*> envp;
  for (auto& e : env_strings) envp.push_back(e.data());
  envp.push_back(nullptr);
  std::vector<std::string> argv_strings = args.command;
  std::vector<char*> argv;
  for (auto& a : argv_strings) argv.push_back(a.data());
  argv.push_back(nullptr);

  pid_t child;
  if (int error = posix_spawnp(&child, argv[0], nullptr, nullptr, argv.data(), envp.data()); error != 0)
    fail("cannot run " + args.command[0] + ": " + std::strerror(error));
  int status = 0;
  while (waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

}  // namespace

void register_vcam_command(CLI::App& app) {
  CLI::App* vcam = app.add_subcommand("vcam", "The virtual camera as V4L2 devices for any program.");
  vcam->require_subcommand(1);
  auto args = std::make_shared<VcamArgs>();
  CLI::App* run = vcam->add_subcommand(
      "run",
      "Run COMMAND with N virtual cameras present as /dev/video0.. (user space: an LD_PRELOAD\n"
      "library answers the V4L2 calls; no kernel module). Returns COMMAND's exit status.\n"
      "Example: camlab vcam run -- v4l2-ctl -d /dev/video0 --stream-mmap --stream-count=30 --stream-to=f.raw\n"
      "Each process gets its own instance of the devices (cross-process sharing: to come).");
  run->add_option("--camera", args->camera, "camera spec JSON (default: a 640x480 10-bit camera)")
      ->check(CLI::ExistingFile);
  run->add_option("--scene", args->scene, "scene spec JSON (default: a chessboard at 0.6 m)")->check(CLI::ExistingFile);
  run->add_option("--count", args->count, "number of virtual cameras")->check(CLI::Range(1, 8));
  run->add_option("command", args->command, "the command and its arguments (after --)")->required();
  run->callback([args] { throw CLI::RuntimeError(run_vcam(*args)); });
}

}  // namespace camlab::cli
