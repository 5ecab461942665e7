// `camlab devices`: every camera with its backend, path, formats and controls.
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "command_errors.h"
#include "commands.h"
#include "device/camera_json.h"
#include "device/device_registry.h"
#include "mock_device/spec/default_specs.h"
#include "mock_device/v4l2/virtual_v4l2_io.h"

namespace camlab::cli {

namespace {

struct DevicesArgs {
  std::string virtual_camera;
  std::string virtual_scene;
  bool json = false;
  bool no_libcamera = false;
};

void print_text(const nlohmann::json& camera, const std::string& transport) {
  std::printf("%s  %s  (%s, %s, %s)\n", camera["id"].get<std::string>().c_str(),
              camera["path"].get<std::string>().c_str(), camera["name"].get<std::string>().c_str(),
              camera["driver"].get<std::string>().c_str(), transport.c_str());
  for (const auto& format : camera["formats"]) {
    std::printf("  format %s (%s):", format["fourcc"].get<std::string>().c_str(),
                format["description"].get<std::string>().c_str());
    for (const auto& size : format["sizes"]) {
      std::printf(" %ux%u", size["width_px"].get<unsigned>(), size["height_px"].get<unsigned>());
      for (const auto& interval : size["intervals"])
        std::printf(" @%.3g", interval["frames_per_second"].get<double>());
    }
    std::printf(" fps\n");
  }
  for (const auto& c : camera["controls"]) {
    std::printf(
        "  %-28s %-8s [%lld, %lld] step %lld default %lld current %lld%s%s%s\n",
        c["name"].get<std::string>().c_str(), c["type"].get<std::string>().c_str(),
        c["min"].get<long long>(), c["max"].get<long long>(), c["step"].get<long long>(),
        c["default"].get<long long>(), c["current"].get<long long>(),
        c["unit"].get<std::string>().empty() ? "" : ("  " + c["unit"].get<std::string>()).c_str(),
        c["inactive"].get<bool>() ? "  (inactive)" : "",
        c["read_only"].get<bool>() ? "  (read-only)" : "");
    if (c.contains("menu"))
      for (const auto& item : c["menu"])
        std::printf("  %28s %lld: %s\n", "", item["value"].get<long long>(),
                    item["name"].get<std::string>().c_str());
  }
}

void run_devices(const DevicesArgs& args) {
  const CommandErrors errors("camlab devices", args.json);
  device::DeviceRegistry registry;
  registry.add_v4l2(device::system_v4l2_io(), "kernel");
  // libcamera's cameras too: a UVC webcam is listed once per backend that reaches it.
  if (device::DeviceRegistry::libcamera_supported() && !args.no_libcamera)
    if (Status status = registry.add_libcamera(); !status)
      std::fprintf(stderr, "camlab devices: libcamera: %s\n", status.error().message.c_str());
  std::shared_ptr<mock::VirtualV4l2Io> virtual_io;
  if (!args.virtual_camera.empty()) {
    mock::CameraSpec camera = errors.take(mock::load_camera_spec(args.virtual_camera));
    mock::SceneSpec scene = args.virtual_scene.empty()
                                ? mock::default_scene_spec()
                                : errors.take(mock::load_scene_spec(args.virtual_scene));
    mock::VirtualDeviceOptions options;
    options.index = static_cast<int>(registry.devices().size());
    std::shared_ptr<mock::VirtualV4l2Device> device =
        errors.take(mock::VirtualV4l2Device::create(std::move(camera), std::move(scene), options));
    virtual_io = std::make_shared<mock::VirtualV4l2Io>(std::vector{std::move(device)});
    registry.add_v4l2(virtual_io, "in-process virtual camera",
                      {"/dev/video" + std::to_string(options.index)});
  }
  nlohmann::json out = nlohmann::json::array();
  for (const auto& entry : registry.devices()) {
    auto camera = registry.open(entry.identity.id);
    nlohmann::json description =
        camera ? device::describe_camera(**camera) : device::to_json(entry.identity);
    if (!camera) description["errors"] = {camera.error().message};
    description["transport"] = entry.transport;
    out.push_back(description);
  }
  if (args.json) {
    std::cout << out.dump(2) << "\n";
    return;
  }
  if (out.empty()) {
    std::printf(
        "no cameras found (no /dev/video* capture device answered); "
        "--virtual CAM.json adds the virtual camera\n");
    return;
  }
  for (const auto& camera : out) print_text(camera, camera["transport"].get<std::string>());
}

}  // namespace

void register_devices_command(CLI::App& app) {
  auto args = std::make_shared<DevicesArgs>();
  CLI::App* cmd = app.add_subcommand(
      "devices",
      "List cameras: every V4L2 capture device (/dev/video*) and every camera libcamera finds,\n"
      "with its id, formats, frame sizes and rates, and controls with ranges, defaults, current\n"
      "values and units.");
  cmd->add_option(
         "--virtual", args->virtual_camera,
         "also list an in-process virtual camera with this camera spec (docs/virtual-camera.md)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--scene", args->virtual_scene,
                  "scene spec for the virtual camera (default: slanted edges at 0.7, 1 and 2 m, as "
                  "camlabd's)")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--json", args->json, "print JSON");
  cmd->add_flag("--no-libcamera", args->no_libcamera,
                device::DeviceRegistry::libcamera_supported()
                    ? "list V4L2 devices only, not also the cameras libcamera finds"
                    : "(camlab was built without libcamera: V4L2 devices only anyway)");
  cmd->callback([args] { run_devices(*args); });
}

}  // namespace camlab::cli
