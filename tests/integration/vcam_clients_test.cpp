// The V4L2 programs Debian ships, unmodified, against the virtual camera under `camlab
// vcam run`: each must find the camera the way it looks for cameras, and what it captures
// must be the camera's image (a decodable picture whose mean and edge contrast are the
// renderer's, client_programs.h). The programs come from scripts/install-deps.sh; a test
// whose program is missing says so and skips. Every program runs with a time limit, on
// loopback ports, in a temporary folder.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "cli_runner.h"
#include "client_programs.h"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using camlab::testing::BackgroundProgram;
using camlab::testing::is_the_cameras_image;
using camlab::testing::run_cli;

bool installed(const char* program) { return fs::exists(fs::path("/usr/bin") / program); }

// What gst-device-monitor printed for the camera, checked for the provider that found it
// (its name goes into `seen`).
void expect_device_monitor_found_the_camera(const std::string& out, std::set<std::string>* seen) {
  EXPECT_NE(out.find("Device found:"), std::string::npos) << out;
  const bool through_libcamera = out.find("libcamerasrc") != std::string::npos;
  seen->insert(through_libcamera ? "libcamera" : "v4l2");
  std::printf("gst-device-monitor found the camera through %s\n",
              through_libcamera ? "libcamera's provider (gstreamer1.0-libcamera)" : "V4L2's");
  if (through_libcamera) {
    EXPECT_NE(out.find("class : Source/Video"), std::string::npos) << out;
    EXPECT_NE(out.find("CAMLAB"), std::string::npos) << "the camera's libcamera id" << out;
    EXPECT_NE(out.find("video/x-raw, format=YUY2, width=640, height=480"), std::string::npos)
        << out;
    return;
  }
  EXPECT_NE(out.find("name  : vcam clients test"), std::string::npos) << out;
  EXPECT_NE(out.find("class : Video/Source"), std::string::npos) << out;
  EXPECT_NE(out.find("udev-probed = true"), std::string::npos) << "found by udev" << out;
  EXPECT_NE(out.find("device.path = /dev/video0"), std::string::npos) << out;
  // Its caps: the sensor's size at the spec's rate, as a driver reports 33333 us.
  EXPECT_NE(out.find("format=YUY2, width=640, height=480, framerate={ (fraction)30/1, "
                     "(fraction)15/1 }"),
            std::string::npos)
      << out;
}

class VcamClients : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("camlab_clients_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::ofstream(dir / "camera.json") << camlab::testing::kClientCameraJson;
    std::ofstream(dir / "scene.json") << camlab::testing::kClientSceneJson;
  }
  void TearDown() override { fs::remove_all(dir); }

  // `camlab vcam run [--count N] -- ` with the client camera and scene.
  std::string vcam(int count = 1) const {
    return "vcam run --count " + std::to_string(count) + " --camera " +
           (dir / "camera.json").string() + " --scene " + (dir / "scene.json").string() + " -- ";
  }
  std::vector<std::string> vcam_argv(std::vector<std::string> program) const {
    std::vector<std::string> argv = {CAMLAB_CLI_PATH,
                                     "vcam",
                                     "run",
                                     "--camera",
                                     (dir / "camera.json").string(),
                                     "--scene",
                                     (dir / "scene.json").string(),
                                     "--"};
    argv.insert(argv.end(), program.begin(), program.end());
    return argv;
  }
  cv::Mat truth() {
    if (truth_.empty()) truth_ = camlab::testing::truth_image(dir);
    return truth_;
  }

  fs::path dir;
  cv::Mat truth_;
};

