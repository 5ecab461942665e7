// A process that writes a capture folder and is killed (SIGKILL) by
// capture_journal_test at a random instant: frame k is a 320x240 16-bit image whose pixels
// are noise over the base value 1000 x k (k's own seed), with sequence = k, so a reader can
// tell a whole frame from anything else.
//
//   capture_writer_child DIR FRAMES
#include <cstdio>
#include <cstdlib>

#include <opencv2/core.hpp>

#include "image/capture_folder.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: capture_writer_child DIR FRAMES\n");
    return 2;
  }
  using namespace camlab::image;
  const int frames = std::atoi(argv[2]);
  auto writer = CaptureFolderWriter::create(argv[1], "single", {{"backend", "test"}}, {},
                                            CommitPolicy{4, std::chrono::milliseconds(20)});
  if (!writer) return 1;
  for (int k = 0; k < frames; ++k) {
    cv::Mat image(240, 320, CV_16UC1);
    cv::RNG rng(static_cast<uint64_t>(k) + 1);
    rng.fill(image, cv::RNG::UNIFORM, 0, 1000);
    image += cv::Scalar(1000.0 * (k % 60));
    FrameSidecar sidecar;
    sidecar.sequence = static_cast<uint64_t>(k);
    sidecar.pixel_format = "Y16";
    sidecar.bit_depth = 16;
    if (!writer->add_frame(image, sidecar)) return 1;
  }
  return writer->finish() ? 0 : 1;
}
