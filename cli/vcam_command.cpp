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

#include "command_errors.h"
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
  std::string rig;
  int count = 1;
  bool unpaced = false;
  std::vector<std::string> command;
};

volatile pid_t forwarded_child = 0;  // for the signal handler

// The vcam subcommands print no JSON: their errors are lines on stderr.
CommandErrors errors_of(const char* subcommand) {
  return CommandErrors(std::string("camlab vcam ") + subcommand, false);
}

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
// broker's socket, the fake sysfs and the fake udev database, removed when the session
// ends (after the broker).
struct VcamSession {
  struct Folder {
    fs::path path;
    ~Folder() {
      std::error_code ec;
      if (!path.empty()) fs::remove_all(path, ec);
    }
  } folder;
  std::unique_ptr<mock::VcamBroker> broker;
  int device_count = 0;  // /dev/video0 .. device_count - 1
  // What a client process needs in its environment.
  std::vector<std::pair<std::string, std::string>> environment;
};

std::unique_ptr<VcamSession> start_session(const VcamArgs& args, const CommandErrors& errors) {
  const std::string preload = find_preload_library();
  if (preload.empty())
    errors.fail(
        "not_found",
        "libcamlab_vcam_preload.so not found beside camlab; set CAMLAB_VCAM_PRELOAD to its path");
  auto session = std::make_unique<VcamSession>();
  char dir_template[] = "/tmp/camlab-vcam-XXXXXX";
  if (!mkdtemp(dir_template))
    errors.fail("io_error",
                std::string("cannot create a temporary folder: ") + std::strerror(errno));
  const fs::path work(dir_template);
  session->folder.path = work;

  // The devices live here, in the broker, for every process of the run.
  auto devices = args.rig.empty()
                     ? mock::create_vcam_devices(args.camera, args.scene, args.count, !args.unpaced)
                     : mock::create_vcam_rig_devices(args.rig, !args.unpaced);
  if (!devices) errors.fail(devices.error());
  const int device_count = static_cast<int>(devices->size());
  session->device_count = device_count;
  // The sysfs names are the cameras' names as VIDIOC_QUERYCAP's card reports them (at
  // most 31 bytes), so that the two agree as on a real uvcvideo device.
  std::vector<std::string> camera_names;
  for (const auto& device : *devices) camera_names.push_back(device->camera().name.substr(0, 31));
  // The broker serves /dev/videoN and its media controller node /dev/mediaN.
  auto broker = mock::VcamBroker::start(std::move(*devices), (work / "broker.sock").string());
  if (!broker) errors.fail(broker.error());
  session->broker = std::move(*broker);
  const fs::path sysfs = work / "sys";
  fs::create_directories(sysfs);
  if (!mock::write_sysfs_tree(sysfs.string(), camera_names))
    errors.fail("io_error", "cannot write the fake sysfs in " + sysfs.string());
  // What udev's rules would have recorded about the video nodes (GStreamer's device
  // monitor lists only nodes udev calls V4L2).
  const fs::path udev = work / "udev";
  fs::create_directories(udev);
  if (!mock::write_udev_database(udev.string(), camera_names))
    errors.fail("io_error", "cannot write the fake udev database in " + udev.string());

  // udev's persistent names, /dev/v4l/by-id and by-path (how rig configurations tell
  // cameras apart).
  const fs::path dev_v4l = work / "dev-v4l";
  if (!mock::write_v4l_links(dev_v4l.string(), camera_names))
    errors.fail("io_error", "cannot write the /dev/v4l links in " + dev_v4l.string());

  const char* existing_preload = std::getenv("LD_PRELOAD");
  session->environment = {
      {"LD_PRELOAD", preload + (existing_preload ? std::string(" ") + existing_preload : "")},
      {"CAMLAB_VCAM_BROKER", session->broker->socket_path()},
      {"CAMLAB_VCAM_COUNT", std::to_string(device_count)},
      {"CAMLAB_VCAM_SYSFS", sysfs.string()},
      {"CAMLAB_VCAM_UDEV", udev.string()},
      {"CAMLAB_VCAM_DEV_V4L", dev_v4l.string()},
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
  const CommandErrors errors = errors_of("fault");
  if (!socket)
    errors.fail("no_device",
                "no virtual cameras here: run this inside `camlab vcam run` or with `camlab vcam "
                "serve`'s environment");
  static const std::map<std::string, mock::broker::Fault> kFaults = {
      {"unplug", mock::broker::Fault::kUnplug},  {"replug", mock::broker::Fault::kReplug},
      {"eio", mock::broker::Fault::kDequeueEio}, {"drop", mock::broker::Fault::kDropFrames},
      {"stall", mock::broker::Fault::kStall},    {"resume", mock::broker::Fault::kResume}};
  const int result =
      mock::broker::inject_fault(socket, args.device, kFaults.at(args.fault), args.count);
  if (result < 0)
    errors.fail(result == -ENODEV || result == -ECONNREFUSED || result == -ENOENT
                    ? ErrorCode::kNoDevice
                    : ErrorCode::kIoError,
                "cannot inject '" + args.fault + "' into /dev/video" + std::to_string(args.device) +
                    ": " + std::strerror(-result));
  return 0;
}

volatile sig_atomic_t stop_serving = 0;

int serve_vcam(const VcamArgs& args) {
  auto session = start_session(args, errors_of("serve"));
  std::printf(
      "# %d virtual camera(s) served as /dev/video0..%d until this process ends (Ctrl-C).\n"
      "# In another shell, for any V4L2 program:\n",
      session->device_count, session->device_count - 1);
  for (const auto& [name, value] : session->environment)
    std::printf("export %s='%s'\n", name.c_str(), value.c_str());
  std::fflush(stdout);
  struct sigaction stop {};
  stop.sa_handler = [](int) { stop_serving = 1; };
  sigemptyset(&stop.sa_mask);
  sigaction(SIGTERM, &stop, nullptr);
  sigaction(SIGINT, &stop, nullptr);
  sigaction(SIGHUP, &stop, nullptr);
  while (!stop_serving) pause();
  return 0;
}

int run_vcam(const VcamArgs& args) {
  const CommandErrors errors = errors_of("run");
  if (args.command.empty())
    errors.fail("invalid_argument",
                "give the command to run after --, e.g. camlab vcam run -- v4l2-ctl --all");
  auto session = start_session(args, errors);
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
  if (child < 0) errors.fail("io_error", std::string("cannot fork: ") + std::strerror(errno));
  if (child == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(127);
    execvpe(argv[0], argv.data(), envp.data());
    std::fprintf(stderr, "camlab vcam run: cannot run %s: %s\n", argv[0], std::strerror(errno));
    _exit(127);
  }
  forwarded_child = child;
  struct sigaction forward {};
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

// The devices of `vcam run` and `vcam serve`.
void add_device_options(CLI::App* command, VcamArgs* args) {
  command
      ->add_option(
          "--camera", args->camera,
          "camera spec JSON (default: camlab's 640x480 10-bit virtual camera, as camlabd's)")
      ->check(CLI::ExistingFile);
  command
      ->add_option("--scene", args->scene,
                   "scene spec JSON (default: slanted edges at 0.7, 1 and 2 m, as camlabd's)")
      ->check(CLI::ExistingFile);
  CLI::Option* count = command->add_option("--count", args->count, "number of virtual cameras")
                           ->check(CLI::Range(1, 8));
  command
      ->add_option("--rig", args->rig,
                   "rig spec JSON: 2-8 cameras, each its own spec and pose (rt_cam_ref), one "
                   "scene, one frame clock (frames one trigger starts share a timestamp); "
                   "/dev/videoN is camera N (docs/virtual-camera.md, \"Rigs\")")
      ->check(CLI::ExistingFile)
      ->excludes("--camera")
      ->excludes("--scene")
      ->excludes(count);
}

}  // namespace

void register_vcam_command(CLI::App& app) {
  CLI::App* vcam =
      app.add_subcommand("vcam", "The virtual camera as V4L2 devices for any program.");
  vcam->require_subcommand(1);
  auto args = std::make_shared<VcamArgs>();
  CLI::App* run = vcam->add_subcommand(
      "run",
      "Run COMMAND with N virtual cameras present as /dev/video0.. (user space: an LD_PRELOAD\n"
      "library answers the V4L2 calls; no kernel module). Returns COMMAND's exit status.\n"
      "Example: camlab vcam run -- v4l2-ctl -d /dev/video0 --stream-mmap --stream-count=30 "
      "--stream-to=f.raw\n"
      "All processes of COMMAND (it may be a shell running several) share the same devices:\n"
      "a control one process sets is what the next one reads, as with a kernel driver.");
  add_device_options(run, args.get());
  run->add_flag("--unpaced", args->unpaced,
                "no frame clock: a frame is made as soon as a buffer is queued (fast tests; no "
                "dropped frames)");
  run->add_option("command", args->command, "the command and its arguments (after --)")->required();
  run->callback([args] { throw CLI::RuntimeError(run_vcam(*args)); });

  auto serve_args = std::make_shared<VcamArgs>();
  CLI::App* serve = vcam->add_subcommand(
      "serve",
      "Serve N virtual cameras until interrupted, and print the environment (LD_PRELOAD and\n"
      "CAMLAB_VCAM_*) under which any program in any shell sees them as /dev/video0.. .\n"
      "Keep it running in one shell and paste the export lines into another.");
  add_device_options(serve, serve_args.get());
  serve->callback([serve_args] { throw CLI::RuntimeError(serve_vcam(*serve_args)); });

  auto fault_args = std::make_shared<FaultArgs>();
  CLI::App* fault = vcam->add_subcommand(
      "fault",
      "Inject a fault into a virtual camera of the surrounding `camlab vcam run` (or serve), to\n"
      "test how a program copes: unplug (ENODEV from then on), replug (an unplugged camera\n"
      "is plugged in again: new opens work, fds opened before stay dead), eio (the next COUNT "
      "dequeues\n"
      "fail with EIO), drop (the next COUNT frames are lost: sequence gaps), stall (no frames\n"
      "until resume), resume.\n"
      "Example: camlab vcam run -- sh -c 'my_capture & sleep 2; camlab vcam fault unplug; wait'");
  fault->add_option("fault", fault_args->fault, "unplug | replug | eio | drop | stall | resume")
      ->required()
      ->check(CLI::IsMember({"unplug", "replug", "eio", "drop", "stall", "resume"}));
  fault->add_option("--device", fault_args->device, "which /dev/videoN (default 0)")
      ->check(CLI::Range(0, 7));
  fault->add_option("--count", fault_args->count, "for eio and drop: how many (default 1)")
      ->check(CLI::Range(1, 100000));
  fault->callback([fault_args] { throw CLI::RuntimeError(inject_vcam_fault(*fault_args)); });
}

}  // namespace camlab::cli
