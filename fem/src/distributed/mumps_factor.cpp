// MUMPS through PETSc: an MPIAIJ matrix of the owned rows, MUMPS's Cholesky factor of it (analysis, then
// numerical factorisation), and MatSolve with the kept factor for every right-hand side.
#include "mumps_factor.hpp"

#include <petscmat.h>

#include <cstdio>
#include <stdexcept>
#include <string>

namespace vim::fem {

namespace {

void check(PetscErrorCode e, const char* what) {
  if (e != 0)
    throw std::runtime_error(std::string("MUMPS (PETSc) failed in ") + what + ", error " + std::to_string(e));
}

// PETSc on the already initialised MPI, without its signal handlers (the ranks' own error handling
// stays in place); not finalised (its objects are destroyed before MPI_Finalize).
void ensure_petsc() {
  PetscBool up = PETSC_FALSE;
  check(PetscInitialized(&up), "PetscInitialized");
  if (up) return;
  check(PetscOptionsSetValue(nullptr, "-no_signal_handler", nullptr), "PetscOptionsSetValue");
  check(PetscInitializeNoArguments(), "PetscInitializeNoArguments");
}

std::string megabytes(double bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f MB", bytes / 1e6);
  return text;
}

}  // namespace

struct MumpsFactor::Impl {
  MPI_Comm comm;
  PetscInt n_local = 0, first = 0;
  ::Mat A = nullptr, F = nullptr;
  ::Vec b = nullptr, x = nullptr;
  ~Impl() {
    if (x) VecDestroy(&x);
    if (b) VecDestroy(&b);
    if (F) MatDestroy(&F);
    if (A) MatDestroy(&A);
  }
};

MumpsFactor::MumpsFactor(MPI_Comm comm, long n_global, long first_row, const std::vector<long>& row_ptr,
                         const std::vector<long>& columns, const std::vector<double>& values)
    : impl_(std::make_unique<Impl>()) {
  ensure_petsc();
  Impl& s = *impl_;
  s.comm = comm;
  s.n_local = static_cast<PetscInt>(row_ptr.size() - 1);
  s.first = static_cast<PetscInt>(first_row);
  const long last = first_row + static_cast<long>(s.n_local);
  std::vector<PetscInt> d_nnz(static_cast<std::size_t>(s.n_local), 0), o_nnz(d_nnz.size(), 0);
  for (std::size_t i = 0; i < d_nnz.size(); ++i)
    for (long k = row_ptr[i]; k < row_ptr[i + 1]; ++k)
      ++((columns[k] >= first_row && columns[k] < last) ? d_nnz[i] : o_nnz[i]);
  check(MatCreateAIJ(comm, s.n_local, s.n_local, static_cast<PetscInt>(n_global),
                     static_cast<PetscInt>(n_global), 0, d_nnz.data(), 0, o_nnz.data(), &s.A),
        "MatCreateAIJ");
  std::vector<PetscInt> cols;
  for (std::size_t i = 0; i < d_nnz.size(); ++i) {
    const PetscInt row = s.first + static_cast<PetscInt>(i);
    cols.assign(columns.begin() + row_ptr[i], columns.begin() + row_ptr[i + 1]);
    check(MatSetValues(s.A, 1, &row, static_cast<PetscInt>(cols.size()), cols.data(),
                       values.data() + row_ptr[i], INSERT_VALUES),
          "MatSetValues");
  }
  check(MatAssemblyBegin(s.A, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  check(MatAssemblyEnd(s.A, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  check(MatSetOption(s.A, MAT_SPD, PETSC_TRUE), "MatSetOption");
  check(MatCreateVecs(s.A, &s.x, &s.b), "MatCreateVecs");
}

MumpsFactor::~MumpsFactor() = default;

double MumpsFactor::analyse() {
  Impl& s = *impl_;
  check(MatGetFactor(s.A, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &s.F), "MatGetFactor");
  MatFactorInfo info;
  check(MatFactorInfoInitialize(&info), "MatFactorInfoInitialize");
  check(MatCholeskyFactorSymbolic(s.F, s.A, nullptr, &info), "MatCholeskyFactorSymbolic");
  PetscInt mb = 0;
  check(MatMumpsGetInfog(s.F, 16, &mb), "MatMumpsGetInfog(16)");
  return static_cast<double>(mb) * 1e6;
}

void MumpsFactor::factorise() {
  Impl& s = *impl_;
  MatFactorInfo info;
  check(MatFactorInfoInitialize(&info), "MatFactorInfoInitialize");
  check(MatCholeskyFactorNumeric(s.F, s.A, &info), "MatCholeskyFactorNumeric");
  PetscInt err = 0;
  check(MatMumpsGetInfog(s.F, 1, &err), "MatMumpsGetInfog(1)");
  if (err < 0)
    throw std::runtime_error("MUMPS factorisation failed (INFOG(1) = " + std::to_string(err) +
                             (err == -10 ? ": the matrix is singular or not positive definite)" : ")"));
  check(MatDestroy(&s.A), "MatDestroy");  // back-substitution needs the factor only
}

void MumpsFactor::solve(const double* b, double* x) {
  Impl& s = *impl_;
  PetscScalar* pb = nullptr;
  check(VecGetArray(s.b, &pb), "VecGetArray");
  for (PetscInt i = 0; i < s.n_local; ++i) pb[i] = b[i];
  check(VecRestoreArray(s.b, &pb), "VecRestoreArray");
  check(MatSolve(s.F, s.b, s.x), "MatSolve");
  const PetscScalar* px = nullptr;
  check(VecGetArrayRead(s.x, &px), "VecGetArrayRead");
  for (PetscInt i = 0; i < s.n_local; ++i) x[i] = px[i];
  check(VecRestoreArrayRead(s.x, &px), "VecRestoreArrayRead");
}

std::unique_ptr<MumpsFactor> factorise_if_fits(std::unique_ptr<MumpsFactor> factor, const SolverOptions& opt,
                                               unsigned long n_dofs, unsigned ranks, std::string& reason) {
  const double estimate = factor->analyse();
  const bool fits = opt.max_memory == 0.0 || estimate <= opt.max_memory;
  const std::string limit =
      opt.max_memory == 0.0 ? "no memory limit" : "the limit of " + megabytes(opt.max_memory) + " per rank";
  const std::string what = "MUMPS estimates " + megabytes(estimate) + " per rank to factorise " +
                           std::to_string(n_dofs) + " DoFs on " + std::to_string(ranks) + " ranks";
  const bool direct = opt.type == SolverOptions::Type::direct;
  if (!fits && direct)
    throw std::invalid_argument(
        "solver.type direct: " + what + ", above " + limit +
        " (--max-memory); use solver.type auto or amg, more ranks or a larger --max-memory");
  reason = std::string(direct ? "solver.type direct: " : "solver.type auto: ") + what +
           (fits ? ", within " : ", above ") + limit + (fits ? "" : ": CG + AMG");
  if (!fits) return nullptr;
  factor->factorise();
  return factor;
}

}  // namespace vim::fem
