// camlabd: the REST capture daemon. Parses flags (and an optional config file), then
// serves (service/daemon.h).
#include <unistd.h>

#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "base/file_mode.h"
#include "base/log.h"
#include "service/daemon.h"

int main(int argc, char** argv) {
  camlab::log::set_program_name("camlabd");
  camlab::service::DaemonConfig config;
  bool no_virtual = false, no_scan = false, no_libcamera = false;
  int rescan_ms = static_cast<int>(config.cameras.rescan_interval.count());
  int read_timeout_s = static_cast<int>(config.limits.read_timeout.count());
  int frame_timeout_ms = static_cast<int>(config.cameras.worker.frame_timeout.count());

  CLI::App app{
      "camlabd: REST capture of exposure brackets, focus stacks and aperture series with "
      "frame-accurate\n"
      "settings (a frame is kept only once the new settings are in effect), plus calibration and "
      "analysis jobs.\n\n"
      "Defaults serve on a fresh machine: http://127.0.0.1:8080, data in ./camlab-data (SQLite "
      "database,\n"
      "capture folders, the API token), every V4L2 capture device found, and one in-process "
      "virtual camera\n"
      "when none is found. Every endpoint but GET /v1/health and the dashboard page needs\n"
      "'Authorization: Bearer TOKEN'; "
      "the token\n"
      "is generated on first start into DATA/token (mode 0600), never printed. The API is "
      "described by\n"
      "GET /v1/openapi.json and docs/service.md. SIGTERM or SIGINT stop it cleanly (exit 0).\n\n"
      "The dashboard (live view, histogram, controls, captures, plots) is at the address itself:\n"
      "open http://127.0.0.1:8080/ in a browser and paste the token (docs/dashboard.md).\n\n"
      "Example:\n"
      "  camlabd &\n"
      "  TOKEN=$(cat camlab-data/token)\n"
      "  curl -H \"Authorization: Bearer $TOKEN\" http://127.0.0.1:8080/v1/cameras"};
  app.set_version_flag("--version", "camlabd 0.1.0");
  app.set_config("--config", "",
                 "read options from a TOML/INI file (keys are the long option names)");
  app.add_option("--listen", config.listen,
                 "address to serve on, HOST:PORT (port 0: any free port)")
      ->capture_default_str();
  app.add_option("--data", config.data_dir, "data folder: database, capture folders, token")
      ->capture_default_str();
  app.add_option("--device", config.cameras.device_paths,
                 "serve only these V4L2 devices (repeatable), instead of every /dev/video*");
  app.add_flag("--no-scan", no_scan,
               "do not look for V4L2 or libcamera cameras (only the virtual camera)");
  app.add_flag("--no-libcamera", no_libcamera,
               "do not serve the cameras libcamera enumerates (V4L2 devices only)");
  app.add_flag("--prefer-libcamera", config.cameras.prefer_libcamera,
               "serve a camera reachable both as a V4L2 node and through libcamera (a UVC "
               "webcam) through\n"
               "libcamera, under its libcamera:ID; without it, through V4L2 under v4l2:BUS_INFO "
               "(listed once\n"
               "either way)");
  app.add_option("--rescan-ms", rescan_ms,
                 "look for cameras plugged in or out at least this often (besides inotify "
                 "events on /dev);\n"
                 "0: never (the cameras found at start are served until camlabd stops)")
      ->check(CLI::Range(0, 3600000))
      ->capture_default_str();
  CLI::Option* camera_spec =
      app.add_option("--camera-spec", config.cameras.camera_spec,
                     "camera spec JSON of an in-process virtual camera (docs/virtual-camera.md); "
                     "giving it adds the\n"
                     "virtual camera even when real cameras exist")
          ->check(CLI::ExistingFile);
  CLI::Option* scene =
      app.add_option("--scene", config.cameras.scene_spec, "scene spec JSON for the virtual camera")
          ->check(CLI::ExistingFile);
  CLI::Option* virtual_count = app.add_option("--virtual-count", config.cameras.virtual_count,
                                              "number of in-process virtual cameras")
                                   ->check(CLI::Range(1, 8))
                                   ->capture_default_str();
  app.add_option("--rig", config.cameras.rig_spec,
                 "rig spec JSON: in-process virtual cameras, each with its own spec and pose, on "
                 "one frame clock\n"
                 "(docs/virtual-camera.md, \"Rigs\"); a synchronised capture of them reports "
                 "each rig view's skew")
      ->check(CLI::ExistingFile)
      ->excludes(camera_spec)
      ->excludes(scene)
      ->excludes(virtual_count);
  app.add_flag("--no-virtual", no_virtual, "never add the in-process virtual camera");
  app.add_option("--device-spec", config.cameras.device_spec,
                 "camera spec JSON saying what the V4L2 cameras' raw values mean (sensor bit "
                 "depth, black level,\n"
                 "gain unity, iris f-numbers, focal length, focus steps); without it f-number "
                 "requests are refused")
      ->check(CLI::ExistingFile);
  app.add_option("--io-threads", config.io_threads, "threads running the HTTP io_context")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_option("--io-nice", config.io_nice,
                 "the I/O threads run this much nicer than the camera threads, so status "
                 "requests never take a capture's CPU (0: the same priority)")
      ->check(CLI::Range(0, 19))
      ->capture_default_str();
  app.add_option("--max-body-bytes", config.limits.max_body_bytes,
                 "largest request body (413 above)")
      ->check(CLI::Range(1024, 64 << 20))
      ->capture_default_str();
  app.add_option("--max-header-bytes", config.limits.max_header_bytes,
                 "largest request header block (431 above)")
      ->check(CLI::Range(1024, 1 << 20))
      ->capture_default_str();
  app.add_option("--read-timeout-s", read_timeout_s,
                 "a request must arrive within this many seconds")
      ->check(CLI::Range(1, 3600))
      ->capture_default_str();
  app.add_option("--max-connections", config.limits.max_connections, "open connections at most")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--max-queued-jobs", config.cameras.worker.max_queued_jobs,
                 "jobs queued per camera at most (429 above)")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  app.add_option("--frame-timeout-ms", frame_timeout_ms,
                 "a frame that does not arrive within this fails the job")
      ->check(CLI::Range(100, 600000))
      ->capture_default_str();
  std::string file_mode;
  app.add_option("--file-mode", file_mode,
                 "octal mode of the files camlabd writes (frames, sidecars, manifests, "
                 "reports), 0600..0666, e.g. 0640; default: 0666 less the umask, as for any "
                 "new file. The token stays 0600");
  app.add_option("--db", config.db,
                 "the job store: a PostgreSQL URL (postgresql://USER@HOST:PORT/DATABASE) shared "
                 "by a fleet of\n"
                 "camlabd hosts (docs/fleet.md); without it, SQLite in the data folder");
  std::string host_name;
  app.add_option("--host-name", host_name,
                 "this host's name in the fleet (with --db; default: the system's host name)");
  app.add_option("--advertise-url", config.advertise_url,
                 "where clients reach this host's API, for redirects to its frames (with --db; "
                 "default: http://LISTEN_ADDRESS:PORT)");
  int lease_ms = static_cast<int>(config.lease.count());
  app.add_option("--lease-ms", lease_ms,
                 "this host's lease in the fleet: renewed every third of it; a host that has not "
                 "renewed it\n"
                 "for this long is taken for dead and its jobs end interrupted (with --db)")
      ->check(CLI::Range(1000, 600000))
      ->capture_default_str();
  app.add_flag("--test-faults", config.test_faults,
               "TESTS ONLY: enable POST /v1/test/cameras/{id}/faults (fault injection into "
               "in-process virtual cameras)");
  CLI11_PARSE(app, argc, argv);

  if (!file_mode.empty()) {
    auto mode = camlab::parse_data_file_mode(file_mode);
    if (!mode) {
      std::fprintf(stderr, "camlabd: --file-mode: %s [%.*s]\n", mode.error().message.c_str(),
                   static_cast<int>(camlab::name_of(mode.error().code).size()),
                   camlab::name_of(mode.error().code).data());
      return 2;
    }
    camlab::set_data_file_mode(*mode);
  }
  config.cameras.scan_devices = !no_scan;
  config.cameras.libcamera = !no_scan && !no_libcamera;
  config.cameras.rescan_interval = std::chrono::milliseconds(rescan_ms);
  if (no_virtual)
    config.cameras.virtual_cameras = camlab::service::VirtualCameras::kNever;
  else if (!config.cameras.camera_spec.empty() || !config.cameras.rig_spec.empty())
    config.cameras.virtual_cameras = camlab::service::VirtualCameras::kAlways;
  config.limits.read_timeout = std::chrono::seconds(read_timeout_s);
  config.lease = std::chrono::milliseconds(lease_ms);
  if (host_name.empty()) {
    char name[256] = {};
    if (::gethostname(name, sizeof name - 1) == 0) host_name = name;
  }
  config.host_name = host_name;
  config.cameras.worker.frame_timeout = std::chrono::milliseconds(frame_timeout_ms);
  return camlab::service::run_daemon(config);
}
