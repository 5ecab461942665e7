// `camlab vcam run`: run a command with virtual cameras present as /dev/video0.. (and
// their media controller nodes /dev/media0..).
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "mock_device/broker/broker_protocol.h"
#include "mock_device/broker/vcam_broker.h"
#include "mock_device/broker/vcam_devices.h"
#include "mock_device/v4l2/fake_sysfs.h"

extern char** environ;

namespace camlab::cli {

namespace {

namespace fs = std::filesystem;

struct VcamArgs {
  std::string camera;
  std::string scene;
  int count = 1;
  bool unpaced = false;
  std::vector<std::string> command;
};

volatile pid_t forwarded_child = 0;  // for the signal handler

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

// The devices of a run and everything that points to them: a temporary folder with the
// broker's socket and the fake sysfs, removed when the session ends (after the broker).
struct VcamSession {
  struct Folder {
    fs::path path;
    ~Folder() {
      std::error_code ec;
      if (!path.empty()) fs::remove_all(path, ec);
    }
  } folder;
  std::unique_ptr<mock::VcamBroker> broker;
  // What a client process needs in its environment.
  std::vector<std::pair<std::string, std::string>> environment;
};

std::unique_ptr<VcamSession> start_session(const VcamArgs& args) {
  const std::string preload = find_preload_library();
  if (preload.empty())
    fail("libcamlab_vcam_preload.so not found beside camlab; set CAMLAB_VCAM_PRELOAD to its path");
  auto session = std::make_unique<VcamSession>();
  char dir_template[] = "/tmp/camlab-vcam-XXXXXX";
  if (!mkdtemp(dir_template)) fail(std::string("cannot create a temporary folder: ") + std::strerror(errno));
  const fs::path work(dir_template);
  session->folder.path = work;

  std::string camera_path = args.camera;
  if (camera_path.empty()) {
    camera_path = (work / "camera.json").string();
    std::ofstream(camera_path) << kDefaultCamera;
  }
  // The devices live here, in the broker, for every process of the run.
  auto devices = mock::create_vcam_devices(camera_path, args.scene, args.count, !args.unpaced);
  if (!devices) fail(devices.error().message);
  // The sysfs names are the cameras' names as VIDIOC_QUERYCAP's card reports them (at
  // most 31 bytes), so that the two agree as on a real uvcvideo device.
  std::vector<std::string> camera_names;
  for (const auto& device : *devices) camera_names.push_back(device->camera().name.substr(0, 31));
  // The broker serves /dev/videoN and its media controller node /dev/mediaN.
  auto broker = mock::VcamBroker::start(std::move(*devices), (work / "broker.sock").string());
  if (!broker) fail(broker.error().message);
  session->broker = std::move(*broker);
  const fs::path sysfs = work / "sys";
  fs::create_directories(sysfs);
  if (!mock::write_sysfs_tree(sysfs.string(), camera_names)) fail("cannot write the fake sysfs in " + sysfs.string());

  const char* existing_preload = std::getenv("LD_PRELOAD");
  session->environment = {
      {"LD_PRELOAD", preload + (existing_preload ? std::string(" ") + existing_preload : "")},
      {"CAMLAB_VCAM_BROKER", session->broker->socket_path()},
      {"CAMLAB_VCAM_COUNT", std::to_string(args.count)},
      {"CAMLAB_VCAM_SYSFS", sysfs.string()},
  };
  return session;
}

struct FaultArgs {
  int device = 0;
  std::string fault;
  int count = 1;
};

int inject_vcam_fault(const FaultArgs& args) {
  const char* socket = std::getenv("CAMLAB_VCAM_BROKER");
  if (!socket) fail("no virtual cameras here: run this inside `camlab vcam run` or with `camlab vcam serve`'s environment");
  static const std::map<std::string, mock::broker::Fault> kFaults = {
      {"unplug", mock::broker::Fault::kUnplug},   {"eio", mock::broker::Fault::kDequeueEio},
      {"drop", mock::broker::Fault::kDropFrames}, {"stall", mock::broker::Fault::kStall},
      {"resume", mock::broker::Fault::kResume}};
  const int result = mock::broker::inject_fault(socket, args.device, kFaults.at(args.fault), args.count);
  if (result < 0)
    fail("cannot inject '" + args.fault + "' into /dev/video" + std::to_string(args.device) + ": " +
         std::strerror(-result));
  return 0;
}

volatile sig_atomic_t stop_serving = 0;

int serve_vcam(const VcamArgs& args) {
  auto session = start_session(args);
  std::printf("# %d virtual camera(s) served as /dev/video0..%d until this process ends (Ctrl-C).\n"
              "# In another shell, for any V4L2 program:\n",
              args.count, args.count - 1);
  for (const auto& [name, value] : session->environment) std::printf("export %s='%s'\n", name.c_str(), value.c_str());
  std::fflush(stdout);
  struct sigaction stop{};
  stop.sa_handler = [](int) { stop_serving = 1; };
  sigemptyset(&stop.sa_mask);
  sigaction(SIGTERM, &stop, nullptr);
  sigaction(SIGINT, &stop, nullptr);
  sigaction(SIGHUP, &stop, nullptr);
  while (!stop_serving) pause();
  return 0;
}

int run_vcam(const VcamArgs& args) {
  if (args.command.empty()) fail("give the command to run after --, e.g. camlab vcam run -- v4l2-ctl --all");
  auto session = start_session(args);
  std::vector<std::string> env_strings;
  for (char** e = environ; *e; ++e) {
    const std::string entry = *e;
    if (entry.rfind("LD_PRELOAD=", 0) == 0 || entry.rfind("CAMLAB_VCAM_", 0) == 0) continue;
    env_strings.push_back(entry);
  }
  for (const auto& [name, value] : session->environment) env_strings.push_back(name + "=" + value);
  std::vector<char*> envp;
  for (auto& e : env_strings) envp.push_back(e.data());
  envp.push_back(nullptr);
  std::vector<std::string> argv_strings = args.command;
  std::vector<char*> argv;
  for (auto& a : argv_strings) argv.push_back(a.data());
  argv.push_back(nullptr);

  // The command must not outlive its devices: it dies with this process (PDEATHSIG)
  // and gets the SIGTERM/SIGHUP sent to it; SIGINT/SIGQUIT reach it from the terminal
  // directly, so this process ignores them while it waits (as system(3) does).
  const pid_t parent = getpid();
  const pid_t child = fork();
  if (child < 0) fail(std::string("cannot fork: ") + std::strerror(errno));
  if (child == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(127);
    execvpe(argv[0], argv.data(), envp.data());
    std::fprintf(stderr, "camlab vcam run: cannot run %s: %s\n", argv[0], std::strerror(errno));
    _exit(127);
  }
  forwarded_child = child;
  struct sigaction forward{};
  forward.sa_handler = [](int signal) { kill(forwarded_child, signal); };
  sigemptyset(&forward.sa_mask);
  sigaction(SIGTERM, &forward, nullptr);
  sigaction(SIGHUP, &forward, nullptr);
  signal(SIGINT, SIG_IGN);
  signal(SIGQUIT, SIG_IGN);
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
      "All processes of COMMAND (it may be a shell running several) share the same devices:\n"
      "a control one process sets is what the next one reads, as with a kernel driver.");
  run->add_option("--camera", args->camera, "camera spec JSON (default: a 640x480 10-bit camera)")
      ->check(CLI::ExistingFile);
  run->add_option("--scene", args->scene, "scene spec JSON (default: a chessboard at 0.6 m)")->check(CLI::ExistingFile);
  run->add_option("--count", args->count, "number of virtual cameras")->check(CLI::Range(1, 8));
  run->add_flag("--unpaced", args->unpaced,
                "no frame clock: a frame is made as soon as a buffer is queued (fast tests; no dropped frames)");
  run->add_option("command", args->command, "the command and its arguments (after --)")->required();
  run->callback([args] { throw CLI::RuntimeError(run_vcam(*args)); });

