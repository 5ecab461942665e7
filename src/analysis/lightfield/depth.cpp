#include "analysis/lightfield/depth.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "analysis/focus/focus_stack.h"
#include "analysis/lightfield/lattice_resampler.h"
#include "analysis/lightfield/refocus.h"
#include "base/format.h"

namespace camlab::analysis::lightfield {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// The most memory the cost volume (one float per pixel and candidate) may take.
constexpr size_t kMaxVolumeBytes = size_t{1} << 30;

}  // namespace

Result<DepthResult> estimate_depth(const LightField& lf, const DepthOptions& options) {
  const image::LightFieldDescription& d = lf.description;
  if (lf.views.size() < 2)
    return make_error("unsupported", "a light field of one view (" + std::to_string(d.views_u) +
                                         " x " + std::to_string(d.views_v) +
                                         ") has no parallax: depth needs at least 2 x 2 views");
  if (options.window_px < 3 || options.window_px > 63 || options.window_px % 2 == 0)
    return make_error("invalid_argument", "window_px = " + std::to_string(options.window_px) +
                                              " must be odd, in [3, 63]");
  if (!(options.max_view_step_px > 0 && options.max_view_step_px <= 16))
    return make_error("invalid_argument",
                      "max_view_step_px = " + format_significant(options.max_view_step_px) +
                          " is out of range (0, 16]");
  const ViewGeometry g = view_geometry(d);
  const double px_per_dioptre = g.f_px * g.cell_pitch_m;  // view step (px) per 1/m
  // The searched range, as view steps d = px_per_dioptre (1/z - q).
  double step_lo = -options.max_view_step_px, step_hi = options.max_view_step_px;
  if (options.near_m > 0 || options.far_m > 0) {
    if (!(options.near_m > 0 && options.far_m > options.near_m))
      return make_error("invalid_argument",
                        "near_m = " + format_significant(options.near_m) +
                            " and far_m = " + format_significant(options.far_m) +
                            ": both are needed, near below far");
    for (double m : {options.near_m, options.far_m})
      if (auto z = refocus_lens_to_sensor_mm(g, m); !z) return z.error();
    step_hi = px_per_dioptre * (1 / options.near_m - g.inverse_focus_per_m);
    step_lo = px_per_dioptre * (1 / options.far_m - g.inverse_focus_per_m);
  }
  DepthResult out;
  const auto depth_at = [&](double step) {
    const double inverse = g.inverse_focus_per_m + step / px_per_dioptre;
    return inverse > 0 ? 1 / inverse : kInf;
  };
  out.near_m = depth_at(step_hi);
  out.far_m = depth_at(step_lo);
  // The outermost view moves by at most 1/4 px between candidates.
  double reach = 0;  // the largest lens offset, in cell sides
  for (const image::LightFieldView& v : d.views)
    reach = std::max(reach, std::hypot(v.centroid_m[0], v.centroid_m[1]) / g.cell_pitch_m);
  out.candidate_step_px = 0.25 / std::max(reach, 0.5);
  out.candidates =
      std::max(3, static_cast<int>(std::ceil((step_hi - step_lo) / out.candidate_step_px)) + 1);
  out.candidate_step_px = (step_hi - step_lo) / (out.candidates - 1);

  const cv::Size view_size = lf.views.front().size();
  const cv::Size size = LatticeResampler::square_grid_size(d.lattice, view_size);
  LatticeResampler resampler(d.lattice, view_size, size);
  double weight_sum = 0, weight_sq = 0;
  for (const image::LightFieldView& v : d.views) {
    weight_sum += v.area_share;
    weight_sq += v.area_share * v.area_share;
  }
  // The noise a pixel's variance across views has when the views agree.
  size_t central = 0;
  for (size_t k = 1; k < d.views.size(); ++k)
    if (std::hypot(d.views[k].centroid_m[0], d.views[k].centroid_m[1]) <
        std::hypot(d.views[central].centroid_m[0], d.views[central].centroid_m[1]))
      central = k;
  const double sigma2 = laplacian_noise_floor(lf.views[central]) / 20;
  out.noise_dn = std::sqrt(sigma2);
  const double noise_variance = sigma2 * (1 - weight_sq / (weight_sum * weight_sum));
  // A floor for noise-free views: the variance of a rounding error (1/12 DN^2) far down.
  const double floor = noise_variance + 1e-6;

  // The cost volume: per candidate, the views' weighted variance per pixel (from their
  // weighted mean and mean square, in double) averaged over the window; kept in float,
  // bounded in size.
  const size_t volume_bytes =
      2 * sizeof(float) * static_cast<size_t>(size.area()) * static_cast<size_t>(out.candidates);
  if (volume_bytes > kMaxVolumeBytes)
    return make_error("out_of_range",
                      format_printf("%d candidates over %dx%d px need %.0f MB of costs; at most "
                                    "%.0f MB: narrow near_m..far_m or raise max_view_step_px "
                                    "less",
                                    out.candidates, size.width, size.height, volume_bytes / 1e6,
                                    kMaxVolumeBytes / 1e6));
  std::vector<cv::Mat> costs(static_cast<size_t>(out.candidates));
  std::vector<cv::Mat> support(static_cast<size_t>(out.candidates));
  cv::Mat sum1(size, CV_64F), sum2(size, CV_64F), variance(size, CV_64F), cost(size, CV_64F);
  cv::Mat shifted;
  for (int c = 0; c < out.candidates; ++c) {
    const double step = step_lo + c * out.candidate_step_px;
    const double slope = step / g.cell_pitch_m;  // px per metre of lens offset
    sum1.setTo(0);
    sum2.setTo(0);
    for (size_t k = 0; k < lf.views.size(); ++k) {
      const image::LightFieldView& v = d.views[k];
      const double w = v.area_share / weight_sum;
      shifted =
          resampler.resample(lf.views[k], 1.0, -slope * v.centroid_m[0], -slope * v.centroid_m[1]);
      for (int y = 0; y < size.height; ++y) {
        const float* in = shifted.ptr<float>(y);
        double* s1 = sum1.ptr<double>(y);
        double* s2 = sum2.ptr<double>(y);
        for (int x = 0; x < size.width; ++x) {
          s1[x] += w * in[x];
          s2[x] += w * static_cast<double>(in[x]) * in[x];
        }
      }
    }
    for (int y = 0; y < size.height; ++y) {
      const double* s1 = sum1.ptr<double>(y);
      const double* s2 = sum2.ptr<double>(y);
      double* row = variance.ptr<double>(y);
      for (int x = 0; x < size.width; ++x) row[x] = std::max(0.0, s2[x] - s1[x] * s1[x]);
    }
    cv::boxFilter(variance, cost, CV_64F, cv::Size(options.window_px, options.window_px),
                  cv::Point(-1, -1), true, cv::BORDER_REFLECT);
    cost.convertTo(costs[static_cast<size_t>(c)], CV_32F);
    cv::boxFilter(variance, cost, CV_64F, cv::Size(3, 3), cv::Point(-1, -1), true,
                  cv::BORDER_REFLECT);
    cost.convertTo(support[static_cast<size_t>(c)], CV_32F);
  }

  // The texture the central view has over each window (its variance there): what a
  // candidate that aligns the views brings the cost far below.
  cv::Mat central_view = resampler.resample(lf.views[central], 1.0, 0, 0), mean_w, square_w;
  cv::boxFilter(central_view, mean_w, CV_64F, cv::Size(options.window_px, options.window_px),
                cv::Point(-1, -1), true, cv::BORDER_REFLECT);
  cv::sqrBoxFilter(central_view, square_w, CV_64F, cv::Size(options.window_px, options.window_px),
                   cv::Point(-1, -1), true, cv::BORDER_REFLECT);
  const cv::Mat texture = square_w - mean_w.mul(mean_w);

  // Per pixel: the least cost, a parabola through it and its neighbours, and how much
  // higher the pixel's own variance (over 3 x 3) is wherever the outermost view is half a
  // pixel or more out of place: a pixel whose own texture does not pin the depth (a
  // window that an edge reaches only at its rim, or only at large shifts) or that has a
  // rival least is no measurement.
  const int apart = std::max(2, static_cast<int>(std::ceil(0.5 / (out.candidate_step_px * reach))));
  out.depth_m = cv::Mat(size, CV_32F, cv::Scalar(0));
  out.view_step_px = cv::Mat(size, CV_32F, cv::Scalar(0));
  out.confidence = cv::Mat(size, CV_32F, cv::Scalar(0));
  out.status = cv::Mat(size, CV_8U, cv::Scalar(kDepthOk));
  long ok = 0, flat = 0, outside = 0;
  std::vector<float> curve(static_cast<size_t>(out.candidates));
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      int i = 0;
      for (int c = 0; c < out.candidates; ++c) {
        curve[static_cast<size_t>(c)] = costs[static_cast<size_t>(c)].at<float>(y, x);
        if (curve[static_cast<size_t>(c)] < curve[static_cast<size_t>(i)]) i = c;
      }
      const double least = curve[static_cast<size_t>(i)];
      const double own = support[static_cast<size_t>(i)].at<float>(y, x);
      double off = std::numeric_limits<double>::infinity();
      for (int c = 0; c < out.candidates; ++c)
        if (std::abs(c - i) >= apart)
          off = std::min(off, static_cast<double>(support[static_cast<size_t>(c)].at<float>(y, x)));
      const double confidence = std::isfinite(off) ? (off - own) / (own + floor) : 0.0;
      out.confidence.at<float>(y, x) = static_cast<float>(confidence);
      // No texture in the window: nothing to match. Texture that no candidate aligns (the
      // least still half the texture's variance), or a least at an end of the range: the
      // point lies beyond the range. Otherwise a least that the pixel's own texture does
      // not single out is undecided.
      const double window_texture = texture.at<double>(y, x);
      uint8_t status = kDepthOk;
      if (!(window_texture >= options.min_confidence * floor))
        status = kDepthFlat;
      else if (i == 0 || i == out.candidates - 1 || least > 0.5 * window_texture)
        status = kDepthOutOfRange;
      else if (!(confidence >= options.min_confidence))
        status = kDepthFlat;
      double depth = 0;
      if (status == kDepthOk) {
        const double m = curve[static_cast<size_t>(i - 1)], p = curve[static_cast<size_t>(i + 1)];
        const double curvature = m - 2 * least + p;
        const double delta = curvature > 0 ? std::clamp(0.5 * (m - p) / curvature, -0.5, 0.5) : 0;
        const double step = step_lo + (i + delta) * out.candidate_step_px;
        depth = depth_at(step);
        if (std::isfinite(depth)) {
          out.view_step_px.at<float>(y, x) = static_cast<float>(step);
          out.depth_m.at<float>(y, x) = static_cast<float>(depth);
        } else {
          status = kDepthOutOfRange;  // beyond infinity: the searched range's far end
        }
      }
      out.status.at<uint8_t>(y, x) = status;
      ok += status == kDepthOk;
      flat += status == kDepthFlat;
      outside += status == kDepthOutOfRange;
    }
  const double pixels = static_cast<double>(size.area());
  out.ok_share = ok / pixels;
  out.flat_share = flat / pixels;
  out.out_of_range_share = outside / pixels;
  if (out.flat_share > 0)
    out.warnings.push_back(format_printf(
        "%.3g%% of the pixels have no texture that pins their depth (none, or only an edge at "
        "the window's rim): no depth there (status flat, depth 0)",
        100 * out.flat_share));
  if (out.out_of_range_share > 0)
    out.warnings.push_back(format_printf(
        "%.2g%% of the pixels match best at an end of the searched range (%.4g to %.4g m): "
        "they lie beyond it (status out_of_range, depth 0); widen it with near_m and far_m",
        100 * out.out_of_range_share, out.near_m, out.far_m));
  return out;
}

}  // namespace camlab::analysis::lightfield
