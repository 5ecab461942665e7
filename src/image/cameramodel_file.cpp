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
  if (!model.optimization_inputs_b85.empty()) {
    // mrcal's Python reader requires icam_intrinsics with the inputs; its C reader skips
    // both keys. The base-85 alphabet has no quote or backslash: no escaping needed.
    out << "    'icam_intrinsics': " << model.icam_intrinsics << ",\n";
    out << "    # mrcal's optimization_inputs of the solve that made this model: an .npz,\n"
           "    # base-85 encoded (mrcal.cameramodel(...).optimization_inputs() decodes it).\n";
    out << "    'optimization_inputs': b'" << model.optimization_inputs_b85 << "',\n";
  }
  out << "}\n";
  return out.str();
}

}  // namespace camlab::image