TEST_F(VcamClients, AShellGlobListsTheNodes) {
  auto run = run_cli(vcam(2) + "sh -c 'ls -d /dev/video* /dev/media*'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.out, "/dev/media0\n/dev/media1\n/dev/video0\n/dev/video1\n");
}

TEST_F(VcamClients, V4l2CtlListDevicesGroupsEachCamerasNodes) {
  if (!installed("v4l2-ctl")) GTEST_SKIP() << "v4l2-ctl (v4l-utils) is not installed";
  auto run = run_cli(vcam(2) + "timeout -k 5 60 v4l2-ctl --list-devices");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  // One paragraph per camera, by bus: its video node and its media controller node.
  EXPECT_NE(
      run.out.find("vcam clients test (platform:camlab-vcam-0):\n\t/dev/video0\n\t/dev/media0\n"),
      std::string::npos)
      << run.out;
  EXPECT_NE(
      run.out.find("vcam clients test (platform:camlab-vcam-1):\n\t/dev/video1\n\t/dev/media1\n"),
      std::string::npos)
      << run.out;
}

// A rig: each camera its own device with its own spec (the example pair: 640x480 left,
// 1280x800 right), as v4l2-ctl reads them; --rig replaces --camera, --scene and --count.
TEST_F(VcamClients, ARigsCamerasAreItsDevicesEachWithItsOwnSpec) {
  if (!installed("v4l2-ctl")) GTEST_SKIP() << "v4l2-ctl (v4l-utils) is not installed";
  const std::string rig = CAMLAB_SOURCE_DIR "/mock_device/examples/rig_stereo_pair.json";
  auto run =
      run_cli("vcam run --rig " + rig +
              " -- sh -c 'timeout -k 5 60 v4l2-ctl -d /dev/video0 --get-fmt-video && "
              "timeout -k 5 60 v4l2-ctl -d /dev/video1 --get-fmt-video && ls -d /dev/video*'");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const size_t left = run.out.find("Width/Height      : 640/480");
  const size_t right = run.out.find("Width/Height      : 1280/800");
  ASSERT_NE(left, std::string::npos) << run.out;
  ASSERT_NE(right, std::string::npos) << run.out;
  EXPECT_LT(left, right) << "camera 0 is /dev/video0";
  EXPECT_NE(run.out.find("/dev/video0\n/dev/video1\n"), std::string::npos) << run.out;
  auto both = run_cli("vcam run --rig " + rig + " --count 2 -- true");
  EXPECT_NE(both.exit_code, 0);
  EXPECT_NE(both.err.find("excludes"), std::string::npos) << both.err;
}

// udev's persistent names: each camera of a rig under /dev/v4l/by-id (by its USB serial)
// and by-path (by its port), links to its own node, which v4l2-ctl opens through the link
// (the right camera's 1280x800 format through its by-path name) and ls lists as links.
TEST_F(VcamClients, PersistentNamesUnderDevV4lLeadToEachRigCamera) {
  if (!installed("v4l2-ctl")) GTEST_SKIP() << "v4l2-ctl (v4l-utils) is not installed";
  const std::string rig = CAMLAB_SOURCE_DIR "/mock_device/examples/rig_stereo_pair.json";
  const std::string right_by_path =
      "/dev/v4l/by-path/platform-camlab_vcam_hcd.0-usb-0:2:1.0-video-index0";
  auto run = run_cli("vcam run --rig " + rig +
                     " -- sh -c 'ls /dev && ls -l /dev/v4l/by-id /dev/v4l/by-path && "
                     "timeout -k 5 60 v4l2-ctl -d " +
                     right_by_path +
                     " --get-fmt-video && readlink -f /dev/v4l/by-id/*camlab-vcam-0-video-index0'");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  EXPECT_NE(run.out.find("\nv4l\n"), std::string::npos) << "/dev lists v4l\n" << run.out;
  for (const char* link :
       {"usb-camlab_camlab_virtual_640x480__OPENCV4_camlab-vcam-0-video-index0 -> ../../video0",
        "camlab-vcam-1-video-index0 -> ../../video1",
        "platform-camlab_vcam_hcd.0-usb-0:1:1.0-video-index0 -> ../../video0",
        "platform-camlab_vcam_hcd.0-usb-0:2:1.0-video-index0 -> ../../video1"})
    EXPECT_NE(run.out.find(link), std::string::npos) << link << " in\n" << run.out;
  EXPECT_NE(run.out.find("Width/Height      : 1280/800"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("\n/dev/video0\n"), std::string::npos) << run.out;
}

// gst-device-monitor lists the camera through whichever provider finds it: V4L2's (udev
// probed, /dev/video0, its caps with the frame rates) or, on a machine with Debian's
// gstreamer1.0-libcamera (as most that run libcamera have), libcamera's, which then hides
// the V4L2 one (class Source/Video, libcamerasrc, the camera by libcamera's id). Either is
// the camera found; the test says which it saw, and where the package is installed it runs
// the monitor both ways (scripts/install-deps.sh installs it, so CI shows both).
TEST_F(VcamClients, GstreamersDeviceMonitorFindsTheCameraThroughUdev) {
  if (!installed("gst-device-monitor-1.0"))
    GTEST_SKIP() << "gst-device-monitor-1.0 (gstreamer1.0-plugins-base-apps) is not installed";
  // The monitor as this machine has it, then, where libcamera's plugin is installed, as a
  // machine without it: a plugin path of every other plugin and a registry of its own.
  const fs::path plugins = "/usr/lib/x86_64-linux-gnu/gstreamer-1.0";
  const bool has_libcamera = fs::exists(plugins / "libgstlibcamera.so");
  std::vector<std::string> environments = {""};
  if (has_libcamera) {
    const fs::path without = dir / "plugins-without-libcamera";
    fs::create_directories(without);
    for (const auto& e : fs::directory_iterator(plugins))
      if (e.path().extension() == ".so" && e.path().filename() != "libgstlibcamera.so")
        fs::create_symlink(e.path(), without / e.path().filename());
    environments.push_back("GST_PLUGIN_SYSTEM_PATH_1_0=" + without.string() +
                           " GST_REGISTRY_1_0=" + (dir / "registry.bin").string() + " ");
  }
  std::set<std::string> seen;
  for (const std::string& environment : environments) {
    auto run = run_cli(vcam() + "env " + environment +
                       "timeout -k 5 60 gst-device-monitor-1.0 Video/Source");
    ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
    expect_device_monitor_found_the_camera(run.out, &seen);
  }
  // With libcamera's plugin its provider, without it V4L2's: both ways were seen.
  EXPECT_EQ(seen.size(), environments.size());
}

TEST_F(VcamClients, UstreamerServesTheCamerasImageAsASnapshot) {
  if (!installed("ustreamer")) GTEST_SKIP() << "ustreamer is not installed";
  const int port = camlab::testing::free_loopback_port();
  ASSERT_GT(port, 0);
  BackgroundProgram ustreamer(
      vcam_argv({"/usr/bin/ustreamer", "--device=/dev/video0", "--resolution=640x480",
                 "--format=YUYV", "--host=127.0.0.1", "--port=" + std::to_string(port)}),
      dir / "ustreamer.log");
  // Until the first frame, /snapshot is ustreamer's black "no signal" picture: wait for
  // the camera's.
  cv::Mat snapshot;
  const bool served = camlab::testing::wait_for(60s, [&] {
    auto reply = camlab::testing::http_get(port, "/snapshot", 3000ms);
    if (!reply || reply->status != 200) return false;
    const std::vector<uint8_t> bytes(reply->body.begin(), reply->body.end());
    snapshot = cv::imdecode(bytes, cv::IMREAD_COLOR);
    return !snapshot.empty() && cv::mean(snapshot)[1] > 10;
  });
  ustreamer.stop();
  ASSERT_TRUE(served) << camlab::testing::read_text(dir / "ustreamer.log");
  EXPECT_TRUE(is_the_cameras_image(snapshot, truth()));
}

TEST_F(VcamClients, MotionWritesSnapshotsOfTheCamerasImage) {
  if (!installed("motion")) GTEST_SKIP() << "motion is not installed";
  const fs::path out = dir / "motion";
  fs::create_directories(out);
  // No web control or stream ports, no movies: one snapshot a second into `out`.
  std::ofstream(dir / "motion.conf") << "daemon off\nsetup_mode off\nlog_level 6\n"
                                        "videodevice /dev/video0\nwidth 640\nheight 480\n"
                                        "framerate 10\ntarget_dir "
                                     << out.string()
                                     << "\nsnapshot_interval 1\nsnapshot_filename snap-%v-%s\n"
                                        "picture_output off\npicture_type jpeg\n"
                                        "movie_output off\nwebcontrol_port 0\nstream_port 0\n"
                                        "emulate_motion off\n";
  BackgroundProgram motion(
      vcam_argv({"/usr/bin/motion", "-n", "-c", (dir / "motion.conf").string()}),
      dir / "motion.log");
  fs::path snapshot;
  const bool written = camlab::testing::wait_for(60s, [&] {
    for (const auto& entry : fs::directory_iterator(out))
      if (entry.path().extension() == ".jpg" && entry.path().filename() != "lastsnap.jpg" &&
          fs::file_size(entry.path()) > 0) {
        snapshot = entry.path();
        return true;
      }
    return false;
  });
  // Motion writes the file as it encodes: let it finish before reading.
  std::this_thread::sleep_for(500ms);
  motion.stop();
  ASSERT_TRUE(written) << camlab::testing::read_text(dir / "motion.log");
  EXPECT_TRUE(is_the_cameras_image(cv::imread(snapshot.string()), truth())) << snapshot;
}

TEST_F(VcamClients, FswebcamWritesTheCamerasImage) {
  if (!installed("fswebcam")) GTEST_SKIP() << "fswebcam is not installed";
  const fs::path image = dir / "fswebcam.jpg";
  auto run = run_cli(vcam() +
                     "timeout -k 5 60 fswebcam --device /dev/video0 --resolution 640x480 "
                     "--palette YUYV --skip 2 --no-banner " +
                     image.string());
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  EXPECT_TRUE(is_the_cameras_image(cv::imread(image.string()), truth())) << run.err;
}

TEST_F(VcamClients, UvccapturesYuyvModeWritesTheCamerasImage) {
  if (!installed("uvccapture")) GTEST_SKIP() << "uvccapture is not installed";
  // -m: YUYV, compressed by uvccapture itself; its default size is 320x240, the binned
  // mode.
  const fs::path image = dir / "uvccapture.jpg";
  auto run = run_cli(vcam() + "timeout -k 5 60 uvccapture -m -d/dev/video0 -o" + image.string());
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const cv::Mat picture = cv::imread(image.string());
  EXPECT_EQ(picture.cols, 320);
  EXPECT_TRUE(is_the_cameras_image(picture, truth())) << run.err;
}

TEST_F(VcamClients, UvccapturesDefaultMjpegModeSavesTheDevicesJpegHeaderOnly) {
  if (!installed("uvccapture")) GTEST_SKIP() << "uvccapture is not installed";
  if (!installed("v4l2-ctl")) GTEST_SKIP() << "v4l2-ctl (v4l-utils) is not installed";
  // The device's image processor (a colour sensor's) offers MJPEG.
  std::string colour = camlab::testing::kClientCameraJson;
  colour.replace(colour.find("\"shot_noise\": false"), 19,
                 "\"shot_noise\": false, \"cfa\": \"RGGB\"");
  std::ofstream(dir / "camera.json") << colour;
  auto formats = run_cli(vcam() + "timeout -k 5 60 v4l2-ctl -d /dev/video0 --list-formats");
  ASSERT_EQ(formats.exit_code, 0) << formats.err;
  if (formats.out.find("'MJPG'") == std::string::npos)
    GTEST_SKIP() << "the virtual device does not offer MJPEG (VIDIOC_ENUM_FMT lists no MJPG), "
                    "and uvccapture's default mode asks for it without checking what S_FMT "
                    "gave: it would save a raw frame's first bytes as a .jpg";
  // uvccapture saves buf.bytesused + 420 bytes after re-queueing the buffer, and VIDIOC_QBUF
  // sets bytesused to 0 for a capture buffer (videobuf2, as the virtual device does): so
  // it writes the first 175 bytes of the device's JPEG and its own 245-byte Huffman tables,
  // 420 bytes, whatever the camera, kernel or virtual. Check that it got the device's JPEG:
  // those bytes are the start of a frame v4l2-ctl streams (the camera has no noise, so
  // every frame is the same JPEG).
  const fs::path image = dir / "uvccapture.jpg", frame = dir / "frame.mjpg";
  auto run =
      run_cli(vcam() + "sh -c 'timeout -k 5 60 uvccapture -d/dev/video0 -o" + image.string() +
              " && timeout -k 5 60 v4l2-ctl -d /dev/video0 "
              "--set-fmt-video=width=320,height=240,pixelformat=MJPG --stream-mmap "
              "--stream-count=1 --stream-to=" +
              frame.string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const std::string saved = camlab::testing::read_text(image);
  const std::string streamed = camlab::testing::read_text(frame);
  ASSERT_GT(streamed.size(), 420u);
  EXPECT_EQ(streamed.substr(0, 2), "\xFF\xD8") << "the device's frame is a JPEG";
  EXPECT_EQ(saved.size(), 420u) << "bytesused was not 0 after QBUF, as videobuf2 makes it";
  EXPECT_EQ(saved.substr(0, 175), streamed.substr(0, 175)) << "the device's JPEG header";
}

}  // namespace
