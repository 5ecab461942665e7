#include "calib/cholmod_sparse.h"

namespace camlab::calib {

SparseJacobian::SparseJacobian(int nstate, int nmeasurements, int nonzeros)
    : nstate(nstate),
      nmeasurements(nmeasurements),
      row_start(nmeasurements + 1),
      col(nonzeros),
      val(nonzeros) {
  jt.nrow = nstate;
  jt.ncol = nmeasurements;
  jt.nzmax = nonzeros;
  jt.p = row_start.data();
  jt.i = col.data();
  jt.x = val.data();
  jt.sorted = jt.packed = 1;
}

void SparseJacobian::information(int observation_rows, cv::Mat* jtj, cv::Mat* jobs) const {
  *jtj = cv::Mat::zeros(nstate, nstate, CV_64F);
  *jobs = cv::Mat::zeros(nstate, nstate, CV_64F);
  for (int r = 0; r < nmeasurements; ++r) {
    cv::Mat& m = r < observation_rows ? *jobs : *jtj;
    for (int a = row_start[r]; a < row_start[r + 1]; ++a) {
      double* out = m.ptr<double>(col[a]);
      for (int b = row_start[r]; b < row_start[r + 1]; ++b) out[col[b]] += val[a] * val[b];
    }
  }
  *jtj += *jobs;
}

}  // namespace camlab::calib