  auto serve_args = std::make_shared<VcamArgs>();
  CLI::App* serve = vcam->add_subcommand(
      "serve",
      "Serve N virtual cameras until interrupted, and print the environment (LD_PRELOAD and\n"
      "CAMLAB_VCAM_*) under which any program in any shell sees them as /dev/video0.. .\n"
      "Keep it running in one shell and paste the export lines into another.");
  serve->add_option("--camera", serve_args->camera, "camera spec JSON (default: a 640x480 10-bit camera)")
      ->check(CLI::ExistingFile);
  serve->add_option("--scene", serve_args->scene, "scene spec JSON (default: a chessboard at 0.6 m)")
      ->check(CLI::ExistingFile);
  serve->add_option("--count", serve_args->count, "number of virtual cameras")->check(CLI::Range(1, 8));
  serve->callback([serve_args] { throw CLI::RuntimeError(serve_vcam(*serve_args)); });

  auto fault_args = std::make_shared<FaultArgs>();
  CLI::App* fault = vcam->add_subcommand(
      "fault",
      "Inject a fault into a virtual camera of the surrounding `camlab vcam run` (or serve), to\n"
      "test how a program copes: unplug (ENODEV from then on), eio (the next COUNT dequeues\n"
      "fail with EIO), drop (the next COUNT frames are lost: sequence gaps), stall (no frames\n"
      "until resume), resume.\n"
      "Example: camlab vcam run -- sh -c 'my_capture & sleep 2; camlab vcam fault unplug; wait'");
  fault->add_option("fault", fault_args->fault, "unplug | eio | drop | stall | resume")
      ->required()
      ->check(CLI::IsMember({"unplug", "eio", "drop", "stall", "resume"}));
  fault->add_option("--device", fault_args->device, "which /dev/videoN (default 0)")->check(CLI::Range(0, 7));
  fault->add_option("--count", fault_args->count, "for eio and drop: how many (default 1)")->check(CLI::Range(1, 100000));
  fault->callback([fault_args] { throw CLI::RuntimeError(inject_vcam_fault(*fault_args)); });
}

}  // namespace camlab::cli
