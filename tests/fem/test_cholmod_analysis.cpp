// CHOLMOD with a kept analysis (fem/src/cholmod_llt.hpp): one analysis of a sparsity pattern serves
// the factorisations of several matrices with that pattern (the Newton tangents of a fixed mesh).
// Truth: a fresh analysis and factorisation of each matrix, and Eigen's dense Cholesky.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <stdexcept>
#include <vector>

#include "../../fem/src/cholmod_llt.hpp"

using namespace vim::fem;

namespace {

// An SPD matrix on the graph of an n×n×n grid (the 6 neighbours and the diagonal): random positive edge
// weights w, K = Laplacian(w) + diag(shift); its upper triangle in compressed columns.
struct GridMatrix {
  long n = 0;
  std::vector<long> Ap, Ai;
  std::vector<double> Ax;
  Eigen::MatrixXd dense;
};

GridMatrix grid_matrix(int side, unsigned seed, double shift) {
  const long n = static_cast<long>(side) * side * side;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> weight(0.5, 2.0);
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n, n);
  const auto id = [side](int x, int y, int z) { return (static_cast<long>(z) * side + y) * side + x; };
  for (int z = 0; z < side; ++z)
    for (int y = 0; y < side; ++y)
      for (int x = 0; x < side; ++x) {
        const long a = id(x, y, z);
        K(a, a) += shift;
        const long next[3] = {x + 1 < side ? id(x + 1, y, z) : -1, y + 1 < side ? id(x, y + 1, z) : -1,
                              z + 1 < side ? id(x, y, z + 1) : -1};
        for (const long b : next) {
          if (b < 0) continue;
          const double w = weight(rng);
          K(a, a) += w, K(b, b) += w, K(a, b) -= w, K(b, a) -= w;
        }
      }
  GridMatrix g;
  g.n = n;
  g.dense = K;
  g.Ap.push_back(0);
  for (long c = 0; c < n; ++c) {  // the pattern: the grid's, whatever the values
    for (long r = 0; r <= c; ++r)
      if (r == c || K(r, c) != 0.0) g.Ai.push_back(r), g.Ax.push_back(K(r, c));
    g.Ap.push_back(static_cast<long>(g.Ai.size()));
  }
  return g;
}

Eigen::VectorXd solve(const CholmodLLT& f, const Eigen::VectorXd& b) {
  Eigen::VectorXd x = b;
  f.solve(x.data());
  return x;
}

}  // namespace

// Two matrices of one pattern factorised with one kept analysis: each solution equals the fresh
// factorisation's and the dense Cholesky's to 1e-12 (relative).
TEST(CholmodAnalysis, KeptAnalysisGivesTheFreshFactorisationsSolutions) {
  const GridMatrix a = grid_matrix(12, 1, 0.1), b = grid_matrix(12, 2, 0.01);
  ASSERT_EQ(a.Ai, b.Ai);
  const CholmodAnalysis analysis(a.n, a.Ap, a.Ai);
  EXPECT_EQ(analysis.size(), a.n);
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  for (const GridMatrix* m : {&a, &b, &a}) {
    Eigen::VectorXd rhs(m->n);
    for (auto& v : rhs) v = normal(rng);
    const Eigen::VectorXd kept = solve(CholmodLLT(analysis, m->Ax), rhs);
    const Eigen::VectorXd fresh = solve(CholmodLLT(m->n, m->Ap, m->Ai, m->Ax), rhs);
    const Eigen::VectorXd dense = m->dense.llt().solve(rhs);
    EXPECT_LT((kept - fresh).norm(), 1e-12 * fresh.norm());
    EXPECT_LT((kept - dense).norm(), 1e-12 * dense.norm());
    EXPECT_LT((m->dense * kept - rhs).norm(), 1e-10 * rhs.norm());
  }
}

// A matrix of the pattern that is not positive definite throws, as the fresh factorisation does (the
// grid is large enough for the supernodal LLᵀ, which meets the negative pivot); the analysis then
// serves the next matrix.
TEST(CholmodAnalysis, IndefiniteMatrixThrowsAndTheAnalysisStaysUsable) {
  const GridMatrix a = grid_matrix(12, 4, 0.1);
  const CholmodAnalysis analysis(a.n, a.Ap, a.Ai);
  std::vector<double> indefinite = a.Ax;
  for (long c = 0; c < a.n; ++c) indefinite[static_cast<std::size_t>(a.Ap[c + 1] - 1)] *= -1.0;  // diagonals
  EXPECT_THROW(CholmodLLT(a.n, a.Ap, a.Ai, indefinite), std::runtime_error);
  EXPECT_THROW(CholmodLLT(analysis, indefinite), std::runtime_error);
  EXPECT_THROW(CholmodLLT(analysis, std::vector<double>(3, 1.0)), std::invalid_argument);
  Eigen::VectorXd rhs = Eigen::VectorXd::LinSpaced(a.n, -1.0, 2.0);
  const Eigen::VectorXd x = solve(CholmodLLT(analysis, a.Ax), rhs);
  EXPECT_LT((a.dense * x - rhs).norm(), 1e-10 * rhs.norm());
}
