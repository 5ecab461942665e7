#include "image/capture_folder.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <optional>
#include <system_error>

#include <opencv2/imgcodecs.hpp>

#include "base/atomic_file.h"
#include "image/frame_journal.h"
#include "image/jpeg_codec.h"

namespace camlab::image {

namespace fs = std::filesystem;

namespace {

std::optional<FrameLayout> layout_named(const std::string& name) {
  for (FrameLayout layout : {FrameLayout::kMono, FrameLayout::kMosaic, FrameLayout::kRgb})
    if (name_of(layout) == name) return layout;
  return std::nullopt;
}

}  // namespace

bool is_plain_file_name(const std::string& name) {
  return !name.empty() && name.find('/') == std::string::npos && name != "." && name != ".." &&
         name.find('\0') == std::string::npos;
}

std::string_view name_of(FrameLayout layout) {
  switch (layout) {
    case FrameLayout::kMono:
      return "mono";
    case FrameLayout::kMosaic:
      return "mosaic";
    case FrameLayout::kRgb:
      return "rgb";
  }
  return "mono";
}

Status check_mono_linear(const FrameSidecar& sidecar, const std::string& what) {
  if (!sidecar.linear) {
    const bool jpeg = sidecar.pixel_format == "MJPG" || sidecar.pixel_format == "JPEG";
    const bool undeclared = sidecar.transfer == TransferFunction::kUnknown;
    const std::string curve = sidecar.transfer == TransferFunction::kLinear ? ""
                              : sidecar.transfer == TransferFunction::kOther
                                  ? "a tone curve"
                                  : "the " + std::string(name_of(sidecar.transfer)) + " curve";
    const std::string why =
        undeclared ? (jpeg ? " is a JPEG (" + sidecar.delivered_format + "): lossy, and"
                           : " (" + sidecar.delivered_format + "):") +
                         " the camera declares no colour space for it, so how its DN relate to "
                         "light is not known"
                   : (jpeg ? " is a JPEG (" + sidecar.delivered_format + "): lossy" +
                                 (curve.empty() ? "" : " and encoded with " + curve)
                           : " (" + sidecar.delivered_format + ") is encoded with " + curve +
                                 ", as the camera declared") +
                         ", so its DN are not proportional to light";
    return make_error("not_linear", what + why +
                                        "; capture a raw or linear format instead (GREY, Y16, "
                                        "a Bayer format)");
  }
  if (sidecar.layout != FrameLayout::kMono)
    return make_error("unsupported", what + " is " +
                                         (sidecar.layout == FrameLayout::kMosaic
                                              ? "a raw " + sidecar.cfa_pattern + " Bayer mosaic"
                                              : std::string("an RGB frame")) +
                                         " (" + sidecar.pixel_format +
                                         "); this measurement reads mono frames");
  return {};
}

nlohmann::json to_json(const FrameSidecar& sidecar) {
  nlohmann::json json = {
      {"sequence", sidecar.sequence},
      {"timestamp_ns", sidecar.timestamp_ns},
      {"clock", sidecar.clock},
      {"pixel_format", sidecar.pixel_format},
      {"delivered_format", sidecar.delivered_format},
      {"layout", name_of(sidecar.layout)},
      {"cfa_pattern",
       sidecar.cfa_pattern.empty() ? nlohmann::json() : nlohmann::json(sidecar.cfa_pattern)},
      {"bit_depth", sidecar.bit_depth},
      {"black_level_dn", sidecar.black_level_dn},
      {"white_level_dn", sidecar.white_level_dn > 0
                             ? sidecar.white_level_dn
                             : (1 << std::clamp(sidecar.bit_depth, 1, 16)) - 1},
      {"linear", sidecar.linear},
      {"transfer", name_of(sidecar.transfer)},
      {"frames_discarded", sidecar.frames_discarded},
      {"settings", sidecar.settings},
      {"labels", sidecar.labels},
      {"truth", sidecar.truth},
  };
  return json;
}

Result<FrameSidecar> frame_sidecar_from_json(const nlohmann::json& json) {
  if (!json.is_object()) return make_error("bad_sidecar", "frame sidecar is not a JSON object");
  // Integers must be JSON integers: converting 1e300 to an int is undefined behaviour
  // (found by fuzzing), and a fraction of a DN or a frame is not a value any writer makes.
  for (const char* key : {"sequence", "timestamp_ns", "bit_depth", "black_level_dn",
                          "white_level_dn", "frames_discarded"})
    if (json.contains(key) && !json[key].is_number_integer())
      return make_error("bad_sidecar",
                        std::string("frame sidecar: ") + key + " must be an integer");
  FrameSidecar sidecar;
  try {
    sidecar.sequence = json.at("sequence").get<uint64_t>();
    sidecar.timestamp_ns = json.at("timestamp_ns").get<int64_t>();
    sidecar.clock = json.value("clock", "monotonic");
    sidecar.pixel_format = json.value("pixel_format", "");
    sidecar.delivered_format = json.value("delivered_format", "");
    sidecar.bit_depth = json.at("bit_depth").get<int>();
    sidecar.black_level_dn = json.value("black_level_dn", 0);
    // Version 1 sidecars have none of the colour keys: mono, linear, full scale.
    const std::string layout = json.value("layout", "mono");
    if (auto named = layout_named(layout)) {
      sidecar.layout = *named;
    } else {
      return make_error("bad_sidecar",
                        "frame sidecar: layout \"" + layout + "\" is not mono, mosaic or rgb");
    }
    if (json.contains("cfa_pattern") && !json["cfa_pattern"].is_null())
      sidecar.cfa_pattern = json["cfa_pattern"].get<std::string>();
    sidecar.linear = json.value("linear", true);
    sidecar.transfer = sidecar.linear ? TransferFunction::kLinear : TransferFunction::kOther;
    if (json.contains("transfer")) {
      const auto named = transfer_function_named(json["transfer"].get<std::string>());
      if (!named)
        return make_error("bad_sidecar", "frame sidecar: transfer " + json["transfer"].dump() +
                                             " is not linear, srgb, bt709, other or unknown");
      sidecar.transfer = *named;
    }
    if (sidecar.transfer != TransferFunction::kLinear && sidecar.linear)
      return make_error("bad_sidecar", "frame sidecar: linear is true but transfer is " +
                                           std::string(name_of(sidecar.transfer)));
    if (sidecar.bit_depth >= 1 && sidecar.bit_depth <= 16)
      sidecar.white_level_dn = json.value("white_level_dn", (1 << sidecar.bit_depth) - 1);
    sidecar.frames_discarded = json.value("frames_discarded", 0);
    sidecar.settings = json.value("settings", nlohmann::json::object());
    sidecar.labels = json.value("labels", nlohmann::json::object());
    sidecar.truth = json.value("truth", nlohmann::json());
  } catch (const nlohmann::json::exception& e) {
    return make_error("bad_sidecar", std::string("frame sidecar: ") + e.what());
  }
  if (sidecar.bit_depth < 1 || sidecar.bit_depth > 16)
    return make_error("bad_sidecar", "frame sidecar: bit_depth " +
                                         std::to_string(sidecar.bit_depth) + " is not in 1..16");
  if (sidecar.layout == FrameLayout::kMosaic && !is_bayer_pattern(sidecar.cfa_pattern))
    return make_error("bad_sidecar",
                      "frame sidecar: a mosaic needs cfa_pattern RGGB, BGGR, "
                      "GRBG or GBRG, not \"" +
                          sidecar.cfa_pattern + "\"");
  if (sidecar.white_level_dn <= sidecar.black_level_dn ||
      sidecar.white_level_dn > (1 << sidecar.bit_depth) - 1)
    return make_error("bad_sidecar",
                      "frame sidecar: white_level_dn " + std::to_string(sidecar.white_level_dn) +
                          " is not above black_level_dn " + std::to_string(sidecar.black_level_dn) +
                          " and within " + std::to_string(sidecar.bit_depth) + " bits");
  return sidecar;
}

int CaptureFolder::version() const {
  const auto it = manifest_.find("version");
  if (it == manifest_.end() || !it->is_number_integer()) return 0;
  const int64_t version = it->get<int64_t>();
  return version >= 1 && version <= 999 ? static_cast<int>(version) : 0;
}

bool CaptureFolder::complete() const {
  const auto it = manifest_.find("complete");
  return it != manifest_.end() && it->is_boolean() && it->get<bool>();
}

Result<CaptureFolder> CaptureFolder::open(const fs::path& dir) {
  auto text = read_text_file(dir / "manifest.json");
  if (!text)
    return make_error("not_a_capture",
                      dir.string() + " is not a capture folder (" + text.error().message + ")");
  CaptureFolder folder;
  folder.dir_ = dir;
  const std::string manifest_path = (dir / "manifest.json").string();
  try {
    folder.manifest_ = nlohmann::json::parse(*text);
    if (folder.manifest_.value("format", "") != kCaptureFormatName)
      return make_error("not_a_capture", manifest_path + " does not say format \"camlab-capture\"");
    // Read as typed values, never converted: a "version": 1e300 or a "complete": "yes"
    // is an error here, not undefined behaviour or an exception later (found by fuzzing).
    const int version = folder.version();
    if (version < 1 || version > kCaptureFormatVersion)
      return make_error("unsupported_version",
                        "capture format version " +
                            folder.manifest_.value("version", nlohmann::json()).dump() +
                            " is not supported (this camlab reads 1.." +
                            std::to_string(kCaptureFormatVersion) + ")");
    if (folder.manifest_.contains("complete") && !folder.manifest_["complete"].is_boolean())
      return make_error("bad_manifest", manifest_path + ": \"complete\" must be true or false");
    if (version <= 2) {
      for (const auto& f : folder.manifest_.at("frames")) {
        if (!f.is_object() || !f.value("index", nlohmann::json()).is_number_integer())
          return make_error("bad_manifest", manifest_path + ": a frame without an integer index");
        CaptureFrameEntry entry{f.at("index").get<int>(), f.at("image").get<std::string>(),
                                f.at("sidecar").get<std::string>()};
        if (!is_plain_file_name(entry.image_file) || !is_plain_file_name(entry.sidecar_file))
          return make_error("bad_manifest", "manifest names a frame file outside the folder");
        folder.frames_.push_back(entry);
      }
      return folder;
    }
  } catch (const nlohmann::json::exception& e) {
    return make_error("bad_manifest", manifest_path + ": " + e.what());
  }
  // Version 3: the frames are the journal's complete lines.
  auto journal_text = read_text_file(dir / kFrameJournalName);
  if (!journal_text)
    return make_error("bad_manifest", (dir / kFrameJournalName).string() +
                                          " is missing: a version 3 folder lists its frames "
                                          "there (" +
                                          journal_text.error().message + ")");
  JournalContents journal = parse_frame_journal(*journal_text);
  for (auto& entry : journal.entries) folder.frames_.push_back(std::move(entry.frame));
  folder.journal_problem_ = std::move(journal.problem);
  if (folder.complete()) {
    const nlohmann::json count = folder.manifest_.value("frame_count", nlohmann::json());
    if (!journal.problem.empty() || !count.is_number_integer() ||
        count.get<int64_t>() != static_cast<int64_t>(folder.frames_.size()))
      return make_error("bad_manifest",
                        manifest_path + " says the capture is complete with frame_count " +
                            count.dump() + ", but " + kFrameJournalName + " lists " +
                            std::to_string(folder.frames_.size()) + " frames" +
                            (journal.problem.empty() ? "" : " (" + journal.problem + ")"));
  }
  return folder;
}

Result<cv::Mat> CaptureFolder::load_stored_image(int index) const {
  if (index < 0 || index >= static_cast<int>(frames_.size()))
    return make_error("out_of_range", "frame " + std::to_string(index) + " is not in 0.." +
                                          std::to_string(static_cast<int>(frames_.size()) - 1));
  const fs::path path = dir_ / frames_[index].image_file;
  if (path.extension() == ".jpg") {
    auto bytes = read_text_file(path);  // any bytes: the name says text, the read is binary
    if (!bytes) return bytes.error();
    auto image = decode_jpeg({reinterpret_cast<const uint8_t*>(bytes->data()), bytes->size()});
    if (!image) return make_error("bad_image", path.string() + ": " + image.error().message);
    return *image;
  }
  cv::Mat image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (image.empty())
    return make_error("bad_image", "cannot decode " + path.string() + " (missing or corrupt)");
  if (image.channels() != 1 && image.channels() != 3)
    return make_error("bad_image", path.string() + " has " + std::to_string(image.channels()) +
                                       " channels; camlab frames have 1 or 3");
  return image;
}

Result<cv::Mat> CaptureFolder::load_image(int index) const {
  auto sidecar = load_sidecar(index);
  if (!sidecar) return sidecar.error();
  if (Status mono =
          check_mono_linear(*sidecar, "frame " + std::to_string(index) + " of " + dir_.string());
      !mono)
    return mono.error();
  auto image = load_stored_image(index);
  if (!image) return image.error();
  if (image->channels() != 1)
    return make_error("bad_image", (dir_ / frames_[index].image_file).string() + " has " +
                                       std::to_string(image->channels()) +
                                       " channels; its sidecar says mono");
  return image;
}

Result<FrameSidecar> CaptureFolder::load_sidecar(int index) const {
  if (index < 0 || index >= static_cast<int>(frames_.size()))
    return make_error("out_of_range", "frame " + std::to_string(index) + " is not in the folder");
  const fs::path path = dir_ / frames_[index].sidecar_file;
  auto text = read_text_file(path);
  if (!text) return text.error();
  nlohmann::json json = nlohmann::json::parse(*text, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) return make_error("bad_sidecar", path.string() + " is not valid JSON");
  return frame_sidecar_from_json(json);
}

double manifest_pixel_pitch_um(const CaptureFolder& folder) {
  const nlohmann::json& source = folder.manifest().value("source", nlohmann::json::object());
  if (source.is_object() && source.contains("camera_spec")) {
    const auto& sensor = source["camera_spec"].value("sensor", nlohmann::json::object());
    if (sensor.is_object() && sensor.contains("pixel_pitch_um") &&
        sensor["pixel_pitch_um"].is_number())
      return sensor["pixel_pitch_um"].get<double>();
  }
  return 0;
}

}  // namespace camlab::image
