// Renders a list of settings into a capture folder as `camlab render` does (one frame per
// entry), so analysis tests can vary several settings at once (e.g. exposure with the
// f-number to keep the signal level). Small specs built in code; see test_specs.h.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "fresh_dir.h"
#include "image/capture_folder.h"
#include "mock_device/render/renderer.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/scene_spec.h"

namespace camlab::analysis::testing {

inline mock::Renderer make_renderer(const nlohmann::json& camera, const nlohmann::json& scene) {
  auto c = mock::parse_camera_spec(camera);
  auto s = mock::parse_scene_spec(scene);
  if (!c || !s) throw std::runtime_error(!c ? c.error().message : s.error().message);
  auto r = mock::Renderer::create(std::move(*c), std::move(*s));
  if (!r) throw std::runtime_error(r.error().message);
  return std::move(*r);
}

inline void render_frames(mock::Renderer& renderer, const std::filesystem::path& dir,
                          const std::vector<mock::RenderSettings>& settings, uint64_t seed,
                          bool noise = true, bool keep_truth = true) {
  const auto& cam = renderer.camera();
  nlohmann::json source = {{"backend", "virtual"},
                           {"camera", cam.name},
                           {"camera_spec", cam.source},
                           {"scene_spec", renderer.scene().source}};
  if (!keep_truth) source = {{"backend", "unknown"}};
  auto writer = image::CaptureFolderWriter::create(dir, "render", source, {{"seed", seed}});
  if (!writer) throw std::runtime_error(writer.error().message);
  for (size_t i = 0; i < settings.size(); ++i) {
    mock::RenderOptions o;
    o.seed = seed;
    o.frame_number = i;
    o.noise = noise;
    auto frame = renderer.render(settings[i], 0, o);
    if (!frame) throw std::runtime_error(frame.error().message);
    image::FrameSidecar side;
    side.sequence = i;
    side.clock = "virtual";
    side.pixel_format = cam.sensor.bit_depth <= 8 ? "GREY" : "Y16";
    side.bit_depth = cam.sensor.bit_depth;
    side.black_level_dn = cam.sensor.black_level_dn;
    side.settings = frame->settings;
    side.labels = {{"view", 0}, {"sweep_index", i}, {"repeat", 0}};
    side.truth = keep_truth ? frame->truth : nlohmann::json();  // null: a real camera
    if (auto added = writer->add_frame(frame->image, side); !added)
      throw std::runtime_error(added.error().message);
  }
  if (Status s = writer->finish(); !s) throw std::runtime_error(s.error().message);
}

}  // namespace camlab::analysis::testing
