// Internal to vim_fem: CHOLMOD's sparse Cholesky factorisation K = L Lᵀ of the symmetric positive
// definite stiffness matrix (Dirichlet DoFs eliminated), factorised once, then solves for one or many
// right-hand sides. Supernodal Cholesky with a fill-reducing ordering: several times faster to
// factorise and to back-substitute than UMFPACK's LU of the same K (docs/performance.md). A pattern's
// analysis (the ordering and the symbolic factor) can be kept and reused by every factorisation of a
// matrix with that pattern (the Newton tangents of a fixed mesh). deal.II-free.
#pragma once

#include <cstddef>
#include <vector>

namespace vim::fem {

// The analysis of one sparsity pattern: the fill-reducing ordering and the symbolic factor, computed
// once. The pattern is the upper triangle in compressed columns (n columns, Ap[n] entries, rows sorted).
class CholmodAnalysis {
 public:
  CholmodAnalysis(long n, std::vector<long> Ap, std::vector<long> Ai);
  ~CholmodAnalysis();
  CholmodAnalysis(const CholmodAnalysis&) = delete;
  CholmodAnalysis& operator=(const CholmodAnalysis&) = delete;

  long size() const { return n_; }
  std::size_t n_entries() const { return Ai_.size(); }

 private:
  friend class CholmodLLT;
  struct Data;
  long n_ = 0;
  std::vector<long> Ap_, Ai_;
  Data* d_ = nullptr;
};

class CholmodLLT {
 public:
  // K in compressed columns (n columns, Ap[n] entries; all of the symmetric K or its upper triangle:
  // only entries with row ≤ column are read). Throws std::runtime_error when K is not positive
  // definite (e.g. a rigid-body mode left free) or CHOLMOD fails.
  CholmodLLT(long n, const std::vector<long>& Ap, const std::vector<long>& Ai, const std::vector<double>& Ax);
  // K with the analysed pattern, Ax its values in the pattern's order: the factor the constructor above
  // gives for that pattern, without redoing the ordering and the symbolic analysis (the factor starts
  // from a copy of the analysis's symbolic factor). Throws as above.
  CholmodLLT(const CholmodAnalysis& analysis, const std::vector<double>& Ax);
  ~CholmodLLT();
  CholmodLLT(const CholmodLLT&) = delete;
  CholmodLLT& operator=(const CholmodLLT&) = delete;

  long size() const { return n_; }
  // In place: the n × k column-major block X ← K⁻¹ X (k right-hand sides in one sweep through L).
  void solve(double* X, std::size_t k = 1) const;

 private:
  struct Data;
  // Factorises K (its upper triangle with the given arrays) into d_->factor, analysed unless given.
  void factorise(const std::vector<long>& Ap, const std::vector<long>& Ai, const std::vector<double>& Ax,
                 const CholmodAnalysis* analysis);
  long n_ = 0;
  Data* d_ = nullptr;
};

}  // namespace vim::fem
