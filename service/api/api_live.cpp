// What the dashboard looks at: a camera's live view (a multipart JPEG stream, or one JPEG),
// the histogram of its raw DN, and thumbnails of captured frames. Rendering and encoding
// run on the live hub's thread (service/live/live_hub.h), never on an HTTP thread or a
// camera's worker; the worker only copies frames while somebody watches.
#include <cmath>
#include <memory>

#include "analysis/dn_histogram.h"
#include "capture/frame_convert.h"
#include "image/capture_folder.h"
#include "image/jpeg_codec.h"
#include "service/api/api_lookup.h"
#include "service/api/service_context.h"
#include "service/jobs/camera_set.h"
#include "service/live/display_frame.h"
#include "service/live/live_hub.h"

namespace camlab::service {

namespace {

constexpr char kBoundary[] = "camlabframe";
constexpr std::chrono::milliseconds kFrameWait{3000};
constexpr int kDefaultThumbnailWidthPx = 160;
// Up to the widest display: the viewer shows a frame at 1:1 and beyond from it.
constexpr int kMaxThumbnailWidthPx = kMaxDisplayWidthPx;

Result<DisplayOptions> display_options(const QueryParams& query, int default_width_px,
                                       int max_width_px) {
  DisplayOptions options;
  double width = 0, threshold = 0, quality = 0;
  bool clipping = false, peaking = false;
  CAMLAB_ASSIGN(width,
                query_number(query, "width", kMinDisplayWidthPx, max_width_px, default_width_px));
  CAMLAB_ASSIGN(clipping, query_flag(query, "clipping", false));
  CAMLAB_ASSIGN(peaking, query_flag(query, "peaking", false));
  CAMLAB_ASSIGN(threshold,
                query_number(query, "peaking_threshold", 1, 1000, options.peaking_threshold));
  CAMLAB_ASSIGN(quality, query_number(query, "quality", 10, 100, options.jpeg_quality));
  options.max_width_px = static_cast<int>(width);
  options.clipping = clipping;
  options.focus_peaking = peaking;
  options.peaking_threshold = static_cast<int>(threshold);
  options.jpeg_quality = static_cast<int>(quality);
  return options;
}

ApiResponse jpeg_response(std::string bytes) {
  ApiResponse response;
  response.content_type = "image/jpeg";
  response.body = std::move(bytes);
  return response;
}

// One part of multipart/x-mixed-replace: the JPEG with what a client needs to know of it.
std::string multipart_part(const EncodedFrame& frame) {
  std::string part =
      std::string("--") + kBoundary +
      "\r\nContent-Type: image/jpeg\r\nContent-Length: " + std::to_string(frame.jpeg->size()) +
      "\r\nX-Frame-Sequence: " + std::to_string(frame.sequence) +
      "\r\nX-Frame-Timestamp-Ns: " + std::to_string(frame.timestamp_ns) +
      "\r\nX-Frame-Width: " + std::to_string(frame.width_px) +
      "\r\nX-Frame-Height: " + std::to_string(frame.height_px) +
      "\r\nX-Frame-Repeated: " + (frame.repeated ? "1" : "0") + "\r\n\r\n";
  part.append(reinterpret_cast<const char*>(frame.jpeg->data()), frame.jpeg->size());
  part += "\r\n";
  return part;
}

class MjpegStream : public BodyStream {
 public:
  explicit MjpegStream(std::shared_ptr<LiveHub::Viewer> viewer) : viewer_(std::move(viewer)) {}
  ~MjpegStream() override { viewer_->close(); }
  void next(Deliver deliver) override {
    viewer_->next([deliver = std::move(deliver)](Result<EncodedFrame> frame) {
      // An error (the camera is gone, camlabd stops) ends the stream; the client
      // reconnects and is told why by the answer to its new request.
      deliver(frame ? std::optional<std::string>(multipart_part(*frame)) : std::nullopt);
    });
  }
  void close() override { viewer_->close(); }

