// Under `camlab vcam run`: reads N frames from /dev/video0 through OpenCV's V4L2 backend
// (cv::VideoCapture with CAP_V4L2, YUYV at WIDTHxHEIGHT, converted to BGR as an
// application would have them) and prints one line per frame, the buffer's timestamp in
// ms (CAP_PROP_POS_MSEC: the driver's timestamp of the frame, so a frame the camera
// skipped shows as a step of two intervals however late the client read it):
//   frame 0 t_ms 1234.567
// Exit status: 0, or 1 (usage), 2 (cannot open), 3 (a read failed).
#include <cstdio>
#include <cstdlib>

#include <opencv2/videoio.hpp>

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: vcam_opencv_rate_client FRAMES WIDTH HEIGHT\n");
    return 1;
  }
  const int frames = std::atoi(argv[1]);
  cv::VideoCapture capture(0, cv::CAP_V4L2);
  if (!capture.isOpened()) return 2;
  capture.set(cv::CAP_PROP_FOURCC, cv::VideoWriter::fourcc('Y', 'U', 'Y', 'V'));
  capture.set(cv::CAP_PROP_FRAME_WIDTH, std::atoi(argv[2]));
  capture.set(cv::CAP_PROP_FRAME_HEIGHT, std::atoi(argv[3]));
  cv::Mat frame;
  for (int i = 0; i < frames; ++i) {
    if (!capture.read(frame) || frame.empty()) return 3;
    std::printf("frame %d t_ms %.3f\n", i, capture.get(cv::CAP_PROP_POS_MSEC));
  }
  return 0;
}
