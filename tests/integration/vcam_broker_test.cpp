// One device across processes: in one `camlab vcam run`, every process reaches the same
// virtual camera through the broker, with a kernel driver's semantics: a control one
// process sets is read by the next, one streaming process makes the queue busy for the
// others, and a process that dies releases what it held. Also every interposed entry
// point, including syscall() as libv4l2 uses it.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_runner.h"

namespace {

namespace fs = std::filesystem;
using camlab::testing::run_cli;

class VcamBroker : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists("/usr/bin/v4l2-ctl")) GTEST_SKIP() << "v4l2-ctl (v4l-utils) is not installed";
    dir = fs::temp_directory_path() /
          ("camlab_vcam_broker_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
    // Small and quick: 160x120 (80x60 binned), 50 fps.
    std::ofstream(dir / "camera.json") << R"({
      "name": "vcam broker test",
      "sensor": {"width_px": 160, "height_px": 120, "pixel_pitch_um": 4.0, "bit_depth": 8,
                 "black_level_dn": 4, "full_well_e": 12000, "read_noise_e": 2},
      "lens": {"focal_mm": 8.0, "f_number_min": 2.0, "f_number_max": 16.0},
      "timing": {"frame_interval_us": 20000, "control_latency_frames": 2},
      "controls": {"exposure_time_absolute": {"min": 1, "max": 200, "default": 50}}})";
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string vcam_sh(const std::string& script) const {
    return "vcam run --camera " + (dir / "camera.json").string() + " -- sh -c '" + script + "'";
  }
  fs::path dir;
};

TEST_F(VcamBroker, AControlSetInOneProcessIsSeenByTheNextAndByCamlab) {
  auto run = run_cli(
      vcam_sh("v4l2-ctl -d /dev/video0 --set-ctrl exposure_time_absolute=200 && "
              "v4l2-ctl -d /dev/video0 --get-ctrl exposure_time_absolute && " CAMLAB_CLI_PATH
              " devices --json --no-libcamera"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("exposure_time_absolute: 200"), std::string::npos) << run.out;
  const auto json_start = run.out.find('[');
  ASSERT_NE(json_start, std::string::npos) << run.out;
  const auto devices = nlohmann::json::parse(run.out.substr(json_start));
  bool seen = false;
  for (const auto& control : devices.at(0).at("controls"))
    if (control.at("name") == "exposure_time_absolute") seen = control.at("current") == 200;
  EXPECT_TRUE(seen) << devices.dump(2);
}

TEST_F(VcamBroker, OneStreamingProcessMakesTheQueueBusyForAnother) {
  auto run =
      run_cli(vcam_sh("v4l2-ctl -d /dev/video0 --stream-mmap --stream-count=200 "
                      "--stream-to=/dev/null >/dev/null 2>&1 & "
                      "sleep 0.5; v4l2-ctl -d /dev/video0 --stream-mmap --stream-count=2 "
                      "--stream-to=/dev/null; kill $!; wait"));
  EXPECT_NE((run.out + run.err).find("VIDIOC_REQBUFS returned -1 (Device or resource busy)"),
            std::string::npos)
      << run.out << run.err;
}

TEST_F(VcamBroker, AProcessKilledWhileStreamingReleasesTheDevice) {
  const fs::path frames = dir / "after.raw";
  auto run = run_cli(vcam_sh(
      "v4l2-ctl -d /dev/video0 --stream-mmap --stream-count=100000 --stream-to=/dev/null "
      ">/dev/null 2>&1 & "
      "pid=$!; sleep 0.5; kill -9 $pid; wait; "
      "v4l2-ctl -d /dev/video0 --set-fmt-video=pixelformat=GREY,width=160,height=120 --stream-mmap "
      "--stream-count=3 --stream-to=" +
      frames.string()));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  ASSERT_TRUE(fs::exists(frames)) << run.out << run.err;
  EXPECT_EQ(fs::file_size(frames), 3u * 160u * 120u) << run.out << run.err;
}

TEST_F(VcamBroker, LibV4l2StreamsThroughSyscall) {
  // v4l2-ctl -w goes through libv4l2, which makes its ioctls with syscall(SYS_ioctl).
  const fs::path frames = dir / "libv4l2.raw";
  auto run = run_cli(
      vcam_sh("v4l2-ctl -w -d /dev/video0 --set-fmt-video=pixelformat=GREY,width=160,height=120 "
              "--stream-mmap --stream-count=5 --stream-to=" +
              frames.string()));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  ASSERT_TRUE(fs::exists(frames)) << run.out << run.err;
  EXPECT_EQ(fs::file_size(frames), 5u * 160u * 120u);
}

TEST_F(VcamBroker, EveryInterposedEntryPointBehavesLikeTheKernel) {
  auto run = run_cli("vcam run --camera " + (dir / "camera.json").string() +
                     " -- " VCAM_ENTRY_POINTS_CLIENT);
  EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_NE(run.out.find("all entry points ok"), std::string::npos) << run.out << run.err;
}

TEST_F(VcamBroker, ServeSharesTheDevicesWithProgramsStartedElsewhere) {
  // `camlab vcam serve` prints the environment; programs started with it (here in the
  // same shell, as a user would in another) see one device. Bounded wait for the lines.
  const fs::path env_file = dir / "serve.env";
  const std::string script =
      std::string(CAMLAB_CLI_PATH) + " vcam serve --camera " + (dir / "camera.json").string() +
      " > " + env_file.string() + " & pid=$!; for i in $(seq 100); do grep -q CAMLAB_VCAM_SYSFS " +
      env_file.string() + " 2>/dev/null && break; sleep 0.1; done; eval \"$(grep ^export " +
      env_file.string() +
      ")\"; "
      "v4l2-ctl -d /dev/video0 --set-ctrl exposure_time_absolute=123; v4l2-ctl -d /dev/video0 -C "
      "exposure_time_absolute; "
      "kill $pid; wait $pid";
  std::string command = "sh -c '" + script + "'";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string out;
  char buffer[1024];
  for (size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) out.append(buffer, n);
  const int status = pclose(pipe);
  EXPECT_NE(out.find("exposure_time_absolute: 123"), std::string::npos) << out;
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << out;  // serve exits 0 on SIGTERM
}

}  // namespace
