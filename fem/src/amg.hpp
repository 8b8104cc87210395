// Internal to vim_fem: the CG preconditioner for elasticity (serial and MPI solves), ML AMG with the
// rigid-body modes at the DoF support points as a pre-computed null space.
#pragma once

#include <Epetra_MultiVector.h>
#include <deal.II/base/point.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>

#include <Teuchos_ParameterList.hpp>
#include <functional>
#include <memory>

namespace vim::fem {

// Sets up `amg` for K; support_of_local / component_of_local give the support point and vector
// component of each locally owned DoF (local index).
// Linear elements (P1 simplices, Q1 voxel hexahedra): unsmoothed aggregation (damping factor 0),
// aggregation threshold 0, W-cycle; Chebyshev degree 1 on voxel grids (81 nonzeros per row), 2 on
// simplices. Voxel 50³ grid (398k DoFs, 2 ranks): smoothed aggregation (threshold 0.02, degree 2)
// took 37 CG iterations but a ~2.5x longer set-up and 1.43x the peak memory (1.05 vs 0.73 GB per
// rank; the 100³ grid ran out of memory with it); the unsmoothed hierarchy takes 66 iterations
// (V-cycle) / 53 (W-cycle) and is faster overall. P1 Kuhn 68³ (985k DoFs, 2 ranks): smoothed
// aggregation (threshold 0.02) set-up 10.8 s + CG 7.6 s (62 iterations), threshold 0 13.0 + 5.0 s
// (38), unsmoothed V-cycle 2.5 + 9.1 s (102), unsmoothed W-cycle 2.7 + 6.4 s (62), with 18 % less
// peak memory (docs/performance.md). P2 keeps smoothed aggregation (threshold 0.02, degree 2,
// V-cycle), not re-measured.
template <int dim>
inline void amg_setup(const dealii::TrilinosWrappers::SparseMatrix& K,
                      const std::function<dealii::Point<dim>(unsigned)>& support_of_local,
                      const std::function<unsigned(unsigned)>& component_of_local, unsigned degree,
                      bool voxel_grid, dealii::TrilinosWrappers::PreconditionAMG& amg) {
  const bool unsmoothed = degree == 1;
  constexpr int nm = dim == 2 ? 3 : 6;
  dealii::TrilinosWrappers::PreconditionAMG::AdditionalData data;
  data.elliptic = true;
  data.higher_order_elements = degree > 1;
  data.smoother_sweeps = voxel_grid ? 1 : 2;
  data.aggregation_threshold = unsmoothed ? 0.0 : 0.02;
  data.w_cycle = unsmoothed;
  Teuchos::ParameterList pl;
  std::unique_ptr<Epetra_MultiVector> unused;
  data.set_parameters(pl, unused, K);
  if (unsmoothed) pl.set("aggregation: damping factor", 0.0);
  Epetra_MultiVector nsp(K.trilinos_matrix().DomainMap(), nm);
  const int n_local = K.trilinos_matrix().DomainMap().NumMyElements();
  for (int i = 0; i < n_local; ++i) {
    const dealii::Point<dim> x = support_of_local(static_cast<unsigned>(i));
    const unsigned c = component_of_local(static_cast<unsigned>(i));
    for (int k = 0; k < nm; ++k) nsp[k][i] = 0.0;
    nsp[c][i] = 1.0;
    if constexpr (dim == 2) {
      nsp[2][i] = c == 0 ? -x[1] : x[0];
    } else {
      const double rot[3][3] = {{0.0, x[2], -x[1]}, {-x[2], 0.0, x[0]}, {x[1], -x[0], 0.0}};
      for (int a = 0; a < 3; ++a) nsp[3 + a][i] = rot[a][c];
    }
  }
  pl.set("null space: type", "pre-computed");
  pl.set("null space: dimension", nm);
  pl.set("null space: vectors", nsp.Values());
  pl.set("null space: add default vectors", false);
  pl.set("PDE equations", dim);
  amg.initialize(K, pl);
}

}  // namespace vim::fem
