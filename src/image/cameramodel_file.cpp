#include "image/cameramodel_file.h"

#include <cstdio>
#include <sstream>

namespace camlab::image {

namespace {

std::string exact(double value) {
  char text[40];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

}  // namespace

std::string to_cameramodel_text(const CameraModelText& model) {
  std::ostringstream out;
  std::istringstream comment(model.comment);
  for (std::string line; std::getline(comment, line);) out << "# " << line << "\n";
  out << "{\n";
  out << "    'lensmodel':  '" << model.lensmodel << "',\n";
  out << "    'intrinsics': [";
  for (size_t i = 0; i < model.intrinsics.size(); ++i)
    out << (i ? ", " : " ") << exact(model.intrinsics[i]);
  out << " ],\n";
  // mrcal 2.2's readers (C and Python) call the rt_cam_ref transform 'extrinsics'.
  out << "    'extrinsics': [";
  for (size_t i = 0; i < 6; ++i) out << (i ? ", " : " ") << exact(model.rt_cam_ref[i]);
  out << " ],\n";
  out << "    'imagersize': [ " << model.imagersize[0] << ", " << model.imagersize[1] << " ],\n";
  out << "}\n";
  return out.str();
}

}  // namespace camlab::image
