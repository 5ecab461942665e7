// Focus stacks (docs/physics.md, "Focus stacks and depth from focus"): a Laplacian focus measure
// per pixel and per region, best focus by log-parabola interpolation between frames, a depth map
// where the focus distance of each frame is known, and an all-in-focus image.
//
// The measure: the Laplacian (3x3 kernel [0 1 0; 1 -4 1; 0 1 0]) of the frame, squared,
// averaged over a box of `window_px` per pixel (reflected borders), and that averaged
// again over each region for the region curves. Its
// noise floor, the part white noise alone contributes, is 20 sigma_n^2 per pixel (the
// kernel's squared norm); sigma_n is estimated per frame by Immerkaer's estimator and the
// least over the stack is used (the most defocused frame, where texture adds least).
//
// Peak between frames, per pixel: with l = log(measure - floor) at the frame of the
// maximum and its two neighbours, delta = (l- - l+) / (2 (l- - 2 l0 + l+)), best = index +
// delta in frame steps. Per region the whole curve is kept and its peak is the curve's
// centre of symmetry (fit_symmetric_peak below), with a sigma from the data. A maximum at
// the first or last frame, or a peak that does not rise clearly above the floor (flat
// texture), is flagged and not extrapolated.
//
// Brightness: the working aperture (f / z_s)^2, flicker or auto exposure change the
// signal across a stack, and the measure grows as its square, which tilts the curve and
// moves its peak (by a quarter of a frame step in a 5-step sweep at f/2). The measure is
// therefore divided by the squared mean signal above `black_level`: of the frame for the
// per-pixel measure, of the region for the region curves.
//
// Deep stacks: frames are streamed in order of focus; per pixel only the running maximum,
// its neighbours and the previous frame's measure are kept, so memory does not grow with
// the number of frames and hundreds of frames stay exact.
//
// Frames must be given in order of focus (monotonic focus position). Reentrant; the
// accumulator is thread-bound.
#pragma once

#include <atomic>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "base/result.h"

