// Under `camlab vcam run`: reads YUYV frames from /dev/video0 through OpenCV's own V4L2
// backend (cv::VideoCapture with CAP_V4L2, no conversion to RGB), writes the fifth
// frame's bytes to the file named by argv[1], and prints the format the device declares
// for it (G_FMT from a second open of the node, which needs no ownership of the stream):
//   width=640 height=480 bytesperline=1280 colorspace=8 ycbcr_enc=0 quantization=0
// Exit status: 0, or 2 (cannot open), 3 (no frame), 4 (cannot write), 5 (no format).
#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>

#include <opencv2/videoio.hpp>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: vcam_opencv_yuyv_client OUTPUT\n");
    return 1;
  }
  cv::VideoCapture capture(0, cv::CAP_V4L2);
  if (!capture.isOpened()) return 2;
  capture.set(cv::CAP_PROP_FOURCC, cv::VideoWriter::fourcc('Y', 'U', 'Y', 'V'));
  capture.set(cv::CAP_PROP_FRAME_WIDTH, 640);
  capture.set(cv::CAP_PROP_FRAME_HEIGHT, 480);
  capture.set(cv::CAP_PROP_CONVERT_RGB, 0);
  cv::Mat frame;
  for (int i = 0; i < 5; ++i)
    if (!capture.read(frame) || frame.empty()) return 3;
  std::ofstream out(argv[1], std::ios::binary);
  out.write(reinterpret_cast<const char*>(frame.data),
            static_cast<std::streamsize>(frame.total() * frame.elemSize()));
  if (!out) return 4;
  const int fd = open("/dev/video0", O_RDWR);
  v4l2_format format{};
  format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (fd < 0 || ioctl(fd, VIDIOC_G_FMT, &format) != 0) return 5;
  close(fd);
  const v4l2_pix_format& pix = format.fmt.pix;
  std::printf("width=%u height=%u bytesperline=%u colorspace=%u ycbcr_enc=%u quantization=%u\n",
              pix.width, pix.height, pix.bytesperline, pix.colorspace, pix.ycbcr_enc,
              pix.quantization);
  return 0;
}
