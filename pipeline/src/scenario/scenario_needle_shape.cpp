// The keys of a needle's shaft beyond the rigid straight needle: needle.flexible (scenario_reader.hpp).
#include <string>

#include "scenario/scenario_reader.hpp"

namespace vim::pipeline {

void parse_needle_flexible(const Scenario& scenario, const YAML::Node& node, const std::string& path, int dim,
                           NeedleSpec& needle) {
  const Reader r(scenario);
  if (dim != 3) r.fail(node, path + " applies only to 3D scenarios (a 2D needle is a plane-strain blade)");
  const Fields f = r.check_keys(node, path, {"youngs_modulus", "inner_diameter", "free_length"});
  FlexibleSpec flex;
  flex.line = Reader::line(node);
  const YAML::Node& e = r.require(f, "youngs_modulus", path + ".youngs_modulus");
  flex.youngs_modulus = r.positive(e, path + ".youngs_modulus");
  if (const YAML::Node& d = f["inner_diameter"]) {
    flex.inner_diameter = r.number(d, path + ".inner_diameter");
    if (!(flex.inner_diameter >= 0.0) || !(flex.inner_diameter < needle.diameter))
      r.fail(d, path + ".inner_diameter = " + number_text(flex.inner_diameter) +
                    " must be >= 0 and less than the needle's diameter " + number_text(needle.diameter) +
                    " (the tube's outer diameter)");
  }
  if (const YAML::Node& l = f["free_length"]) {
    flex.free_length = r.number(l, path + ".free_length");
    if (!(flex.free_length >= 0.0))
      r.fail(l, path + ".free_length must be >= 0 (the holder's distance before the entry), got " +
                    number_text(flex.free_length));
  }
  needle.flexible = flex;
}

}  // namespace vim::pipeline
