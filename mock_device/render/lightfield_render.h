// The virtual light-field (plenoptic) camera (docs/virtual-camera.md, "Light fields"):
// the sub-aperture views of a scene, the raw lenslet image a plenoptic sensor records,
// and their truth, from a camera spec with a `lightfield` block.
//
// Views. View (i, j) is the image through cell (i, j) of a U x V grid over the aperture
// disk's bounding square (optics/aperture_cells.h) alone: the renderer's thin-lens
// integral with the disk replaced by the cell (Renderer::integrate_light_field, every
// cell in one pass over the pixels). Each view is exposed as the camera's thin-lens frame
// would be (the same electrons per unit reflectance): a view of a flat target reads what
// the frame reads, and the area-weighted mean of the views is the frame's scene integral.
// Cells that miss the disk have no view.
//
// Lenslet image. One microlens per view pixel images the aperture onto a U x U block of
// raw pixels, mirrored (raw pixel (a, b) of a block sees cell (U-1-a, U-1-b)), each raw
// pixel lit by its cell's share inside the disk (the white image shows that share). The
// raw image has the camera spec's sensor: a raw pixel behind a fully lit cell reads what
// the view reads (the exposure is the views'), with its own noise draws. Square grid:
// blocks side by side. Hexagonal grid: rows of blocks ceil(U sqrt 3 / 2) raw pixels apart
// and every odd row shifted by U/2, so its microlenses sit on a staggered lattice and the
// views are rendered there (odd rows half a pixel to the right, rows that lattice's pitch
// apart; each view pixel integrates over the p x row-pitch rectangle of its microlens).
// The white image is noise-free (the mean of many flat fields) at 80% of the range.
//
// Thread-bound: one call at a time per Renderer.
#pragma once

#include <filesystem>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "base/result.h"
#include "image/lightfield_folder.h"
#include "mock_device/render/renderer.h"

namespace camlab::mock {

struct LightFieldFrame {
  // The description a light-field folder carries (views' frames unset).
  image::LightFieldDescription description;
  std::vector<cv::Mat> views;  // DN (the sensor's depth), one per description.views entry
  cv::Mat depth_m;             // CV_32F truth on the view lattice (0: no surface)
  cv::Mat lenslet, white;      // raw DN; empty without a microlens grid
  nlohmann::json settings;     // as render() gives them
  nlohmann::json truth;        // as render() gives it, for every view
  RenderStats stats;
};

// Errors: "invalid_argument" (the camera spec has no lightfield block), and those of
// Renderer::render.
Result<LightFieldFrame> render_light_field(Renderer& renderer, const RenderSettings& settings,
                                           int view, const RenderOptions& options);

// Renders one light field into a light-field folder (src/image/lightfield_folder.h):
// the views as frames with their sidecars (settings, truth, labels u_index and v_index),
// lightfield.json, the lenslet and white images, the depth truth.
Status write_light_field(const LightFieldFrame& frame, const Renderer& renderer,
                         const std::filesystem::path& out_dir, const RenderOptions& options);

}  // namespace camlab::mock
