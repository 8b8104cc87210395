// Finite-strain statics on an ElasticModel: the compressible neo-Hookean solid of CalculiX
// (W = C10 (Ī₁ − 3) + (J − 1)²/D₁, C10 = μ/2, D₁ = 2/K from each cell's E and the model's ν),
// total Lagrangian, solved by Newton's method with a line search and adaptive load stepping
// (docs/finite-strain.md). The model's conditions are its loads: Dirichlet values, surface loads
// (traction and pressure as dead loads: on the reference faces, in fixed directions) and the body force
// scale with the load factor t ∈ (0, 1]; volume supports stay linear springs. deal.II-free.
#pragma once

#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>
#include <vim/fem/model.hpp>

namespace vim::fem {

struct NewtonOptions {
  // A load step has converged when ‖r‖ ≤ tolerance · ‖r₀‖ (r the residual on the free DoFs, r₀ the one
  // of the step's first iteration, which carries the step's load increment).
  double tolerance = 1e-10;
  unsigned max_iterations = 25;  // per load step
  unsigned initial_steps = 1;    // equal load steps to start with
  unsigned max_halvings = 10;    // a step that fails is halved at most this many times in a row
};

// One converged load step: its load factor and, per Newton iteration, the residual norm ‖r‖ on the
// free DoFs before the iteration (for the first: ‖r₀‖, which carries the step's load increment), the
// norm of the update taken and its line-search factor; residual_norm ends with the converged ‖r‖.
struct LoadStepRecord {
  double load_factor = 0.0;
  std::vector<double> residual_norm, update_norm, line_search;
};

template <int dim>
struct FiniteStrainSolution {
  // vertex_displacement as in the linear solve; cell_strain the Green–Lagrange strain ½(FᵀF − I),
  // cell_stress the Cauchy stress σ = P Fᵀ/J and von_mises its, at the centroid; strain_energy ∫ W dV;
  // dirichlet_reaction the internal force summed over each condition's DoFs (minus the dead loads).
  Solution<dim> solution;
  std::vector<LoadStepRecord> steps;
  unsigned newton_iterations = 0, halvings = 0;
};

// The load step that failed after max_halvings halvings (its load factors in the message).
struct NewtonFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Solves the model's conditions on the neo-Hookean material from the undeformed state (simplex P1/P2
// and voxel models, serial, no point constraints). The model's sample() and edge_midpoint_displacement()
// then give the finite-strain field. Throws SingularConstraints as solve() does, NewtonFailure.
template <int dim>
FiniteStrainSolution<dim> solve_neo_hookean(ElasticModel<dim>& model, const NewtonOptions& options = {});

// For checks on small models: the residual r(u) = f_int(u) + K_s u − t f_ext of every DoF (the model's
// DoF numbering, no condition eliminated) and its tangent ∂r/∂u, dense.
template <int dim>
void neo_hookean_system(ElasticModel<dim>& model, const Eigen::VectorXd& u, double load_factor,
                        Eigen::VectorXd& residual, Eigen::MatrixXd& tangent);

}  // namespace vim::fem
