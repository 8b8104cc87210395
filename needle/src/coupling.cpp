// The rows of a needle coupling (vim/needle/coupling.hpp).
#include <vim/needle/coupling.hpp>

namespace vim::needle {

template <int dim>
std::vector<fem::PointConstraint<dim>> NeedleCoupling<dim>::rows(const std::vector<std::size_t>& active,
                                                                 const std::vector<double>& axial) const {
  std::vector<Vec> held;
  held_values(active, axial, held);
  std::vector<fem::PointConstraint<dim>> pts;
  pts.reserve(active.size());
  for (std::size_t i = 0; i < active.size(); ++i) {
    pts.push_back(row_template(active[i]));
    pts.back().displacement = held[i];
  }
  return pts;
}

template class NeedleCoupling<2>;
template class NeedleCoupling<3>;

}  // namespace vim::needle
