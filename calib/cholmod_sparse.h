// The Jacobian mrcal_optimizer_callback fills (internal to calib/), and the information
// matrices made from it; shared by the single-camera uncertainty (uncertainty.cpp) and the
// rig's (rig/rig_solver.cpp).
#pragma once

#include <cstddef>
#include <vector>

#include <opencv2/core.hpp>

// mrcal_optimizer_callback fills a caller-allocated cholmod_sparse (J^T in compressed
// columns = J in compressed rows) and reads and writes only its p, i and x arrays. Debian
// ships no cholmod.h with libmrcal-dev, so the struct is declared here with SuiteSparse's
// layout (unchanged from SuiteSparse 4 to 7; mrcal.h only forward-declares it).
struct cholmod_sparse_struct {
  size_t nrow, ncol, nzmax;
  void* p;   // Nmeasurements + 1 row starts (int)
  void* i;   // column (state) index of each non-zero (int)
  void* nz;  // unused (packed)
  void* x;   // values (double)
  void* z;
  int stype, itype, xtype, dtype, sorted, packed;
};

namespace camlab::calib {

// J (nmeasurements x nstate, nonzeros from _mrcal_num_j_nonzero) with its storage; `jt`
// is what mrcal_optimizer_callback takes.
struct SparseJacobian {
  SparseJacobian(int nstate, int nmeasurements, int nonzeros);
  SparseJacobian(const SparseJacobian&) = delete;
  SparseJacobian& operator=(const SparseJacobian&) = delete;

  // J_obs^T J_obs over the rows before `observation_rows` (the board observations) into
  // *jobs, and J^T J over every row into *jtj (nstate x nstate, CV_64F).
  void information(int observation_rows, cv::Mat* jtj, cv::Mat* jobs) const;

  int nstate, nmeasurements;
  std::vector<int> row_start, col;
  std::vector<double> val;
  cholmod_sparse_struct jt{};
};

}  // namespace camlab::calib
