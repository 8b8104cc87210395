// Internal to vim_fem: CHOLMOD's sparse Cholesky factorisation K = L Lᵀ of the symmetric positive
// definite stiffness matrix (Dirichlet DoFs eliminated), factorised once, then solves for one or many
// right-hand sides. Supernodal Cholesky with a fill-reducing ordering: several times faster to
// factorise and to back-substitute than UMFPACK's LU of the same K (docs/performance.md). deal.II-free.
#pragma once

#include <cstddef>
#include <vector>

namespace vim::fem {

class CholmodLLT {
 public:
  // K in compressed columns (n columns, Ap[n] entries; all of the symmetric K or its upper triangle:
  // only entries with row ≤ column are read). Throws std::runtime_error when K is not positive
  // definite (e.g. a rigid-body mode left free) or CHOLMOD fails.
  CholmodLLT(long n, const std::vector<long>& Ap, const std::vector<long>& Ai, const std::vector<double>& Ax);
  ~CholmodLLT();
  CholmodLLT(const CholmodLLT&) = delete;
  CholmodLLT& operator=(const CholmodLLT&) = delete;

  long size() const { return n_; }
  // In place: the n × k column-major block X ← K⁻¹ X (k right-hand sides in one sweep through L).
  void solve(double* X, std::size_t k = 1) const;

 private:
  struct Data;
  long n_ = 0;
  Data* d_ = nullptr;
};

}  // namespace vim::fem
