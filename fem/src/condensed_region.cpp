// The tissue condensed onto a region (vim/fem/condensed_region.hpp).
#include <deal.II/fe/fe_system.h>

#include <algorithm>
#include <stdexcept>
#include <unordered_map>
#include <vim/fem/condensed_region.hpp>

#include "model_state.hpp"

namespace vim::fem {

using namespace dealii;
using State3 = ModelAccess::State<3>;

struct CondensedRegion::Impl {
  const State3* m = nullptr;
  const CellLocator<3>* locator = nullptr;
  std::vector<types::global_dof_index> slot_dof;  // region slot → free DoF
  std::vector<int> region_cell;                   // locator cell → region cell or −1
  std::vector<Eigen::Matrix3d> jinv;              // per region cell: x − v0 → unit point
  std::vector<Vec<3>> v0;
  std::vector<std::size_t> dof_first;  // per region cell: its local DoFs' terms, [dof_first[c·n+i], …)
  std::vector<Term> terms;
  unsigned dofs_per_cell = 0;
  Eigen::MatrixXd W;  // K⁻¹ on the slots
  Eigen::VectorXd u0;

  void build_region(const Region<3>& region, const std::vector<Vec<3>>& points);
  void condense(const SolverOptions& solver, ElasticModel<3>& model);
};

namespace {

// The free-DoF terms of a DoF: itself, or its constraint's entries and inhomogeneity.
void dof_terms(const State3& m, types::global_dof_index dof,
               std::unordered_map<types::global_dof_index, int>& slot,
               std::vector<types::global_dof_index>& slot_dof, std::vector<CondensedRegion::Term>& out) {
  const auto add = [&](types::global_dof_index f, double a) {
    auto [it, fresh] = slot.emplace(f, static_cast<int>(slot_dof.size()));
    if (fresh) slot_dof.push_back(f);
    out.push_back({it->second, a});
  };
  if (const auto* entries = m.constraints.get_constraint_entries(dof)) {
    out.push_back({-1, m.constraints.get_inhomogeneity(dof)});
    for (const auto& [f, a] : *entries) add(f, a);
  } else if (m.constraints.is_constrained(dof)) {
    out.push_back({-1, m.constraints.get_inhomogeneity(dof)});
  } else {
    add(dof, 1.0);
  }
}

}  // namespace

void CondensedRegion::Impl::build_region(const Region<3>& region, const std::vector<Vec<3>>& points) {
  std::vector<bool> chosen(m->E.size(), false);
  for (const auto& p : points) {
    const long c = locator->locate(p);
    if (c < 0) throw std::invalid_argument("HapticNeedle: a probe lies outside the mesh");
    chosen[static_cast<std::size_t>(c)] = true;
  }
  std::unordered_map<types::global_dof_index, int> slot;
  region_cell.assign(m->E.size(), -1);
  dofs_per_cell = m->fe->n_dofs_per_cell();
  std::vector<types::global_dof_index> idx(dofs_per_cell);
  for (const auto& cell : m->dof.active_cell_iterators()) {
    Vec<3> mid = Vec<3>::Zero();
    for (unsigned v = 0; v < cell->n_vertices(); ++v) mid += to_vec<3>(cell->vertex(v)) / cell->n_vertices();
    const auto id = static_cast<std::size_t>(cell->material_id());
    if (!chosen[id] && !region.contains(mid)) continue;
    region_cell[id] = static_cast<int>(v0.size());
    v0.push_back(to_vec<3>(cell->vertex(0)));
    Eigen::Matrix3d J;
    for (int k = 0; k < 3; ++k) J.col(k) = to_vec<3>(cell->vertex(k + 1)) - v0.back();
    jinv.push_back(J.inverse());
    cell->get_dof_indices(idx);
    for (unsigned i = 0; i < dofs_per_cell; ++i) {
      dof_first.push_back(terms.size());
      dof_terms(*m, idx[i], slot, slot_dof, terms);
    }
  }
  dof_first.push_back(terms.size());
}

void CondensedRegion::Impl::condense(const SolverOptions& solver, ElasticModel<3>& model) {
  auto& state = ModelAccess::state(model);
  const std::size_t nd = state.dof.n_dofs(), ns = slot_dof.size();
  W.resize(static_cast<Eigen::Index>(ns), static_cast<Eigen::Index>(ns));
  u0.resize(static_cast<Eigen::Index>(ns));
  for (std::size_t s = 0; s < ns; ++s) u0[static_cast<Eigen::Index>(s)] = state.u0[slot_dof[s]];
  constexpr std::size_t block = 32;
  std::vector<double> B;
  Vector<double> e(nd), x(nd);
  for (std::size_t first = 0; first < ns; first += block) {
    const std::size_t k = std::min(block, ns - first);
    if (state.direct) {
      B.assign(nd * k, 0.0);
      for (std::size_t j = 0; j < k; ++j) B[j * nd + slot_dof[first + j]] = 1.0;
      state.direct->solve(B.data(), k);
    }
    for (std::size_t j = 0; j < k; ++j) {
      const double* col = B.data() + j * nd;
      if (!state.direct) {
        e = 0.0;
        e[slot_dof[first + j]] = 1.0;
        state.apply_inverse(e, x, solver);
        col = x.begin();
      }
      for (std::size_t s = 0; s < ns; ++s)
        W(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(first + j)) = col[slot_dof[s]];
    }
  }
}

CondensedRegion::CondensedRegion(ElasticModel<3>& model, const Region<3>& region,
                                 const std::vector<Vec<3>>& points, const SolverOptions& solver)
    : impl_(std::make_unique<Impl>()) {
  auto& m = ModelAccess::state(model);
  if (m.voxel) throw std::invalid_argument("HapticNeedle: simplex models only");
  if (m.solves_over_ranks())
    throw std::invalid_argument(
        "HapticNeedle: the model's solves run over MPI ranks (distribute_solves); haptic stepping is serial");
  m.ensure_mesh();
  m.prepare_solver(solver);
  m.ensure_u0(solver);
  impl_->m = &m;
  impl_->locator = &model.locator();
  impl_->build_region(region, points);
  impl_->condense(solver, model);
}

CondensedRegion::~CondensedRegion() = default;
CondensedRegion::CondensedRegion(CondensedRegion&&) noexcept = default;

std::size_t CondensedRegion::slots() const { return impl_->slot_dof.size(); }
const Eigen::MatrixXd& CondensedRegion::inverse() const { return impl_->W; }
const Eigen::VectorXd& CondensedRegion::u0() const { return impl_->u0; }
long CondensedRegion::locate(const Vec<3>& x) const { return impl_->locator->locate(x); }

void CondensedRegion::terms(const Vec<3>& x, double w, unsigned d, std::vector<Term>& out) const {
  const Impl& h = *impl_;
  const long c = h.locator->locate(x);
  const int rc = c < 0 ? -1 : h.region_cell[static_cast<std::size_t>(c)];
  if (rc < 0) throw std::invalid_argument("HapticNeedle: the needle's band left the precomputed region");
  const Vec<3> xi = h.jinv[static_cast<std::size_t>(rc)] * (x - h.v0[static_cast<std::size_t>(rc)]);
  const Point<3> unit(xi[0], xi[1], xi[2]);
  for (unsigned i = 0; i < h.dofs_per_cell; ++i) {
    const auto [comp, k] = h.m->fe->system_to_component_index(i);
    if (comp != d) continue;
    const double v = w * h.m->fe->base_element(0).shape_value(k, unit);
    const std::size_t at = static_cast<std::size_t>(rc) * h.dofs_per_cell + i;
    for (std::size_t t = h.dof_first[at]; t < h.dof_first[at + 1]; ++t)
      out.push_back({h.terms[t].slot, v * h.terms[t].coef});
  }
}

long CondensedRegion::terms(const Vec<3>& x, double w, std::array<std::vector<Term>, 3>& out) const {
  const Impl& h = *impl_;
  const long c = h.locator->locate(x);
  if (c < 0) return -1;
  const int rc = h.region_cell[static_cast<std::size_t>(c)];
  if (rc < 0) throw std::invalid_argument("HapticNeedle: the needle's band left the precomputed region");
  const Vec<3> xi = h.jinv[static_cast<std::size_t>(rc)] * (x - h.v0[static_cast<std::size_t>(rc)]);
  const Point<3> unit(xi[0], xi[1], xi[2]);
  const FiniteElement<3>& base = h.m->fe->base_element(0);
  constexpr unsigned kMaxScalar = 64;  // scalar shape functions cached per call (P1 4, P2 10, P3 20)
  std::array<double, kMaxScalar> value{};
  const unsigned n_scalar = base.n_dofs_per_cell();
  for (unsigned k = 0; k < n_scalar && k < kMaxScalar; ++k) value[k] = w * base.shape_value(k, unit);
  for (unsigned i = 0; i < h.dofs_per_cell; ++i) {
    const auto [comp, k] = h.m->fe->system_to_component_index(i);
    const double v = k < kMaxScalar ? value[k] : w * base.shape_value(k, unit);
    const std::size_t at = static_cast<std::size_t>(rc) * h.dofs_per_cell + i;
    for (std::size_t t = h.dof_first[at]; t < h.dof_first[at + 1]; ++t)
      out[comp].push_back({h.terms[t].slot, v * h.terms[t].coef});
  }
  return c;
}

}  // namespace vim::fem
