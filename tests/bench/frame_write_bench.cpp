// What writing a frame to a capture folder costs, and whether the cost stays flat as the
// capture grows (docs/BENCHMARKS.md, "Frame writes"):
//   1. PNG encoding: time and size per 640x480 frame for each encoder and level;
//   2. a 1,000-frame capture through CaptureFolderWriter::add_frame, timing every call
//      (encoding, files, journal and the syncs that fall in it): median, p99 and max over
//      all frames, over frames 0-99 and over frames 900-999, and the bytes written;
//   3. the same frames through capture::FrameWriter (the capture path: its own thread,
//      commits every 16 frames or 250 ms), pushed as fast as its queue takes them at
//      30 frames/s: the time from push to listed in the journal (durable), and the deepest
//      queue.
//
//   frame_write_bench [--frames N] [--repeats R] [--dir DIR] [--skip-levels]
//
// Frames are drawn here from the physics, independent of the renderer: a slanted edge
// (reflectance 0.2 / 0.8) under a cos^4 falloff, Poisson shot noise on the electrons,
// Gaussian read noise of 3 e-, a 10-bit ADC over a 12,000 e- full well and a black level
// of 32 DN, stored in 16 bits as camlabd stores a 10-bit sensor. Each of 16 frames has
// its own noise, so no two consecutive frames are identical. DIR (default: the temporary
// directory) must be on the disk to measure; the folder is removed afterwards.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "capture/frame_writer.h"
#include "image/capture_folder.h"
#include "image/png_encoder.h"

namespace {

using namespace camlab;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The q-quantile (0..1) of `values` (nearest rank).
double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const size_t rank = static_cast<size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::clamp<size_t>(rank, 1, values.size()) - 1];
}

// A 640x480 frame of a 10-bit sensor, DN in 16 bits (see the header comment).
cv::Mat sensor_frame(int width, int height, uint32_t seed) {
  constexpr double kFullWellE = 12000, kReadNoiseE = 3, kBlackDn = 32, kMaxDn = 1023;
  constexpr double kDnPerE = (kMaxDn - kBlackDn) / kFullWellE;
  const double tan_angle = std::tan(5.0 * M_PI / 180.0);
  std::mt19937 rng(seed);
  std::normal_distribution<double> read_noise(0.0, kReadNoiseE);
  cv::Mat frame(height, width, CV_16UC1);
  for (int y = 0; y < height; ++y) {
    auto* row = frame.ptr<uint16_t>(y);
    for (int x = 0; x < width; ++x) {
      const double reflectance = (x - width / 2) > (y - height / 2) * tan_angle ? 0.8 : 0.2;
      const double r2 = (std::pow(x - width / 2, 2) + std::pow(y - height / 2, 2)) /
                        (std::pow(width, 2) + std::pow(height, 2));
      const double falloff = std::pow(1.0 / (1.0 + 2.0 * r2), 2);  // cos^4 at a 55 deg field
      const double mean_e = 0.85 * kFullWellE * reflectance * falloff;
      std::poisson_distribution<int> shot(mean_e);
      const double electrons = shot(rng) + read_noise(rng);
      row[x] = static_cast<uint16_t>(
          std::clamp(std::lround(kBlackDn + electrons * kDnPerE), 0L, static_cast<long>(kMaxDn)));
    }
  }
  return frame;
}

image::FrameSidecar sidecar_for(int index) {
  image::FrameSidecar s;
  s.sequence = static_cast<uint64_t>(index) + 3;
  s.timestamp_ns = 1'000'000'000 + static_cast<int64_t>(index) * 33'333'333;
  s.pixel_format = "Y10";
  s.delivered_format = "Y16 ";
  s.bit_depth = 10;
  s.black_level_dn = 32;
  s.settings = {{"exposure_time_absolute", 100}, {"exposure_us", 10000.0}, {"gain", 1.0}};
  s.labels = {{"step_index", 0}, {"repeat", index}};
  return s;
}

double median_ms(int repeats, const std::function<void()>& work) {
  std::vector<double> ms;
  for (int i = 0; i < repeats; ++i) {
    const auto start = Clock::now();
    work();
    ms.push_back(ms_since(start));
  }
  return quantile(ms, 0.5);
}

