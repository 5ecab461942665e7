// Photon transfer, linearity and HDR merge.
#include "analysis/exposure/exposure.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/core.hpp>

namespace camlab::analysis {

Result<PairStats> pair_stats(const cv::Mat& a, const cv::Mat& b, double black_level_dn,
                             const cv::Rect& roi) {
  if (a.empty() || a.channels() != 1 || a.size() != b.size() || a.type() != b.type())
    return make_error("invalid_argument",
                      "a frame pair must be two non-empty single-channel "
                      "frames of the same size and type");
  const cv::Rect r = roi.area() > 0 ? roi : cv::Rect(0, 0, a.cols, a.rows);
  if ((r & cv::Rect(0, 0, a.cols, a.rows)) != r || r.area() < 2)
    return make_error("invalid_argument", "the region lies outside the frame");
  cv::Mat fa, fb;
  a(r).convertTo(fa, CV_64F);
  b(r).convertTo(fb, CV_64F);
  PairStats s;
  s.pixels = r.area();
  s.mean_dn = 0.5 * (cv::mean(fa)[0] + cv::mean(fb)[0]) - black_level_dn;
  cv::Scalar m, sd;
  cv::meanStdDev(fa - fb, m, sd);
  // meanStdDev is the population deviation; the unbiased variance over n pixels.
  const double n = static_cast<double>(s.pixels);
  s.variance_dn2 = 0.5 * sd[0] * sd[0] * n / (n - 1);
  return s;
}

Result<PhotonTransfer> fit_photon_transfer(std::vector<PairStats> points,
                                           std::optional<double> clip_mean_dn) {
  if (points.empty()) return make_error("too_few_samples", "no frame pairs");
  std::sort(points.begin(), points.end(),
            [](const PairStats& x, const PairStats& y) { return x.mean_dn < y.mean_dn; });
  PhotonTransfer pt;
  // The variance peak among the pairs not partly clipped (a partly clipped pair's variance
  // is that of its unclipped pixels only).
  const auto peak =
      std::max_element(points.begin(), points.end(), [](const PairStats& x, const PairStats& y) {
        return (x.saturated ? -1.0 : x.variance_dn2) < (y.saturated ? -1.0 : y.variance_dn2);
      });
  pt.saturation_mean_dn = peak->mean_dn;
  // A brighter pair whose variance has collapsed (under half the peak's) has most of its
  // pixels clipped: its mean is where the sensor clips, which a coarse sweep's variance
  // peak (doubling exposures: up to a factor 2 lower) does not reach.
  for (auto p = peak + 1; p != points.end(); ++p)
    if (p->variance_dn2 < 0.5 * peak->variance_dn2) {
      pt.saturation_mean_dn = p->mean_dn;
      pt.saturation_reached = true;
      break;
    }
  // A pair with part of its pixels clipped reached it too.
  for (const PairStats& p : points) pt.saturation_reached |= p.saturated;
  if (clip_mean_dn && *clip_mean_dn > pt.saturation_mean_dn) {
    pt.saturation_mean_dn = *clip_mean_dn;
    pt.saturation_reached = true;
  }
  if (!(pt.saturation_mean_dn > 0))
    return make_error("no_signal", "no frame pair has a signal above the black level");
  // If the brightest pair is the variance peak, the sweep may not reach saturation: the
  // capacity is then a lower bound (as EMVA 1288 asks for a sweep into saturation).
  double s0 = 0, s1 = 0, s2 = 0, r0 = 0, r1 = 0;
  for (PairStats& p : points) {
    // The 70% cap is of a saturation the data reached; below it (a sweep that stops short)
    // every pair is below the sensor's saturation.
    p.used = !p.saturated && (!pt.saturation_reached || p.mean_dn <= 0.7 * pt.saturation_mean_dn) &&
             p.variance_dn2 > 0 && p.pixels > 1;
    if (!p.used) continue;
    const double w = (p.pixels - 1) / (2.0 * p.variance_dn2 * p.variance_dn2);
    s0 += w;
    s1 += w * p.mean_dn;
    s2 += w * p.mean_dn * p.mean_dn;
    r0 += w * p.variance_dn2;
    r1 += w * p.mean_dn * p.variance_dn2;
    ++pt.used_count;
  }
  if (pt.used_count < 3)
    return make_error("too_few_samples",
                      "photon transfer needs at least 3 frame pairs below "
                      "70% of saturation; got " +
                          std::to_string(pt.used_count));
  const double det = s0 * s2 - s1 * s1;
  if (!(det > 0)) return make_error("too_few_samples", "the pairs' means do not differ");
  const double k = (s0 * r1 - s1 * r0) / det, intercept = (s2 * r0 - s1 * r1) / det;
  if (!(k > 0)) return make_error("no_signal", "the variance does not grow with the signal");
  pt.system_gain_dn_per_e = k;
  pt.system_gain_sigma = std::sqrt(s0 / det);
  pt.dark_variance_dn2 = std::max(0.0, intercept);
  // The intercept of a line fitted over the whole range is poorly determined; a pair at
  // low signal pins it: its variance minus its shot-noise part K mu.
  if (points.front().mean_dn < 0.05 * pt.saturation_mean_dn)
    pt.dark_variance_dn2 =
        std::max(0.0, points.front().variance_dn2 - k * std::max(0.0, points.front().mean_dn));
  const double quant = 1.0 / 12.0;
  const double dark_e = std::sqrt(std::max(0.0, pt.dark_variance_dn2 - quant)) / k;
  pt.dark_noise_e = dark_e;
  pt.saturation_capacity_e = pt.saturation_mean_dn / k;
  const double mu = pt.saturation_capacity_e;
  pt.snr_max = mu / std::sqrt(dark_e * dark_e + quant / (k * k) + mu);
  pt.dynamic_range = mu / std::max(dark_e, 1.0 / (k * std::sqrt(12.0)));
  pt.points = std::move(points);
  return pt;
}

Result<Linearity> fit_linearity(std::vector<LinearityPoint> points, double saturation_dn,
                                bool saturation_known) {
  Linearity lin;
  // Minimise sum ((y - a x) / y)^2: a = sum(x / y) / sum(x^2 / y^2).
  double sxy = 0, sxx = 0;
  for (LinearityPoint& p : points) {
    p.used = !p.saturated && saturation_dn > 0 && p.exposure_gain_us > 0 &&
             p.mean_dn >= 0.05 * saturation_dn &&
             (!saturation_known || p.mean_dn <= 0.95 * saturation_dn);
    if (!p.used) continue;
    const double q = p.exposure_gain_us / p.mean_dn;
    sxy += q;
    sxx += q * q;
    ++lin.used_count;
  }
  if (lin.used_count < 2)
    return make_error("too_few_samples",
                      "linearity needs at least 2 exposures between 5% and "
                      "95% of saturation; got " +
                          std::to_string(lin.used_count));
  lin.slope_dn_per_us = sxy / sxx;
  for (LinearityPoint& p : points) {
    const double model = lin.slope_dn_per_us * p.exposure_gain_us;
    p.error_pct = model > 0 ? 100.0 * (p.mean_dn - model) / model : 0.0;
    if (p.used) lin.max_abs_error_pct = std::max(lin.max_abs_error_pct, std::fabs(p.error_pct));
  }
  std::sort(points.begin(), points.end(), [](const LinearityPoint& x, const LinearityPoint& y) {
    return x.exposure_gain_us < y.exposure_gain_us;
  });
  lin.points = std::move(points);
  return lin;
}

Result<HdrResult> merge_hdr(std::span<const HdrFrame> frames, const HdrNoise& noise) {
  if (frames.empty()) return make_error("invalid_argument", "an HDR merge needs frames");
  if (!(noise.k_dn_per_e > 0) || !(noise.read_variance_dn2 >= 0) ||
      !std::isfinite(noise.k_dn_per_e) || !std::isfinite(noise.read_variance_dn2))
    return make_error("invalid_argument", "the noise model needs K > 0 and a read variance >= 0");
  const cv::Size size = frames[0].signal_dn.size();
  for (const HdrFrame& f : frames) {
    if (f.signal_dn.empty() || f.signal_dn.size() != size || f.signal_dn.type() != CV_32F)
      return make_error("invalid_argument", "HDR frames must be CV_32F images of one size");
    if (!(f.exposure_us > 0) || !(f.gain > 0) || !(f.clip_dn > 0))
      return make_error("invalid_argument", "HDR frames need exposure, gain and clip level > 0");
  }
  // The least exposed frame gives the bound for pixels clipped everywhere.
  size_t least = 0;
  for (size_t i = 1; i < frames.size(); ++i)
    if (frames[i].exposure_us * frames[i].gain < frames[least].exposure_us * frames[least].gain)
      least = i;
  HdrResult out;
  out.radiance.create(size, CV_32F);
  out.sigma.create(size, CV_32F);
  out.clipped = cv::Mat::zeros(size, CV_8U);
  out.frames_used = cv::Mat::zeros(size, CV_8U);
  // A floor on the variance so that a zero signal with no read noise still has weight.
  const double floor_var = 1.0 / 12.0;
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      double sw = 0, swx = 0;
      int used = 0;
      for (const HdrFrame& f : frames) {
        const double s = f.signal_dn.at<float>(r, c);
        if (!std::isfinite(s) || s >= 0.97 * f.clip_dn) continue;
        const double h = f.exposure_us * f.gain;
        const double var = f.gain * noise.k_dn_per_e * std::max(s, 0.0) +
                           f.gain * f.gain * noise.read_variance_dn2 + floor_var;
        const double w = h * h / var;  // 1 / var(s / h)
        sw += w;
        swx += w * s / h;
        ++used;
      }
      out.frames_used.at<uint8_t>(r, c) = static_cast<uint8_t>(std::min(used, 255));
      if (used == 0) {
        const HdrFrame& f = frames[least];
        out.radiance.at<float>(r, c) = static_cast<float>(f.clip_dn / (f.exposure_us * f.gain));
        out.sigma.at<float>(r, c) = 0.0f;
        out.clipped.at<uint8_t>(r, c) = 255;
        ++out.clipped_everywhere;
        continue;
      }
      out.radiance.at<float>(r, c) = static_cast<float>(swx / sw);
      out.sigma.at<float>(r, c) = static_cast<float>(1.0 / std::sqrt(sw));
    }
  }
  return out;
}

}  // namespace camlab::analysis
