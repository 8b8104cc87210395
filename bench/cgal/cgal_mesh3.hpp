// CGAL Mesh_3 on a labelled image, shared by the VIM-vs-CGAL benches (docs/cgal_comparison.md): the
// in-memory CGAL::Image_3 of a vim::Image, the criteria with one size parameter s, the refinement-only
// tuning of s to a node count, and the extraction of the meshed cells as a vim::SimplexMesh with
// CGAL's subdomain index per cell.
#pragma once

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Image_3.h>
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/make_mesh_3.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <vector>
#include <vim/initial_mesh.hpp>

namespace vim::cgal_bench {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh_domain = CGAL::Labeled_mesh_domain_3<K>;
using Tr = CGAL::Mesh_triangulation_3<Mesh_domain, CGAL::Default, CGAL::Sequential_tag>::type;
using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr>;
using Mesh_criteria = CGAL::Mesh_criteria_3<Tr>;
namespace params = CGAL::parameters;

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// CGAL::Image_3 from the vim image: one unsigned byte per voxel, label_of(value) (1..255; CGAL meshes
// only non-zero labels). CGAL places voxel (i,j,k) at (i·vx + tx, ...): tx = the vim origin (first
// voxel centre).
template <class LabelOf>
CGAL::Image_3 labeled_image(const vim::Image<3>& image, LabelOf&& label_of) {
  _image* im = ::_createImage(image.size[0], image.size[1], image.size[2], 1, image.spacing[0],
                              image.spacing[1], image.spacing[2], 1, WK_FIXED, SGN_UNSIGNED);
  im->tx = static_cast<float>(image.origin[0]);
  im->ty = static_cast<float>(image.origin[1]);
  im->tz = static_cast<float>(image.origin[2]);
  auto* data = static_cast<unsigned char*>(im->data);
  for (std::size_t k = 0; k < image.voxel_count(); ++k) {
    const auto i = image.index_of(k);
    const std::size_t lin =
        static_cast<std::size_t>(i[0]) +
        static_cast<std::size_t>(image.size[0]) *
            (static_cast<std::size_t>(i[1]) + static_cast<std::size_t>(image.size[1]) * i[2]);
    data[lin] = static_cast<unsigned char>(label_of(image.data[k]));
  }
  return CGAL::Image_3(im);
}

struct CgalMesh {
  vim::SimplexMesh<3> mesh;
  std::vector<int> subdomain;
};

inline CgalMesh extract(const C3t3& c3t3) {
  CgalMesh out;
  std::map<Tr::Vertex_handle, int> index;
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c) {
    std::array<int, 4> cell;
    for (int k = 0; k < 4; ++k) {
      const auto v = c->vertex(k);
      auto [it, fresh] = index.emplace(v, static_cast<int>(out.mesh.points.size()));
      if (fresh) {
        const auto& p = v->point();
        out.mesh.points.emplace_back(CGAL::to_double(p.x()), CGAL::to_double(p.y()), CGAL::to_double(p.z()));
      }
      cell[k] = it->second;
    }
    out.mesh.cells.push_back(cell);
    out.subdomain.push_back(static_cast<int>(c3t3.subdomain_index(c)));
  }
  vim::orient_positively<3>(out.mesh);
  return out;
}

// facet_size = cell_size = s, facet_distance = s/4, facet_angle = 25, cell_radius_edge_ratio = 3.
inline Mesh_criteria criteria_for(double s) {
  return Mesh_criteria(params::facet_angle = 25, params::facet_size = s, params::facet_distance = s / 4,
                       params::cell_radius_edge_ratio = 3, params::cell_size = s);
}

// Tunes s on refinement-only runs (no optimisers) towards `target` nodes, starting from s: node count
// ~ s^-3 model, then bisection once bracketed; stops within ±5%. CGAL's node count is not monotone in s
// (random initial surface points), so the s whose run came closest is returned; a fresh domain
// (domain_of()) per run gives the same refinement for the same s. Warns when the best is off by > 10%.
template <class DomainOf>
double tune_size(DomainOf&& domain_of, long target, double s, int max_tuning) {
  double s_lo = 0.0, s_hi = 0.0;  // bracket: s_lo gives too many nodes, s_hi too few
  double best_s = s, best_err = 1e300;
  for (int run = 0; run < max_tuning; ++run) {
    const auto t0 = std::chrono::steady_clock::now();
    const Mesh_domain domain = domain_of();
    const C3t3 c3t3 =
        CGAL::make_mesh_3<C3t3>(domain, criteria_for(s), params::no_perturb(), params::no_exude());
    const CgalMesh m = extract(c3t3);
    const long nodes = static_cast<long>(m.mesh.n_points());
    std::printf("  tuning %d: s=%.5f -> %ld nodes, %zu tets (%.2f s, refinement only)\n", run, s, nodes,
                m.mesh.n_cells(), seconds_since(t0));
    std::fflush(stdout);
    const double rel = static_cast<double>(nodes) / static_cast<double>(target);
    if (std::abs(rel - 1.0) < best_err) best_err = std::abs(rel - 1.0), best_s = s;
    if (std::abs(rel - 1.0) <= 0.05) break;
    if (rel > 1.0)
      s_lo = s;
    else
      s_hi = s;
    double next = s * std::cbrt(rel);  // model update
    if (s_lo > 0.0 && s_hi > 0.0 && (next <= s_lo || next >= s_hi)) next = 0.5 * (s_lo + s_hi);  // bisection
    s = next;
  }
  if (best_err > 0.10)
    std::printf("  WARNING: best tuning run is %.1f%% off the target (outside +-10%%)\n", 100 * best_err);
  return best_s;
}

}  // namespace vim::cgal_bench
