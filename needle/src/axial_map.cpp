// The axial stiffness map of the active shaft points (vim/needle/axial_map.hpp).
#include <Eigen/Cholesky>
#include <stdexcept>
#include <vim/needle/axial_map.hpp>
#include <vim/needle/tissue_response.hpp>

namespace vim::needle {

AxialMap AxialMap::probe(Eigen::Index m, const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& forces,
                         double sigma) {
  if (!(sigma > 0.0)) throw std::invalid_argument("AxialMap::probe: sigma must be > 0");
  AxialMap map;
  map.c = forces(Eigen::VectorXd::Zero(m));
  map.K.resize(m, m);
  for (Eigen::Index j = 0; j < m; ++j) {
    Eigen::VectorXd e = Eigen::VectorXd::Zero(m);
    e[j] = sigma;
    map.K.col(j) = (forces(e) - map.c) / sigma;
  }
  map.K = (0.5 * (map.K + map.K.transpose())).eval();  // symmetric up to round-off
  return map;
}

void AxialMap::Work::reserve(Eigen::Index m) {
  if (kff.rows() < m) kff.resize(m, m), rhs.resize(m);
  free.reserve(static_cast<std::size_t>(m)), held.reserve(static_cast<std::size_t>(m));
}

void AxialMap::apply(const Eigen::Ref<const Eigen::VectorXd>& w, Eigen::Ref<Eigen::VectorXd> f) const {
  const Eigen::Index m = w.size();
  f.noalias() = K.topLeftCorner(m, m) * w;
  f += c.head(m);
}

void AxialMap::solve_free(Eigen::Ref<Eigen::VectorXd> w, const std::vector<bool>& free,
                          const Eigen::Ref<const Eigen::VectorXd>& target, Work& work) const {
  work.reserve(w.size());
  work.free.clear(), work.held.clear();
  for (Eigen::Index j = 0; j < w.size(); ++j)
    (free[static_cast<std::size_t>(j)] ? work.free : work.held).push_back(j);
  const auto nf = static_cast<Eigen::Index>(work.free.size());
  if (nf == 0) return;
  auto rhs = work.rhs.head(nf);
  for (Eigen::Index a = 0; a < nf; ++a) {
    const Eigen::Index fa = work.free[static_cast<std::size_t>(a)];
    rhs[a] = target[fa] - c[fa];
    for (Eigen::Index j : work.held) rhs[a] -= K(fa, j) * w[j];
    for (Eigen::Index b = 0; b <= a; ++b) work.kff(a, b) = K(fa, work.free[static_cast<std::size_t>(b)]);
  }
  // K is symmetric positive definite, so is its free block: Cholesky in place on the work block.
  Eigen::Ref<Eigen::MatrixXd> kff = work.kff.topLeftCorner(nf, nf);
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Lower> llt(kff);
  if (llt.info() != Eigen::Success)
    throw std::runtime_error("AxialMap::solve_free: the free points' stiffness is not positive definite");
  llt.solveInPlace(rhs);
  for (Eigen::Index a = 0; a < nf; ++a) w[work.free[static_cast<std::size_t>(a)]] = rhs[a];
}

AxialMap probe_axial_map(TissueResponse& tissue, const ShaftState& state, std::size_t n_points, double step) {
  return AxialMap::probe(
      static_cast<Eigen::Index>(state.active.size()),
      [&](const Eigen::VectorXd& wc) {
        std::vector<double> full(n_points, 0.0);
        state.expand(wc, full);
        return state.compact(tissue.solve(full));
      },
      step);
}

}  // namespace vim::needle
