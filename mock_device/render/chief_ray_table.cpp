#include "mock_device/render/chief_ray_table.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "mock_device/spec/mrcal_api.h"

namespace camlab::mock {

Result<ChiefRayTable> ChiefRayTable::create(const std::string& lensmodel_name,
                                            const std::vector<double>& intrinsics, int width_px,
                                            int height_px) {
  mrcal_lensmodel_t lensmodel;
  if (!mrcal_lensmodel_from_name(&lensmodel, lensmodel_name.c_str()))
    return make_error("bad_lensmodel", "unknown lens model " + lensmodel_name);
  if (static_cast<int>(intrinsics.size()) != mrcal_lensmodel_num_params(&lensmodel))
    return make_error("bad_lensmodel", lensmodel_name + " needs " +
                                           std::to_string(mrcal_lensmodel_num_params(&lensmodel)) +
                                           " intrinsics, got " + std::to_string(intrinsics.size()));
  ChiefRayTable table;
  table.width_ = width_px;
  table.height_ = height_px;
  table.cx_ = intrinsics[2];
  table.cy_ = intrinsics[3];
  const int stride = width_px + 1;
  const size_t n = static_cast<size_t>(stride) * (height_px + 1);
  std::vector<mrcal_point2_t> q(n);
  for (int j = 0; j <= height_px; ++j)
    for (int i = 0; i <= width_px; ++i) q[j * stride + i] = {.x = i - 0.5, .y = j - 0.5};
  std::vector<mrcal_point3_t> v(n);
  // mrcal_unproject reports failure for the whole batch if any point fails to converge;
  // the round trip below judges each point on its own, so its return value is not needed.
  (void)mrcal_unproject(v.data(), q.data(), static_cast<int>(n), &lensmodel, intrinsics.data());
  std::vector<mrcal_point2_t> q_back(n);
  mrcal_project(q_back.data(), nullptr, nullptr, v.data(), static_cast<int>(n), &lensmodel,
                intrinsics.data());

  table.xn_.resize(n);
  table.yn_.resize(n);
  table.valid_.assign(n, 0);
  for (size_t k = 0; k < n; ++k) {
    const auto& p = v[k];
    const double error_px = std::hypot(q_back[k].x - q[k].x, q_back[k].y - q[k].y);
    const double norm = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
    // Rays within 1 degree of the lens plane cannot meet a plane of focus in front.
    const bool ok = std::isfinite(error_px) && error_px < 1e-3 && norm > 0 && p.z > 0.0175 * norm;
    table.valid_[k] = ok;
    table.xn_[k] = ok ? static_cast<float>(p.x / p.z) : 0.f;
    table.yn_[k] = ok ? static_cast<float>(p.y / p.z) : 0.f;
  }
  table.compute_block_bounds();
  return table;
}

ChiefRayTable ChiefRayTable::rescaled(double ratio, int threads) const {
  if (ratio == 1.0) return *this;
  ChiefRayTable out;
  out.width_ = width_;
  out.height_ = height_;
  out.cx_ = cx_;
  out.cy_ = cy_;
  const int stride = width_ + 1;
  const size_t n = static_cast<size_t>(stride) * (height_ + 1);
  out.xn_.resize(n);
  out.yn_.resize(n);
  out.valid_.resize(n);
  // Where in this table (corner index space) corner (i, j) of the new one lives: the same
  // column position for every row, and the same row position for every column.
  std::vector<int> i0s(static_cast<size_t>(stride));
  std::vector<double> as(static_cast<size_t>(stride));
  for (int i = 0; i <= width_; ++i) {
    const double qx = cx_ + ((i - 0.5) - cx_) / ratio + 0.5;
    i0s[static_cast<size_t>(i)] = std::clamp(static_cast<int>(std::floor(qx)), 0, width_ - 1);
    as[static_cast<size_t>(i)] = std::clamp(qx - i0s[static_cast<size_t>(i)], 0.0, 1.0);
  }
  auto rows = [&](int first, int step) {
    for (int j = first; j <= height_; j += step) {
      const double qy = cy_ + ((j - 0.5) - cy_) / ratio + 0.5;
      const int j0 = std::clamp(static_cast<int>(std::floor(qy)), 0, height_ - 1);
      const double b = std::clamp(qy - j0, 0.0, 1.0);
      const size_t row0 = static_cast<size_t>(j0) * stride, row1 = row0 + stride;
      const size_t k_row = static_cast<size_t>(j) * stride;
      for (int i = 0; i <= width_; ++i) {
        const size_t i0 = static_cast<size_t>(i0s[static_cast<size_t>(i)]);
        const double a = as[static_cast<size_t>(i)];
        const size_t k00 = row0 + i0, k01 = row1 + i0, k = k_row + i;
        out.valid_[k] = valid_[k00] && valid_[k00 + 1] && valid_[k01] && valid_[k01 + 1];
        out.xn_[k] = static_cast<float>((1 - b) * ((1 - a) * xn_[k00] + a * xn_[k00 + 1]) +
                                        b * ((1 - a) * xn_[k01] + a * xn_[k01 + 1]));
        out.yn_[k] = static_cast<float>((1 - b) * ((1 - a) * yn_[k00] + a * yn_[k00 + 1]) +
                                        b * ((1 - a) * yn_[k01] + a * yn_[k01 + 1]));
      }
    }
  };
  std::vector<std::thread> workers;
  for (int t = 1; t < threads; ++t) workers.emplace_back(rows, t, threads);
  rows(0, std::max(1, threads));
  for (auto& w : workers) w.join();
  out.compute_block_bounds();
  return out;
}

void ChiefRayTable::compute_block_bounds() {
  const int stride = width_ + 1;
  blocks_x_ = (width_ + kBlockPx - 1) / kBlockPx;
  const int blocks_y = (height_ + kBlockPx - 1) / kBlockPx;
  blocks_.assign(static_cast<size_t>(blocks_x_) * blocks_y, BlockBounds{});
  for (int by = 0; by < blocks_y; ++by)
    for (int bx = 0; bx < blocks_x_; ++bx) {
      const int i0 = bx * kBlockPx, i1 = std::min(i0 + kBlockPx, width_);
      const int j0 = by * kBlockPx, j1 = std::min(j0 + kBlockPx, height_);
      BlockBounds b{xn_[j0 * stride + i0], xn_[j0 * stride + i0], yn_[j0 * stride + i0],
                    yn_[j0 * stride + i0], true};
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          const size_t k = static_cast<size_t>(j) * stride + i;
          b.valid = b.valid && valid_[k];
          b.x_min = std::min(b.x_min, xn_[k]);
          b.x_max = std::max(b.x_max, xn_[k]);
          b.y_min = std::min(b.y_min, yn_[k]);
          b.y_max = std::max(b.y_max, yn_[k]);
        }
      blocks_[static_cast<size_t>(by) * blocks_x_ + bx] = b;
    }
}

double ChiefRayTable::invalid_fraction() const {
  if (valid_.empty()) return 1.0;
  return 1.0 - static_cast<double>(std::count(valid_.begin(), valid_.end(), 1)) / valid_.size();
}

}  // namespace camlab::mock
