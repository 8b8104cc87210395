// ElasticModel::edge_midpoint_displacement: the last solution evaluated at edge midpoints through the
// cell's own shape functions on the reference simplex (no point location: an edge's midpoint is the
// midpoint of two reference vertices of every cell that holds the edge).
#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>

#include "elasticity_impl.hpp"

namespace vim::fem {

template <int dim>
std::vector<Vec<dim>> ElasticModel<dim>::edge_midpoint_displacement(
    const std::vector<std::array<int, 2>>& edges) const {
  const Impl& m = *impl_;
  if (m.voxel) throw std::invalid_argument("edge_midpoint_displacement: simplex models only");
  if (!m.have_solution)
    throw std::runtime_error("edge_midpoint_displacement: no solution yet; call solve() first");
  std::map<std::pair<unsigned, unsigned>, std::size_t> wanted;
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const auto [a, b] = edges[e];
    wanted[{static_cast<unsigned>(std::min(a, b)), static_cast<unsigned>(std::max(a, b))}] = e;
  }
  std::vector<Vec<dim>> out(edges.size(), Vec<dim>::Zero());
  std::vector<bool> found(edges.size(), false);
  const dealii::FiniteElement<dim>& fe = *m.fe;
  std::vector<dealii::types::global_dof_index> idx(fe.n_dofs_per_cell());
  for (const auto& cell : m.dof.active_cell_iterators()) {
    cell->get_dof_indices(idx);
    for (unsigned a = 0; a < cell->n_vertices(); ++a)
      for (unsigned b = a + 1; b < cell->n_vertices(); ++b) {
        const unsigned va = cell->vertex_index(a), vb = cell->vertex_index(b);
        const auto it = wanted.find({std::min(va, vb), std::max(va, vb)});
        if (it == wanted.end() || found[it->second]) continue;
        const dealii::ReferenceCell ref = cell->reference_cell();
        const dealii::Point<dim> mid = 0.5 * (ref.template vertex<dim>(a) + ref.template vertex<dim>(b));
        Vec<dim> v = Vec<dim>::Zero();
        for (unsigned j = 0; j < idx.size(); ++j)
          v[fe.system_to_component_index(j).first] += m.u[idx[j]] * fe.shape_value(j, mid);
        out[it->second] = v;
        found[it->second] = true;
      }
  }
  for (std::size_t e = 0; e < edges.size(); ++e)
    if (!found[e])
      throw std::invalid_argument("edge_midpoint_displacement: vertices " + std::to_string(edges[e][0]) +
                                  " and " + std::to_string(edges[e][1]) + " are not an edge of the mesh");
  return out;
}

template std::vector<Vec<2>> ElasticModel<2>::edge_midpoint_displacement(
    const std::vector<std::array<int, 2>>&) const;
template std::vector<Vec<3>> ElasticModel<3>::edge_midpoint_displacement(
    const std::vector<std::array<int, 2>>&) const;

}  // namespace vim::fem
