// The registry of the friction laws (vim/needle/friction_law.hpp).
#include <stdexcept>
#include <vim/needle/friction_law.hpp>

#include "friction_laws.hpp"

namespace vim::needle {

const std::vector<FrictionLawEntry>& friction_laws() {
  static const std::vector<FrictionLawEntry> laws = {
      {"stick", "kinematic", &make_stick_law},
      {"stick-slip", "kinematic", &make_stick_slip_law},
      {"force", "force", &make_force_law},
  };
  return laws;
}

std::vector<std::string> friction_law_names(const std::string& model) {
  std::vector<std::string> names;
  for (const auto& law : friction_laws())
    if (model == law.model) names.emplace_back(law.name);
  return names;
}

std::unique_ptr<FrictionLaw> make_friction_law(const FrictionOptions& options) {
  for (const auto& law : friction_laws())
    if (options.law == law.name) return law.make(options);
  std::string known;
  for (const auto& law : friction_laws()) known += std::string(known.empty() ? "" : ", ") + law.name;
  throw std::invalid_argument("unknown friction law '" + options.law + "' (known: " + known + ")");
}

}  // namespace vim::needle
