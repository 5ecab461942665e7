#include "image/pfm.h"

#include <cstdio>
#include <cstring>

#include "base/atomic_file.h"

namespace camlab::image {

std::string encode_pfm(const cv::Mat& image) {
  CV_Assert(image.type() == CV_32F);
  std::string out =
      "Pf\n" + std::to_string(image.cols) + " " + std::to_string(image.rows) + "\n-1.0\n";
  const size_t row_bytes = static_cast<size_t>(image.cols) * sizeof(float);
  for (int y = image.rows - 1; y >= 0; --y)
    out.append(reinterpret_cast<const char*>(image.ptr<float>(y)), row_bytes);
  return out;
}

Result<cv::Mat> decode_pfm(const std::string& bytes, const std::string& what) {
  int width = 0, height = 0, used = 0;
  double scale = 0;
  if (std::sscanf(bytes.c_str(), "Pf %d %d %lf%n", &width, &height, &scale, &used) != 3 ||
      width < 1 || height < 1 || width > 65536 || height > 65536 || scale >= 0 ||
      used >= static_cast<int>(bytes.size()))
    return make_error("bad_image", what + " is not a little-endian grey PFM image");
  const size_t data = static_cast<size_t>(used) + 1;  // one whitespace after the scale
  const size_t row_bytes = static_cast<size_t>(width) * sizeof(float);
  if (bytes.size() != data + row_bytes * static_cast<size_t>(height))
    return make_error("bad_image", what + " holds " + std::to_string(bytes.size()) +
                                       " bytes, not a " + std::to_string(width) + "x" +
                                       std::to_string(height) + " float image");
  cv::Mat image(height, width, CV_32F);
  for (int y = 0; y < height; ++y)
    std::memcpy(image.ptr<float>(height - 1 - y), bytes.data() + data + row_bytes * y, row_bytes);
  return image;
}

Status write_pfm(const std::filesystem::path& path, const cv::Mat& image) {
  if (image.empty() || image.type() != CV_32F)
    return make_error("invalid_argument", "a PFM holds a single-channel float image");
  return write_file_atomically(path, encode_pfm(image));
}

Result<cv::Mat> read_pfm(const std::filesystem::path& path) {
  auto bytes = read_text_file(path);
  if (!bytes) return bytes.error();
  return decode_pfm(*bytes, path.string());
}

}  // namespace camlab::image
