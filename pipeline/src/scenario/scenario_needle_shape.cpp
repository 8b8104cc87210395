// The keys of a needle beyond the rigid straight needle with a symmetric tip: needle.flexible,
// needle.bevel and needle.rotations (scenario_reader.hpp).
#include <cmath>
#include <string>

#include "scenario/scenario_reader.hpp"

namespace vim::pipeline {

void parse_needle_flexible(const Scenario& scenario, const YAML::Node& node, const std::string& path, int dim,
                           NeedleSpec& needle) {
  const Reader r(scenario);
  if (dim != 3) r.fail(node, path + " applies only to 3D scenarios (a 2D needle is a plane-strain blade)");
  const Fields f =
      r.check_keys(node, path, {"youngs_modulus", "inner_diameter", "free_length", "base_offset"});
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
  if (const YAML::Node& o = f["base_offset"]) {
    flex.base_offset = r.vector(o, path + ".base_offset", 3);
    double along = 0.0, length = 0.0, norm = 0.0;
    for (std::size_t i = 0; i < 3; ++i) {
      along += flex.base_offset[i] * needle.direction[i];
      length += flex.base_offset[i] * flex.base_offset[i];
      norm += needle.direction[i] * needle.direction[i];
    }
    along /= std::sqrt(norm);
    if (std::abs(along) > 1e-6 * std::sqrt(length))
      r.fail(o, path + ".base_offset [" + Reader::join_numbers(flex.base_offset) +
                    "] must be normal to the needle's direction [" + Reader::join_numbers(needle.direction) +
                    "] (the holder moves across the needle; its component along it is " + number_text(along) +
                    ")");
  }
  needle.flexible = flex;
}

void parse_needle_bevel(const Scenario& scenario, const YAML::Node& bevel, const YAML::Node& rotations,
                        const std::string& path, NeedleSpec& needle) {
  const Reader r(scenario);
  if (bevel) {
    const std::string p = path + ".bevel";
    if (!needle.flexible) r.fail(bevel, p + " needs " + path + ".flexible (a rigid needle does not steer)");
    const Fields f = r.check_keys(bevel, p, {"angle", "side"});
    BevelSpec b;
    b.line = Reader::line(bevel);
    const YAML::Node& a = r.require(f, "angle", p + ".angle");
    b.angle = r.number(a, p + ".angle");
    if (!(b.angle > 0.0 && b.angle < 90.0))
      r.fail(a, p + ".angle must be between 0 and 90 degrees (exclusive), got " + number_text(b.angle));
    const YAML::Node& side = r.require(f, "side", p + ".side");
    b.side = r.nonzero_vector(side, p + ".side", 3);
    double along = 0.0;
    for (int i = 0; i < 3; ++i)
      along += b.side[static_cast<std::size_t>(i)] * needle.direction[static_cast<std::size_t>(i)];
    if (std::abs(along) > 1e-6)
      r.fail(side, p + ".side [" + Reader::join_numbers(b.side) +
                       "] must be normal to the needle's direction [" +
                       Reader::join_numbers(needle.direction) + "] (its unit component along it is " +
                       number_text(along) + ")");
    needle.bevel = b;
  }
  if (!rotations) return;
  const std::string p = path + ".rotations";
  if (!needle.bevel) r.fail(rotations, p + " needs " + path + ".bevel (only a bevelled tip steers)");
  if (!rotations.IsSequence() || rotations.size() == 0)
    r.fail(rotations, p + " must be a non-empty list of {depth, angle}");
  for (std::size_t i = 0; i < rotations.size(); ++i) {
    const std::string q = p + "[" + std::to_string(i) + "]";
    const Fields f = r.check_keys(rotations[i], q, {"depth", "angle"});
    RotationSpec rot;
    rot.line = Reader::line(rotations[i]);
    const YAML::Node& d = r.require(f, "depth", q + ".depth");
    rot.depth = r.number(d, q + ".depth");
    if (!(rot.depth > 0.0 && rot.depth <= needle.depth))
      r.fail(d, q + ".depth = " + number_text(rot.depth) + " must lie in (0, " + number_text(needle.depth) +
                    "] (the needle's depth)");
    if (!needle.rotations.empty() && rot.depth < needle.rotations.back().depth)
      r.fail(d, q + ".depth = " + number_text(rot.depth) + " must not be less than the previous rotation's " +
                    number_text(needle.rotations.back().depth));
    rot.angle = r.number(r.require(f, "angle", q + ".angle"), q + ".angle");
    needle.rotations.push_back(rot);
  }
}

}  // namespace vim::pipeline