 private:
  std::shared_ptr<LiveHub::Viewer> viewer_;
};

// The camera's worker if it can show frames now, else nullptr after the reply.
std::shared_ptr<CameraWorker> live_camera(const ServiceContext& context, const PathParams& params,
                                          const Reply& reply) {
  if (!context.live) {
    reply(error_response("unsupported", "this camlabd serves no live view"));
    return nullptr;
  }
  auto worker = find_camera(context, params.at("id"), reply);
  if (!worker) return nullptr;
  const CameraSnapshot snapshot = worker->snapshot();
  if (snapshot.gone || worker->live_feed()->closed()) {
    reply(error_response(
        "no_device", "camera " + worker->id() + " is gone (" + snapshot.unavailable_reason + ")"));
    return nullptr;
  }
  return worker;
}

void get_live_stream(const ServiceContext& context, const ApiRequest& request,
                     const PathParams& params, Reply reply) {
  const QueryParams query = parse_query(request.query);
  auto display = display_options(query, 640, kMaxDisplayWidthPx);
  if (!display) return reply(error_response(display.error()));
  auto fps = query_number(query, "fps", kMinLiveFps, kMaxLiveFps, 10);
  if (!fps) return reply(error_response(fps.error()));
  auto worker = live_camera(context, params, reply);
  if (!worker) return;
  auto viewer = context.live->open_viewer(worker->live_feed(), {*fps, *display});
  if (!viewer) return reply(error_response(viewer.error()));
  ApiResponse response;
  response.content_type = std::string("multipart/x-mixed-replace; boundary=") + kBoundary;
  response.stream = std::make_shared<MjpegStream>(std::move(*viewer));
  reply(std::move(response));
}

void get_live_frame(const ServiceContext& context, const ApiRequest& request,
                    const PathParams& params, Reply reply) {
  auto display = display_options(parse_query(request.query), 640, kMaxDisplayWidthPx);
  if (!display) return reply(error_response(display.error()));
  auto worker = live_camera(context, params, reply);
  if (!worker) return;
  context.live->next_frame(
      worker->live_feed(), kFrameWait,
      [reply, options = *display](Result<std::shared_ptr<const LiveFrame>> frame) {
        if (!frame) return reply(error_response(frame.error()));
        auto converted = convert_live_frame(**frame);
        if (!converted) return reply(error_response(converted.error()));
        auto jpeg = display_jpeg(*converted, options);
        if (!jpeg) return reply(error_response(jpeg.error()));
        ApiResponse response = jpeg_response(std::string(jpeg->begin(), jpeg->end()));
        response.headers.emplace_back("X-Frame-Sequence", std::to_string((*frame)->meta.sequence));
        response.headers.emplace_back("X-Frame-Timestamp-Ns",
                                      std::to_string((*frame)->meta.timestamp_ns));
        reply(std::move(response));
      });
}

nlohmann::json histogram_json(const analysis::DnHistogram& h, const LiveFrame& frame,
                              const capture::ConvertedFrame& converted) {
  nlohmann::json channels = nlohmann::json::array();
  for (const auto& c : h.channels) {
    const double n = c.samples ? static_cast<double>(c.samples) : 1.0;
    channels.push_back(
        {{"channel", c.channel},
         {"counts", c.counts},
         {"samples", c.samples},
         {"mean_dn", c.mean_dn},
         {"min_dn", c.min_dn},
         {"max_dn", c.max_dn},
         {"clipped_high", c.at_or_above_white},
         {"clipped_high_fraction", static_cast<double>(c.at_or_above_white) / n},
         {"at_or_below_black", c.at_or_below_black},
         {"at_or_below_black_fraction", static_cast<double>(c.at_or_below_black) / n}});
  }
  return {{"sequence", frame.meta.sequence},
          {"timestamp_ns", frame.meta.timestamp_ns},
          {"format",
           {{"fourcc", frame.format.fourcc},
            {"width", frame.format.width},
            {"height", frame.format.height}}},
          {"pixel_format", converted.pixel_format},
          {"linear", converted.linear},
          {"bit_depth", h.bit_depth},
          {"black_level_dn", h.black_level_dn},
          {"white_level_dn", h.white_level_dn},
          {"bin_width_dn", h.bin_width_dn},
          {"bins", h.bins},
          {"channels", channels}};
}

void get_histogram(const ServiceContext& context, const ApiRequest& request,
                   const PathParams& params, Reply reply) {
  auto bins = query_number(parse_query(request.query), "bins", 1, analysis::kMaxHistogramBins, 256);
  if (!bins) return reply(error_response(bins.error()));
  auto worker = live_camera(context, params, reply);
  if (!worker) return;
  context.live->next_frame(
      worker->live_feed(), kFrameWait,
      [reply, bins = static_cast<int>(*bins)](Result<std::shared_ptr<const LiveFrame>> frame) {
        if (!frame) return reply(error_response(frame.error()));
        auto converted = convert_live_frame(**frame);
        if (!converted) return reply(error_response(converted.error()));
        analysis::DnHistogramInput input;
        if (!converted->jpeg.empty()) {
          // MJPEG: the decoded display values (8 bits, not linear), said so in "linear".
          auto decoded = image::decode_jpeg(converted->jpeg);
          if (!decoded) return reply(error_response(decoded.error()));
          input.image = *decoded;
          input.layout =
              input.image.channels() == 3 ? image::FrameLayout::kRgb : image::FrameLayout::kMono;
        } else {
          input.image = converted->image;
          input.layout = converted->layout;
          input.cfa_pattern = converted->cfa_pattern;
        }
        input.bit_depth = converted->bit_depth;
        input.black_level_dn = converted->black_level_dn;
        input.white_level_dn = converted->white_level_dn;
        auto histogram = analysis::dn_histogram(input, bins);
        if (!histogram) return reply(error_response(histogram.error()));
        reply(json_response(200, histogram_json(*histogram, **frame, *converted)));
      });
}

// A stored frame, shown small: read and rendered on the live hub's thread.
void get_thumbnail(const ServiceContext& context, const ApiRequest& request,
                   const PathParams& params, Reply reply) {
  if (!context.live)
    return reply(error_response("unsupported", "this camlabd renders no thumbnails"));
  auto display =
      display_options(parse_query(request.query), kDefaultThumbnailWidthPx, kMaxThumbnailWidthPx);
  if (!display) return reply(error_response(display.error()));
  auto ref = find_job_frame(context, params, reply);
  if (!ref) return;
  const bool posted = context.live->post([ref = *ref, options = *display, reply] {
    auto stored = read_stored_frame(ref);
    if (!stored) return reply(error_response(stored.error()));
    const image::FrameSidecar* sidecar = &stored->sidecar;
    capture::ConvertedFrame frame;
    frame.image = stored->image;
    frame.layout = sidecar->layout;
    frame.cfa_pattern = sidecar->cfa_pattern;
    frame.bit_depth = sidecar->bit_depth;
    frame.black_level_dn = sidecar->black_level_dn;
    frame.white_level_dn =
        sidecar->white_level_dn > 0 ? sidecar->white_level_dn : (1 << sidecar->bit_depth) - 1;
    frame.linear = sidecar->linear;
    auto jpeg = display_jpeg(frame, options);
    if (!jpeg) return reply(error_response(jpeg.error()));
    reply(jpeg_response(std::string(jpeg->begin(), jpeg->end())));
  });
  if (!posted) reply(error_response("shutting_down", "camlabd is shutting down"));
}

}  // namespace

void add_live_routes(Router& router, const ServiceContext& context) {
  router.add({"GET", "/v1/cameras/{id}/live",
              "Live view: multipart/x-mixed-replace JPEG frames, at most ?fps= (0.2-30, 10) a "
              "second, ?width= px (640), ?peaking=1, ?clipping=1; runs beside captures",
              [context](const ApiRequest& request, const PathParams& params, Reply reply) {
                get_live_stream(context, request, params, std::move(reply));
              }});
  router.add({"GET", "/v1/cameras/{id}/live/frame",
              "The camera's next frame as one JPEG (?width=, ?peaking=1, ?clipping=1)",
              [context](const ApiRequest& request, const PathParams& params, Reply reply) {
                get_live_frame(context, request, params, std::move(reply));
              }});
  router.add({"GET", "/v1/cameras/{id}/histogram",
              "Histogram of the next frame's raw DN per channel (R, Gr, Gb, B for Bayer), with "
              "black and white levels and clipped counts (?bins=, 256)",
              [context](const ApiRequest& request, const PathParams& params, Reply reply) {
                get_histogram(context, request, params, std::move(reply));
              }});
  router.add({"GET", "/v1/jobs/{id}/frames/{n}/thumbnail",
              "Frame n shown small as JPEG (?width= px, 160; up to 4096, never above the frame; "
              "?clipping=1)",
              [context](const ApiRequest& request, const PathParams& params, Reply reply) {
                get_thumbnail(context, request, params, std::move(reply));
              }});
}

}  // namespace camlab::service