namespace camlab::analysis {

inline constexpr std::string_view kFocusOk = "ok";
inline constexpr std::string_view kFocusPeakAtEnd = "peak_at_end";
inline constexpr std::string_view kFocusFlat = "flat_texture";

// The per-pixel focus measure of one frame: the squared Laplacian averaged over a box of
// window_px x window_px (made odd, >= 1), borders reflected; equal to OpenCV's Laplacian
// (ksize 1), square and boxFilter to within 1e-6 of each value (float sums of
// non-negative terms), in one streaming pass over the rows (focus_measure.cpp), on
// horizontal stripes on OpenCV's threads (cv::getNumThreads(); 1 thread: one core).
// `image`: single channel, any depth; CV_32F result.
cv::Mat focus_measure(const cv::Mat& image, int window_px);
// The same into *out, reallocated only when its size or type differs (a stack reuses one
// buffer), every value multiplied by `scale` (e.g. a brightness normalisation).
void focus_measure(const cv::Mat& image, int window_px, cv::Mat* out, double scale);

// Noise floor of the per-pixel squared Laplacian (per pixel, before the window sum):
// 20 sigma_n^2 with sigma_n by Immerkaer's estimator (sqrt(pi/2) mean |I (x) [1 -2 1;
// -2 4 -2; 1 -2 1]| / 6), in the image's units.
double laplacian_noise_floor(const cv::Mat& image);

// Log-parabola peak from three samples around a maximum (after floor subtraction).
// Returns delta in [-0.5, 0.5] steps; 0 when the samples do not form a peak.
double log_parabola_delta(double minus, double centre, double plus);

// The log-parabola vertex of a sampled peak: `values` minus `floor`, fitted over the
// contiguous samples around `peak_index` whose excess is at least half the peak's (at
// least the 3 around it). Returns the vertex (in sample indices) and its 1-sigma from the
// fit's residuals (0 with exactly 3 samples). peak_index must not be at either end.
struct PeakFit {
  double index = 0;
  double sigma = 0;
  int samples = 0;
};
PeakFit fit_log_parabola_peak(const std::vector<double>& values, double floor, int peak_index);

// The centre of symmetry of a sampled peak, for region curves: the m that makes
// l(x) = log(value - floor) most nearly symmetric about it, l(m + t) = l(m - t), over the
// samples whose excess is at least 10% of the peak's, each compared with the linear
// interpolation of l at its mirror image 2m - x. A focus curve is symmetric about best
// focus (the blur grows alike on both sides) but not log-parabolic: the three-point
// parabola pulls the peak toward the nearest frame by up to a third of a step (at 1.3 px
// of blur per step), the centre of symmetry does not (within 0.05 step on 99% of
// regions of independent stacks; docs/analysis.md). sigma is the least-squares sigma of m from the
// mirror residuals (never below kMinPeakSigma): asymmetry from noise or from the sampling shows up
// in them. index = peak_index and sigma = 0 when fewer than 3 samples mirror inside.
inline constexpr double kMinPeakSigma = 0.002;  // frame steps: the search's resolution
PeakFit fit_symmetric_peak(const std::vector<double>& values, double floor, int peak_index);

struct FocusStackOptions {
  int window_px = 9;            // per-pixel measure window
  int region_px = 32;           // region grid cell size
  double min_peak_ratio = 3.0;  // peak (minus floor) over the floor: below it, flat;
                                // also flat when the peak is < 1.25 x the curve's least
  double black_level = 0;       // DN subtracted before the brightness normalisation
  const std::atomic<bool>* cancel = nullptr;  // set: stop between frames (base/cancel.h)
};

struct RegionFocus {
  cv::Rect rect;
  std::string status;           // kFocusOk, kFocusPeakAtEnd, kFocusFlat
  double best_index = 0;        // frame index (sub-step) in stack order
  double best_index_sigma = 0;  // 1 sigma of best_index from the peak fit (frames)
  double confidence = 0;        // (peak - floor) / floor (higher is surer); 0 for flat
  std::vector<double> curve;    // measure per frame (mean per pixel), for plots
};

struct FocusStackResult {
  int frames = 0;
  cv::Mat best_index;    // CV_32F, sub-step frame index per pixel
  cv::Mat valid;         // CV_8U, 255 where the pixel's peak is inside and above the floor
  cv::Mat all_in_focus;  // the input type: each pixel from its sharpest frame
  std::vector<RegionFocus> regions;
};

// Streams a stack through the measure. add() the frames in order of focus, then
// finish().
class FocusStackAccumulator {
 public:
  explicit FocusStackAccumulator(FocusStackOptions options) : options_(options) {}
  // `magnification`: the frame's image scale relative to the others (for a thin lens,
  // lens-to-sensor distance / a reference one; 1 when unknown). Focus breathing grows
  // the image as the lens moves out, and the Laplacian energy of content below Nyquist
  // falls as magnification^-4, which tilts the curve and moves the peak (by about 0.25
  // focus steps at f/2 with 1 um steps on an 8 mm lens); the measure is multiplied by
  // magnification^4 to undo it.
  // Errors: "invalid_argument" (empty, multi-channel, or a size/type different from the
  // first frame, magnification not > 0), after finish().
  Status add(const cv::Mat& frame, double magnification = 1.0);
  // Errors: "too_few_samples" (fewer than 3 frames).
  Result<FocusStackResult> finish();

 private:
  template <class Word>
  void update_peaks(const cv::Mat& measure, const cv::Mat& frame);

  FocusStackOptions options_;
  int count_ = 0;
  bool finished_ = false;
  cv::Mat best_, best_minus_, best_plus_, previous_;  // CV_32F measures
  cv::Mat scratch_;                                   // this frame's measure (reused)
  cv::Mat best_index_;                                // CV_32S
  cv::Mat sharpest_;                                  // the input type
  double floor_ = 0;                                  // least normalised noise floor
  std::vector<std::vector<double>> region_curves_;    // normalised measure per frame
  std::vector<cv::Rect> region_rects_;
  cv::Size grid_;                      // regions across, down
  std::vector<double> region_floors_;  // least normalised floor per region
};

// Depth from a best-focus index through the frames' focus distances (metres; +infinity
// allowed): interpolated linearly in dioptres (1/d), which the thin lens makes nearly
// linear in the lens position. Index out of range: clamped.
double distance_at_index(const std::vector<double>& focus_distance_m, double index);

}  // namespace camlab::analysis
