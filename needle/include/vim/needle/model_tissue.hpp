// The tissue as a finite-element model behind the needle's rows: the tissue interface
// (TissueResponse) and what the pipeline's stepping reads of the model at each step — the whole field
// on request, the displacement the rows hold, the probes (targets, seeds) and the solve count.
// Implementations: the linear elastic model condensed once (ElasticTissue) and the neo-Hookean model
// solved by Newton per step (NeoHookeanTissue).
#pragma once

#include <chrono>
#include <cstddef>
#include <vector>
#include <vim/fem/model.hpp>
#include <vim/needle/fem_types.hpp>
#include <vim/needle/tissue_response.hpp>

namespace vim::needle {

namespace detail {
// Wall-clock seconds since `t` (the tissues' solve timings).
inline double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}
}  // namespace detail

template <int dim>
class ModelTissue : public TissueResponse {
 public:
  // Before stepping: the rows of every shaft point and the probes (points whose displacement each
  // solve gives).
  virtual void precompute(const std::vector<Vec<dim>>& probes) = 0;
  // The whole field of the last solve into solution() (once per solve).
  virtual void form_field() = 0;
  // No contact: an empty solution that counts as formed.
  virtual void clear() = 0;
  virtual fem::Solution<dim>& solution() = 0;
  // The displacement along `axis` that point j's rows hold in the last solution.
  virtual double held_axial(std::size_t j, const Vec<dim>& axis) const = 0;
  // The probes' displacements in the last solve.
  virtual std::vector<Vec<dim>> probe_displacements(const std::vector<Vec<dim>>& probes) const = 0;
  virtual int solves() const = 0;
  virtual double solve_seconds() const = 0;
};

}  // namespace vim::needle