void encoder_table(const std::vector<cv::Mat>& frames, int repeats) {
  const double raw_bytes = static_cast<double>(frames[0].total() * frames[0].elemSize());
  std::printf("\nPNG encoding of a 640x480 16-bit frame (10-bit DN, noise on), median of %d\n",
              repeats);
  std::printf("| encoder | level | ms/frame | bytes | %% of raw |\n|---|---|---|---|---|\n");
  for (int level = 0; level <= 9; ++level) {
    std::vector<uchar> png;
    size_t k = 0;
    const double ms = median_ms(repeats, [&] {
      cv::imencode(".png", frames[k++ % frames.size()], png, {cv::IMWRITE_PNG_COMPRESSION, level});
    });
    std::printf("| OpenCV imencode (libpng, zlib) | %d | %.2f | %zu | %.1f |\n", level, ms,
                png.size(), 100.0 * png.size() / raw_bytes);
  }
  const std::pair<image::PngFilter, const char*> filters[] = {
      {image::PngFilter::kNone, "none"},
      {image::PngFilter::kSub, "sub"},
      {image::PngFilter::kUp, "up"},
      {image::PngFilter::kAverage, "average"},
      {image::PngFilter::kPaeth, "paeth"}};
  for (const auto& [filter, name] : filters) {
    for (int level : {0, 1, 2, 3, 4, 6, 9, 12}) {
      if (filter != image::PngFilter::kSub && level > 1) continue;  // sub wins at level 1
      image::PngEncoder encoder({level, filter});
      size_t bytes = 0, k = 0;
      const double ms = median_ms(repeats, [&] {
        auto png = encoder.encode(frames[k++ % frames.size()]);
        bytes = png ? png->size() : 0;
      });
      std::printf("| camlab PngEncoder (libdeflate), filter %s | %d | %.2f | %zu | %.1f |\n", name,
                  level, ms, bytes, 100.0 * bytes / raw_bytes);
    }
  }
}

struct Series {
  std::vector<double> ms;  // per add_frame call
  double finish_ms = 0, wall_s = 0;
  uintmax_t bytes = 0;           // every file in the folder at the end
  uintmax_t manifest_bytes = 0;  // manifest.json at the end
};

Series write_series(const fs::path& dir, const std::vector<cv::Mat>& frames, int count) {
  Series series;
  fs::remove_all(dir);
  const auto started = Clock::now();
  auto writer = image::CaptureFolderWriter::create(dir, "single", {{"camera", "bench"}},
                                                   {{"kind", "single"}, {"repeats", count}});
  if (!writer) {
    std::fprintf(stderr, "cannot create %s: %s\n", dir.c_str(), writer.error().message.c_str());
    return series;
  }
  for (int i = 0; i < count; ++i) {
    const auto start = Clock::now();
    auto entry = writer->add_frame(frames[static_cast<size_t>(i) % frames.size()], sidecar_for(i));
    series.ms.push_back(ms_since(start));
    if (!entry) {
      std::fprintf(stderr, "frame %d: %s\n", i, entry.error().message.c_str());
      return series;
    }
  }
  const auto finishing = Clock::now();
  if (Status s = writer->finish(); !s)
    std::fprintf(stderr, "finish: %s\n", s.error().message.c_str());
  series.finish_ms = ms_since(finishing);
  series.wall_s = ms_since(started) / 1000.0;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.is_regular_file()) series.bytes += entry.file_size();
  std::error_code ec;
  series.manifest_bytes = fs::file_size(dir / "manifest.json", ec);
  return series;
}

void print_series(const Series& s, int count) {
  auto row = [&](const char* what, size_t from, size_t to) {
    to = std::min(to, s.ms.size());
    if (from >= to) return;
    std::vector<double> part(s.ms.begin() + static_cast<long>(from),
                             s.ms.begin() + static_cast<long>(to));
    double sum = 0;
    for (double v : part) sum += v;
    std::printf("| %s | %zu | %.2f | %.2f | %.2f | %.2f |\n", what, part.size(),
                quantile(part, 0.5), quantile(part, 0.99),
                part.empty() ? 0 : *std::max_element(part.begin(), part.end()),
                sum / static_cast<double>(part.size()));
  };
  std::printf(
      "\n%d frames through CaptureFolderWriter::add_frame (wall %.2f s, finish %.2f ms, "
      "%.1f MB on disk, %.0f bytes/frame, manifest.json %ju bytes)\n",
      count, s.wall_s, s.finish_ms, s.bytes / 1e6,
      static_cast<double>(s.bytes) / std::max(count, 1), s.manifest_bytes);
  std::printf(
      "| frames | n | median ms | p99 ms | max ms | mean ms |\n|---|---|---|---|---|---|\n");
  row("all", 0, s.ms.size());
  row("0-99", 0, 100);
  if (count >= 1000) row("900-999", 900, 1000);
  if (count != 1000 && count > 100) row("last 100", s.ms.size() - 100, s.ms.size());
}

