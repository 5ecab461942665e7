// camlab's error vocabulary: a closed set of codes, each with the HTTP status camlabd
// answers with and what it means. Library functions return them in an Error (result.h);
// the command line prints them (`error [code]: message`, or {"error": {"code", "message"}}
// with --json) and camlabd serves them ({"error": {"code", "message"}} with the status
// below). docs/errors.md lists them for users; tests/unit/base checks that every code has
// a unique name, a status and a meaning.
//
// A code names what went wrong in a way a program can act on; the message says what
// exactly, with the value and what is allowed. Add a code only when no code below says
// it: a near-synonym splits what clients have to handle.
//
// Reentrant. Header-only, so that src/optics (which links nothing) can use it.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>

namespace camlab {

enum class ErrorCode : uint8_t {
  // The request or the arguments.
  kInvalidRequest,
  kBadJson,
  kInvalidArgument,
  kOutOfRange,
  kUnsupported,
  kUnknownControl,
  kNoRealImage,
  // camlabd's HTTP layer.
  kUnauthorized,
  kNoRoute,
  kMethodNotAllowed,
  kPayloadTooLarge,
  kHeadersTooLarge,
  kTooManyJobs,
  // Things that exist or not, and their state.
  kNotFound,
  kExists,
  kConflict,
  kNotCancellable,
  kBusy,
  kCancelled,
  kInterrupted,
  kShuttingDown,
  kTooManyConnections,
  kDatabaseUnavailable,
  kHostUnavailable,
  // Cameras.
  kNoDevice,
  kDeviceLost,
  kPermission,
  kNotStreaming,
  kTimeout,
  kUnstableStream,
  kInconclusive,
  // Files.
  kIoError,
  kNotACapture,
  kBadManifest,
  kBadSidecar,
  kUnsupportedVersion,
  kBadImage,
  kBadFrame,
  kBadVnl,
  kMissingSettings,
  kNoFrames,
  kImagerMismatch,
  kNotLinear,
  // Measurements and fits: the data do not support an answer.
  kTooFewSamples,
  kTooFewViews,
  kNoSignal,
  kNoContrast,
  kWindowOutsideImage,
  kWindowTooSmall,
  kNotConverged,
  kNoEdgeGeometry,
  kNoVShape,
  kEmptyPlot,
  kPlotterFailed,
  // Calibration.
  kBoardNotFound,
  kDuplicateView,
  kNoBoard,
  kSolveFailed,
  kSingular,
  kNoCovariance,
  kNoCandidate,
  kBadLensmodel,
  kProjectionFailed,
  // A bug.
  kInternal,
};

struct ErrorCodeInfo {
  ErrorCode code;
  std::string_view name;     // stable, snake_case: what clients match on
  int http_status;           // what camlabd answers with
  std::string_view meaning;  // for docs/errors.md and `camlab --help`
};

// Every code, in the enum's order.
inline constexpr std::array kErrorCodes = {
    ErrorCodeInfo{ErrorCode::kInvalidRequest, "invalid_request", 400,
                  "The request is malformed: not a JSON object, a field of the wrong type, an "
                  "unknown field or kind, a malformed path parameter or HTTP message."},
    ErrorCodeInfo{ErrorCode::kBadJson, "bad_json", 400,
                  "Text that must be JSON (a request body, a camera or scene spec) is not valid "
                  "JSON."},
    ErrorCodeInfo{ErrorCode::kInvalidArgument, "invalid_argument", 422,
                  "A value has the wrong form or is not allowed: not a number, not positive, an "
                  "unknown name, a missing or malformed field."},
    ErrorCodeInfo{ErrorCode::kOutOfRange, "out_of_range", 422,
                  "A number is outside its allowed range; the message gives the range and unit."},
    ErrorCodeInfo{ErrorCode::kUnsupported, "unsupported", 422,
                  "The camera, file or model cannot do what was asked (a pixel format, a "
                  "read-only control, a lens model another format cannot represent)."},
    ErrorCodeInfo{ErrorCode::kUnknownControl, "unknown_control", 422,
                  "The camera has no control of that name; the message lists those it has."},
    ErrorCodeInfo{ErrorCode::kNoRealImage, "no_real_image", 422,
                  "The object is at or inside the focal length: the thin lens forms no real "
                  "image."},
    ErrorCodeInfo{ErrorCode::kUnauthorized, "unauthorized", 401,
                  "The request has no valid bearer token (camlab-data/token)."},
    ErrorCodeInfo{ErrorCode::kNoRoute, "no_route", 404, "No endpoint has this path."},
    ErrorCodeInfo{ErrorCode::kMethodNotAllowed, "method_not_allowed", 405,
                  "The endpoint does not take this method; the Allow header lists those it "
                  "takes."},
    ErrorCodeInfo{ErrorCode::kPayloadTooLarge, "payload_too_large", 413,
                  "The request body is larger than camlabd accepts."},
    ErrorCodeInfo{ErrorCode::kHeadersTooLarge, "headers_too_large", 431,
                  "The request's headers are larger than camlabd accepts."},
    ErrorCodeInfo{ErrorCode::kTooManyJobs, "too_many_jobs", 429,
                  "The queue is full; retry when a job has finished."},
    ErrorCodeInfo{ErrorCode::kNotFound, "not_found", 404,
                  "A named job, camera, frame or file does not exist."},
    ErrorCodeInfo{ErrorCode::kExists, "exists", 409,
                  "The output already exists and would be overwritten."},
    ErrorCodeInfo{ErrorCode::kConflict, "conflict", 409,
                  "The job or resource is in a state that forbids this (finished, or still "
                  "running)."},
    ErrorCodeInfo{ErrorCode::kNotCancellable, "not_cancellable", 409,
                  "The job cannot be cancelled now."},
    ErrorCodeInfo{ErrorCode::kBusy, "busy", 409,
                  "The camera is in use: streaming, running a job, or opened by another "
                  "process."},
    ErrorCodeInfo{ErrorCode::kCancelled, "cancelled", 409,
                  "The job was cancelled by request; the frames taken are kept."},
    ErrorCodeInfo{ErrorCode::kInterrupted, "interrupted", 503,
                  "The job was stopped because camlabd stopped (in a fleet: its host lost its "
                  "lease); the frames taken are kept."},
    ErrorCodeInfo{ErrorCode::kShuttingDown, "shutting_down", 503,
                  "camlabd is stopping and takes no new work."},
    ErrorCodeInfo{ErrorCode::kTooManyConnections, "too_many_connections", 503,
                  "Every connection camlabd accepts is busy answering a request; retry shortly "
                  "(Retry-After)."},
    ErrorCodeInfo{ErrorCode::kDatabaseUnavailable, "database_unavailable", 503,
                  "The job store's database (PostgreSQL, for a fleet) cannot be reached, or "
                  "this host has lost its lease; retry shortly."},
    ErrorCodeInfo{ErrorCode::kHostUnavailable, "host_unavailable", 503,
                  "The fleet host that owns the camera, or keeps the job's frames, is not "
                  "serving (its lease expired, it left, or it is starting and does not "
                  "listen yet); its frames stay on its disk."},
    ErrorCodeInfo{ErrorCode::kNoDevice, "no_device", 503,
                  "The camera is not there: never found, or unplugged."},
    ErrorCodeInfo{ErrorCode::kDeviceLost, "device_lost", 503,
                  "The camera vanished (unplugged) while the job ran or waited for it; the "
                  "frames taken are kept and the job's error says why."},
    ErrorCodeInfo{ErrorCode::kPermission, "permission", 503,
                  "camlab may not open the device (add its user to the video group)."},
    ErrorCodeInfo{ErrorCode::kNotStreaming, "not_streaming", 409,
                  "The camera is not streaming; start it first."},
    ErrorCodeInfo{ErrorCode::kTimeout, "timeout", 504, "No frame arrived within the timeout."},
    ErrorCodeInfo{ErrorCode::kUnstableStream, "unstable_stream", 503,
                  "Too many frames came unusable (flagged, spoiled) or could not be kept (a full "
                  "frame writer) for a frame-accurate capture; the message says whose."},
    ErrorCodeInfo{ErrorCode::kInconclusive, "inconclusive", 422,
                  "A probe could not decide (e.g. the control-latency probe saw no change)."},
    ErrorCodeInfo{ErrorCode::kIoError, "io_error", 500,
                  "Reading or writing a file or a device failed; the message gives the "
                  "system's reason."},
    ErrorCodeInfo{ErrorCode::kNotACapture, "not_a_capture", 422,
                  "The folder is not a capture folder (it has no manifest.json)."},
    ErrorCodeInfo{ErrorCode::kBadManifest, "bad_manifest", 422,
                  "A capture folder's manifest.json is malformed, or its frames journal is "
                  "missing or lists fewer frames than a complete manifest says."},
    ErrorCodeInfo{ErrorCode::kBadSidecar, "bad_sidecar", 422,
                  "A frame's JSON sidecar is malformed."},
    ErrorCodeInfo{ErrorCode::kUnsupportedVersion, "unsupported_version", 422,
                  "The file is of a format version this camlab cannot read."},
    ErrorCodeInfo{ErrorCode::kBadImage, "bad_image", 422,
                  "An image cannot be decoded or has the wrong shape (channels, bit depth, "
                  "size)."},
    ErrorCodeInfo{ErrorCode::kBadFrame, "bad_frame", 502,
                  "A frame from the camera is shorter than its format says, or a JPEG that does "
                  "not decode."},
    ErrorCodeInfo{ErrorCode::kBadVnl, "bad_vnl", 422,
                  "A corners.vnl file is malformed; the message gives the line."},
    ErrorCodeInfo{ErrorCode::kMissingSettings, "missing_settings", 422,
                  "Frames lack a setting the analysis needs (exposure, focus, f-number)."},
    ErrorCodeInfo{ErrorCode::kNoFrames, "no_frames", 422, "The capture or job holds no frames."},
    ErrorCodeInfo{ErrorCode::kImagerMismatch, "imager_mismatch", 422,
                  "Images of one calibration have different sizes."},
    ErrorCodeInfo{ErrorCode::kNotLinear, "not_linear", 422,
                  "The frames are JPEG (gamma-encoded, lossy): their DN are not proportional "
                  "to light, which the measurement needs; capture a raw format."},
    ErrorCodeInfo{ErrorCode::kTooFewSamples, "too_few_samples", 422,
                  "Too few usable points, pixels or frames for the fit."},
    ErrorCodeInfo{ErrorCode::kTooFewViews, "too_few_views", 422,
                  "Too few board views for the calibration asked."},
    ErrorCodeInfo{ErrorCode::kNoSignal, "no_signal", 422,
                  "The frames hold no signal above the black level, or none that grows with "
                  "exposure."},
    ErrorCodeInfo{ErrorCode::kNoContrast, "no_contrast", 422,
                  "The edge's two sides differ by less than the noise."},
    ErrorCodeInfo{ErrorCode::kWindowOutsideImage, "window_outside_image", 422,
                  "The fit window around the edge leaves the image."},
    ErrorCodeInfo{ErrorCode::kWindowTooSmall, "window_too_small", 422,
                  "The blur does not fit inside the fit window; a wider window is needed."},
    ErrorCodeInfo{ErrorCode::kNotConverged, "not_converged", 422,
                  "An iterative fit did not converge to a valid solution."},
    ErrorCodeInfo{ErrorCode::kNoEdgeGeometry, "no_edge_geometry", 422,
                  "The capture says nowhere where its edges are (no scene truth, no edges "
                  "given)."},
    ErrorCodeInfo{ErrorCode::kNoVShape, "no_v_shape", 422,
                  "Blur against focus does not trace a V, so there is no best focus to give."},
    ErrorCodeInfo{ErrorCode::kEmptyPlot, "empty_plot", 422, "Nothing to plot."},
    ErrorCodeInfo{ErrorCode::kPlotterFailed, "plotter_failed", 500,
                  "gnuplot, which draws the plots, is not installed or refused the plot (the "
                  "measurement itself is unaffected)."},
    ErrorCodeInfo{ErrorCode::kBoardNotFound, "board_not_found", 422,
                  "The image shows no calibration board of the given size (no complete "
                  "chessboard, no corner of a ChArUco board)."},
    ErrorCodeInfo{ErrorCode::kDuplicateView, "duplicate_view", 422,
                  "A guided calibration's new view shows the board where an earlier view "
                  "showed it: it adds no geometry, so it is not taken."},
    ErrorCodeInfo{ErrorCode::kNoBoard, "no_board", 422,
                  "No image of the calibration set shows the board: check its size."},
    ErrorCodeInfo{ErrorCode::kSolveFailed, "solve_failed", 422,
                  "The calibration solve failed: no board pose to start from, or no finite "
                  "solution."},
    ErrorCodeInfo{ErrorCode::kSingular, "singular", 422,
                  "The data do not determine every parameter of the model."},
    ErrorCodeInfo{ErrorCode::kNoCovariance, "no_covariance", 422,
                  "The solve has no covariance to give an uncertainty from."},
    ErrorCodeInfo{ErrorCode::kNoCandidate, "no_candidate", 422,
                  "No pose of the board keeps it visible: it is too large for the imager at "
                  "that distance."},
    ErrorCodeInfo{ErrorCode::kBadLensmodel, "bad_lensmodel", 422,
                  "The lens model is unknown or misconfigured, or its parameters do not match "
                  "it."},
    ErrorCodeInfo{ErrorCode::kProjectionFailed, "projection_failed", 422,
                  "The lens model cannot project or unproject the point."},
    ErrorCodeInfo{ErrorCode::kInternal, "internal", 500,
                  "camlab reached a state it should not: a bug. Please report it with the "
                  "message."},
};

constexpr bool error_codes_in_enum_order() {
  for (size_t i = 0; i < kErrorCodes.size(); ++i)
    if (static_cast<size_t>(kErrorCodes[i].code) != i) return false;
  return kErrorCodes.size() == static_cast<size_t>(ErrorCode::kInternal) + 1;
}
static_assert(error_codes_in_enum_order(), "kErrorCodes must list every ErrorCode in order");

constexpr const ErrorCodeInfo& info_of(ErrorCode code) {
  return kErrorCodes[static_cast<size_t>(code)];
}
constexpr std::string_view name_of(ErrorCode code) { return info_of(code).name; }

// The code of a name, or nothing (for names read from outside: JSON, a test's table).
constexpr std::optional<ErrorCode> find_error_code(std::string_view name) {
  for (const ErrorCodeInfo& info : kErrorCodes)
    if (info.name == name) return info.code;
  return std::nullopt;
}

// A code written by its name in the source, checked when compiling:
// make_error("out_of_range", ...) compiles, make_error("out_of_rnage", ...) does not.
struct ErrorCodeName {
  consteval ErrorCodeName(const char* name) : code(lookup(name)) {}  // NOLINT: implicit
  ErrorCode code;

 private:
  static consteval ErrorCode lookup(std::string_view name) {
    if (auto code = find_error_code(name)) return *code;
    throw "not an error code of base/error_code.h";  // a compile error, never thrown
  }
};

// A code compares equal to its name, and prints as it, so that tests and messages can
// speak of codes by name.
inline bool operator==(ErrorCode code, std::string_view name) { return name_of(code) == name; }
inline std::ostream& operator<<(std::ostream& out, ErrorCode code) { return out << name_of(code); }

// JSON (nlohmann, found by argument-dependent lookup): a code is its name, never a number.
template <class Json>
void to_json(Json& json, ErrorCode code) {
  json = std::string(name_of(code));
}

}  // namespace camlab
