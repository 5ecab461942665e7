// The PNG encoder against decoders it does not share code with: libpng (through OpenCV's
// imdecode) reads back every pixel, and zlib inflates the IDAT of a small image whose
// filtered bytes are written out here from the PNG specification.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "image/png_encoder.h"

namespace camlab::image {
namespace {

struct Chunk {
  std::string type;
  std::vector<uint8_t> data;
  uint32_t crc = 0;
};

uint32_t be32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}

// Splits a PNG into its chunks; fails the test on a bad signature or a short chunk.
std::vector<Chunk> chunks_of(std::span<const uint8_t> png) {
  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<Chunk> chunks;
  EXPECT_GE(png.size(), 8u);
  EXPECT_EQ(std::memcmp(png.data(), kSignature, 8), 0);
  size_t at = 8;
  while (at + 12 <= png.size()) {
    const uint32_t length = be32(&png[at]);
    EXPECT_LE(at + 12 + length, png.size());
    if (at + 12 + length > png.size()) break;
    Chunk c;
    c.type.assign(reinterpret_cast<const char*>(&png[at + 4]), 4);
    c.data.assign(png.begin() + static_cast<long>(at + 8),
                  png.begin() + static_cast<long>(at + 8 + length));
    c.crc = be32(&png[at + 8 + length]);
    // The CRC covers the type and the data (zlib's crc32, not the encoder's).
    EXPECT_EQ(c.crc, crc32(0, &png[at + 4], 4 + length)) << c.type;
    chunks.push_back(std::move(c));
    at += 12 + length;
  }
  EXPECT_EQ(at, png.size()) << "no bytes after IEND";
  return chunks;
}

cv::Mat decode(std::span<const uint8_t> png) {
  return cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_UNCHANGED);
}

TEST(PngEncoder, EveryFilterAndLevelReadsBackBitExactThroughLibpng) {
  cv::RNG rng(7);
  const PngFilter filters[] = {PngFilter::kNone, PngFilter::kSub, PngFilter::kUp,
                               PngFilter::kAverage, PngFilter::kPaeth};
  const int types[] = {CV_8UC1, CV_16UC1, CV_8UC3, CV_16UC3};
  const cv::Size sizes[] = {{1, 1}, {7, 3}, {64, 48}};
  for (PngFilter filter : filters) {
    for (int level : {0, 1, 6, 12}) {
      PngEncoder encoder({level, filter});
      for (int type : types) {
        for (cv::Size size : sizes) {
          cv::Mat image(size, type);
          rng.fill(image, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_8U ? 256 : 65536);
          image.at<uint8_t>(0, 0) = 0;  // the extremes, in the first byte of the first row
          if (size.width > 1) image.ptr<uint8_t>(0)[image.elemSize()] = 255;
          auto png = encoder.encode(image);
          ASSERT_TRUE(png.ok()) << png.error().message;
          const cv::Mat back = decode(*png);
          ASSERT_FALSE(back.empty())
              << "libpng refused it: filter " << static_cast<int>(filter) << " level " << level;
          ASSERT_EQ(back.type(), type);
          EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0)
              << "filter " << static_cast<int>(filter) << " level " << level << " type " << type
              << " size " << size;
        }
      }
    }
  }
}

TEST(PngEncoder, ChunksAndFilteredRowsAreAsTheSpecificationLaysThemOut) {
  // A 3x2 16-bit grey image, the sub filter: each byte minus the byte two to its left
  // (bytes per pixel = 2), modulo 256, big-endian samples, a filter-type byte per row.
  cv::Mat image = (cv::Mat_<uint16_t>(2, 3) << 0x0102, 0x0304, 0x0300, 0xffff, 0x0001, 0x1234);
  PngEncoder encoder({0, PngFilter::kSub});
  auto png = encoder.encode(image);
  ASSERT_TRUE(png.ok());
  const std::vector<Chunk> chunks = chunks_of(*png);
  ASSERT_EQ(chunks.size(), 3u);
  EXPECT_EQ(chunks[0].type, "IHDR");
  EXPECT_EQ(chunks[1].type, "IDAT");
  EXPECT_EQ(chunks[2].type, "IEND");
  EXPECT_TRUE(chunks[2].data.empty());
  const std::vector<uint8_t> ihdr = {0,  0, 0, 3,  // width
                                     0,  0, 0, 2,  // height
                                     16,           // bit depth
                                     0,            // colour type: greyscale
                                     0,  0, 0};    // deflate, filter method 0, no interlace
  EXPECT_EQ(chunks[0].data, ihdr);

  std::vector<uint8_t> rows(2 * (1 + 6));
  uLongf size = rows.size();
  ASSERT_EQ(uncompress(rows.data(), &size, chunks[1].data.data(), chunks[1].data.size()), Z_OK);
  ASSERT_EQ(size, rows.size());
  const std::vector<uint8_t> expected = {
      1, 0x01, 0x02, 0x03 - 0x01,       0x04 - 0x02,       0x03 - 0x03, 0x00 - 0x04 + 256,
      1, 0xff, 0xff, 0x00 - 0xff + 256, 0x01 - 0xff + 256, 0x12 - 0x00, 0x34 - 0x01};
  EXPECT_EQ(rows, expected);
}

TEST(PngEncoder, ColourIsStoredAsRgbFromOpenCvsBgr) {
  cv::Mat image(1, 1, CV_8UC3, cv::Scalar(10, 20, 30));  // B, G, R
  PngEncoder encoder({0, PngFilter::kNone});
  auto png = encoder.encode(image);
  ASSERT_TRUE(png.ok());
  const std::vector<Chunk> chunks = chunks_of(*png);
  ASSERT_GE(chunks.size(), 2u);
  EXPECT_EQ(chunks[0].data[8], 8);  // bit depth
  EXPECT_EQ(chunks[0].data[9], 2);  // colour type: truecolour
  std::vector<uint8_t> row(4);
  uLongf size = row.size();
  ASSERT_EQ(uncompress(row.data(), &size, chunks[1].data.data(), chunks[1].data.size()), Z_OK);
  EXPECT_EQ(row, (std::vector<uint8_t>{0, 30, 20, 10}));  // filter none, then R, G, B
}

TEST(PngEncoder, ImagesItCannotStoreAreRefusedWithAReason) {
  PngEncoder encoder;
  for (const cv::Mat& image :
       {cv::Mat(), cv::Mat(4, 4, CV_32FC1), cv::Mat(4, 4, CV_8UC2), cv::Mat(4, 4, CV_16UC4)}) {
    auto png = encoder.encode(image);
    ASSERT_FALSE(png.ok());
    EXPECT_EQ(png.error().code, "bad_frame");
  }
  // The encoder still works after a refusal.
  EXPECT_TRUE(encoder.encode(cv::Mat(2, 2, CV_8UC1, cv::Scalar(9))).ok());
}

}  // namespace
}  // namespace camlab::image