// Pushes `count` frames at `fps` (0: as fast as the queue takes them) and measures, for
// each, the time from push to listed.
void frame_writer_series(const fs::path& dir, const std::vector<cv::Mat>& frames, int count,
                         double fps) {
  fs::remove_all(dir);
  auto folder = image::CaptureFolderWriter::create(dir, "single", {{"camera", "bench"}}, {});
  if (!folder) {
    std::fprintf(stderr, "cannot create %s: %s\n", dir.c_str(), folder.error().message.c_str());
    return;
  }
  capture::FrameWriter writer(std::move(*folder), {});
  std::vector<Clock::time_point> pushed(static_cast<size_t>(count));
  std::vector<double> latency_ms;
  const auto start = Clock::now();
  auto collect = [&] {
    for (const auto& w : writer.take_written())
      latency_ms.push_back(
          std::chrono::duration<double, std::milli>(Clock::now() - pushed[w.entry.index]).count());
  };
  for (int i = 0; i < count;) {
    if (fps > 0) std::this_thread::sleep_until(start + std::chrono::duration<double>(i / fps));
    if (!writer.has_room()) {
      collect();
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      continue;
    }
    pushed[static_cast<size_t>(i)] = Clock::now();
    if (Status s =
            writer.push(frames[static_cast<size_t>(i) % frames.size()].clone(), sidecar_for(i));
        !s) {
      std::fprintf(stderr, "push %d: %s\n", i, s.error().message.c_str());
      return;
    }
    ++i;
    collect();
  }
  while (static_cast<int>(latency_ms.size()) < count - 16 && ms_since(start) < 600'000) {
    collect();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (Status s = writer.close(true); !s)
    std::fprintf(stderr, "close: %s\n", s.error().message.c_str());
  collect();
  const double wall_s = ms_since(start) / 1000;
  const auto stats = writer.stats();
  std::printf("| %s | %d | %.2f | %.1f | %.1f | %.1f | %zu | %d |\n",
              fps > 0 ? "30 frames/s" : "as fast as it takes them", count, wall_s, count / wall_s,
              quantile(latency_ms, 0.5), quantile(latency_ms, 0.99), stats.most_frames_held,
              stats.commits);
  fs::remove_all(dir);
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 1000, repeats = 15;
  bool levels = true;
  fs::path dir = fs::temp_directory_path();
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--frames" && i + 1 < argc) {
      frames = std::clamp(std::atoi(argv[++i]), 1, 100000);
    } else if (arg == "--repeats" && i + 1 < argc) {
      repeats = std::clamp(std::atoi(argv[++i]), 1, 1000);
    } else if (arg == "--dir" && i + 1 < argc) {
      dir = argv[++i];
    } else if (arg == "--skip-levels") {
      levels = false;
    } else {
      std::fprintf(stderr,
                   "usage: frame_write_bench [--frames N] [--repeats R] [--dir DIR] "
                   "[--skip-levels]\n");
      return 2;
    }
  }
  std::vector<cv::Mat> images;
  for (uint32_t seed = 1; seed <= 16; ++seed) images.push_back(sensor_frame(640, 480, seed));
  if (levels) encoder_table(images, repeats);
  const fs::path folder = dir / ("camlab_frame_write_bench_" + std::to_string(::getpid()));
  const Series series = write_series(folder, images, frames);
  print_series(series, frames);
  fs::remove_all(folder);
  std::printf(
      "\n%d frames through capture::FrameWriter (its own thread; listed = synced and in "
      "the journal)\n",
      frames);
  std::printf(
      "| pushed | frames | wall s | frames/s | push to listed, median ms | p99 ms | "
      "deepest queue | commits |\n|---|---|---|---|---|---|---|---|\n");
  frame_writer_series(folder, images, frames, 0);
  frame_writer_series(folder, images, frames, 30);
  return series.ms.size() == static_cast<size_t>(frames) ? 0 : 1;
}
