// The axial stiffness map of the active shaft points (vim/needle/axial_map.hpp).
#include <Eigen/Dense>
#include <stdexcept>
#include <vim/needle/axial_map.hpp>

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

void AxialMap::solve_free(Eigen::VectorXd& w, const std::vector<bool>& free,
                          const Eigen::VectorXd& target) const {
  std::vector<Eigen::Index> f, n;
  for (Eigen::Index j = 0; j < w.size(); ++j) (free[j] ? f : n).push_back(j);
  if (f.empty()) return;
  Eigen::MatrixXd kff(f.size(), f.size());
  Eigen::VectorXd rhs(f.size());
  for (std::size_t a = 0; a < f.size(); ++a) {
    rhs[a] = target[f[a]] - c[f[a]];
    for (Eigen::Index j : n) rhs[a] -= K(f[a], j) * w[j];
    for (std::size_t b = 0; b < f.size(); ++b) kff(a, b) = K(f[a], f[b]);
  }
  const Eigen::VectorXd x = kff.ldlt().solve(rhs);
  for (std::size_t a = 0; a < f.size(); ++a) w[f[a]] = x[a];
}

}  // namespace vim::needle
