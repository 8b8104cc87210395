// The tissue behind a flexible needle's rows (FlexibleTissue): a TissueResponse whose rows' lateral
// values also carry the needle's deflection at each point, with the force on the tissue at each active
// point of its last solve. Implementations: the CLI's condensed rows with a DeflectedCoupling
// (FlexibleTissue's own adapter), and the real-time needle's condensed region (HapticNeedle).
#pragma once

#include <cstddef>
#include <vector>
#include <vim/needle/fem_types.hpp>
#include <vim/needle/tissue_response.hpp>

namespace vim::needle {

class DeflectableTissue : public TissueResponse {
 public:
  // The needle's lateral deflection at each point for the next solves (model axes, one entry per point;
  // missing entries: 0; the tip bearing's rows, axial only, ignore theirs).
  virtual void set_deflection(const std::vector<Vec<3>>& deflection) = 0;
  // Of the last solve: the force on the tissue at the i-th active point (model axes).
  virtual Vec<3> active_force(std::size_t i) const = 0;
};

}  // namespace vim::needle
