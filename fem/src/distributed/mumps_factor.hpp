// Internal to vim_fem: MUMPS's sparse Cholesky factorisation of a symmetric positive definite matrix
// distributed by rows over the ranks of a communicator, through PETSc's C API (no deal.II), factorised
// once and reused for every right-hand side (distributed.cpp).
#pragma once

#include <mpi.h>

#include <memory>
#include <string>
#include <vector>

#include "vim/fem/model.hpp"

namespace vim::fem {

class MumpsFactor {
 public:
  // The rows [first_row, first_row + n_local) of the symmetric n_global × n_global matrix, on the calling
  // rank, in CSR form (row_ptr of size n_local + 1, global column indices, both triangles). Collective.
  MumpsFactor(MPI_Comm comm, long n_global, long first_row, const std::vector<long>& row_ptr,
              const std::vector<long>& columns, const std::vector<double>& values);
  ~MumpsFactor();
  MumpsFactor(const MumpsFactor&) = delete;
  MumpsFactor& operator=(const MumpsFactor&) = delete;

  // MUMPS's analysis (ordering, symbolic factorisation). Returns its estimate of the memory of the
  // numerical factorisation in core, in bytes: the largest over the ranks (INFOG(16)). Collective.
  double analyse();
  // The numerical factorisation (after analyse()); std::runtime_error if the matrix is not positive
  // definite or MUMPS fails. Collective.
  void factorise();
  // x = A⁻¹ b on the owned rows (n_local entries each) by back-substitution. Collective.
  void solve(const double* b, double* x);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The solver choice of `opt` for a factor of n_dofs DoFs over `ranks` ranks: analyses `factor` and, when
// MUMPS's estimate fits opt.max_memory, factorises and returns it; returns nullptr when `automatic` falls
// back to CG + AMG. Sets `reason` (the estimate and the limit). Throws std::invalid_argument, one line
// with the estimate, before any factorisation when type `direct` does not fit. Collective.
std::unique_ptr<MumpsFactor> factorise_if_fits(std::unique_ptr<MumpsFactor> factor, const SolverOptions& opt,
                                               unsigned long n_dofs, unsigned ranks, std::string& reason);

}  // namespace vim::fem
