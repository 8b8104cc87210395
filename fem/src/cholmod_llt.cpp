// CHOLMOD sparse Cholesky of K (cholmod_llt.hpp), through CHOLMOD's 64-bit-index interface.
#include "cholmod_llt.hpp"

#include <suitesparse/cholmod.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

namespace vim::fem {

struct CholmodLLT::Data {
  cholmod_common common;
  cholmod_factor* factor = nullptr;
  // Workspace reused across solves (cholmod_l_solve2 reallocates it only when k grows).
  cholmod_dense* x = nullptr;
  cholmod_dense* y = nullptr;
  cholmod_dense* e = nullptr;

  void release() {
    if (factor) cholmod_l_free_factor(&factor, &common);
    if (x) cholmod_l_free_dense(&x, &common);
    if (y) cholmod_l_free_dense(&y, &common);
    if (e) cholmod_l_free_dense(&e, &common);
    cholmod_l_finish(&common);
  }
};

CholmodLLT::CholmodLLT(long n, const std::vector<long>& Ap, const std::vector<long>& Ai,
                       const std::vector<double>& Ax)
    : n_(n), d_(new Data) {
  cholmod_l_start(&d_->common);
  d_->common.print = 0;
  d_->common.error_handler = nullptr;
  cholmod_sparse A{};
  A.nrow = A.ncol = static_cast<std::size_t>(n);
  A.nzmax = static_cast<std::size_t>(Ap[static_cast<std::size_t>(n)]);
  A.p = const_cast<long*>(Ap.data());
  A.i = const_cast<long*>(Ai.data());
  A.x = const_cast<double*>(Ax.data());
  A.stype = 1;  // symmetric, upper triangle stored (entries below the diagonal are ignored)
  A.itype = CHOLMOD_LONG;
  A.xtype = CHOLMOD_REAL;
  A.dtype = CHOLMOD_DOUBLE;
  A.sorted = 1;
  A.packed = 1;
  d_->factor = cholmod_l_analyze(&A, &d_->common);
  const bool ok =
      d_->factor && cholmod_l_factorize(&A, d_->factor, &d_->common) && d_->common.status == CHOLMOD_OK;
  if (!ok) {
    const int status = d_->common.status;
    d_->release();
    delete d_;
    d_ = nullptr;
    throw std::runtime_error("CHOLMOD factorisation of the stiffness matrix failed (status " +
                             std::to_string(status) +
                             (status == CHOLMOD_NOT_POSDEF ? ": not positive definite)" : ")"));
  }
}

CholmodLLT::~CholmodLLT() {
  if (!d_) return;
  d_->release();
  delete d_;
}

void CholmodLLT::solve(double* X, std::size_t k) const {
  if (k == 0 || n_ == 0) return;
  cholmod_dense B{};
  B.nrow = static_cast<std::size_t>(n_);
  B.ncol = k;
  B.nzmax = B.nrow * k;
  B.d = B.nrow;
  B.x = X;
  B.xtype = CHOLMOD_REAL;
  B.dtype = CHOLMOD_DOUBLE;
  if (!cholmod_l_solve2(CHOLMOD_A, d_->factor, &B, nullptr, &d_->x, nullptr, &d_->y, &d_->e, &d_->common))
    throw std::runtime_error("CHOLMOD solve failed (status " + std::to_string(d_->common.status) + ")");
  std::memcpy(X, d_->x->x, sizeof(double) * B.nzmax);
}

}  // namespace vim::fem
