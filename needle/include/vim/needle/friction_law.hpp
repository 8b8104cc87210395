// The friction laws between the shaft and the tissue, and their registry: one table of {name, needle
// model, factory} rows that make_friction_law, the scenario parser's list of valid names and the docs
// read. A new law is one class in its own file (needle/src/friction_NAME.cpp) and one row in
// friction_laws() (needle/src/friction_law.cpp).
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>
#include <vim/needle/active_set.hpp>
#include <vim/needle/shaft_state.hpp>
#include <vim/needle/tissue_response.hpp>

namespace vim::needle {

// A value that is piecewise constant along the needle's path (a property of the tissues the path
// crosses): v = values[i] on [breaks[i], breaks[i + 1]) (arc lengths at rest), the end values beyond
// the ends. The stick-slip limit per length: a shaft point carrying [b, b + L] has the limit
// ∫_b^{b+L} q ds, exact; the cutting force: that of the tissue at the front.
class PathProfile {
 public:
  PathProfile() = default;
  // breaks increasing, one more than values; throws std::invalid_argument otherwise.
  PathProfile(std::vector<double> breaks, std::vector<double> values);
  bool empty() const { return values_.empty(); }
  // The value at s (the piece that starts at s where s is a break).
  double at(double s) const { return values_[piece(s)]; }
  // ∫_a^b v ds (a ≤ b).
  double integral(double a, double b) const;
  // The first arc length after s at which the value differs from at(s) (infinity if it never does).
  double next_change(double s) const;
  const std::vector<double>& breaks() const { return breaks_; }
  const std::vector<double>& values() const { return values_; }

 private:
  std::size_t piece(double s) const;  // the piece holding s (the first or last beyond the ends)
  std::vector<double> breaks_, values_, cumulative_;  // cumulative_[i] = ∫_{breaks[0]}^{breaks[i]} v ds
};

// A law and its parameters (the scenario's needle.model, needle.friction and their keys).
struct FrictionOptions {
  std::string law = "stick-slip";     // a name of friction_laws()
  double max_shear_per_length = 0.0;  // stick-slip: the limit per unit length of carried shaft
  double friction_per_length = 0.0;   // force: the friction per unit length of carried shaft
  double tip_force = 0.0;             // force: the load of the point the tip pushes
  double cutting_distance = 0.0;      // kinematic: the tip is this far behind the needle's end
  double cutting_force = 0.0;         // kinematic: the load at which the tip cuts the tissue it pushes
  int max_sweeps = 100;               // kinematic: active-set sweeps per step
  // Per shaft point, from the tissue at each point (filled once the shaft is built; empty: the values
  // above everywhere): the stick-slip limit per length, and the cutting force when the tip pushes it.
  std::vector<double> point_max_shear_per_length, point_cutting_force;
  // Along the path (3D; not empty: they replace the per-point values): the stick-slip limit per length,
  // whose integral over a shaft point's carried interval (ShaftState::start) is its limit, and the
  // cutting force of the tissue at the front (ShaftState::front) for the tip row the tip presses.
  PathProfile shear_profile, cutting_profile;

  // The values at shaft point j: its own, else the needle's.
  double max_shear_per_length_at(std::size_t j) const {
    return j < point_max_shear_per_length.size() ? point_max_shear_per_length[j] : max_shear_per_length;
  }
  double cutting_force_at(std::size_t j) const {
    return j < point_cutting_force.size() ? point_cutting_force[j] : cutting_force;
  }
  // Some tissue on the path has a cutting force (the tip pushes the tissue until it cuts it).
  bool cuts() const {
    bool any = cutting_force > 0.0;
    for (double f : point_cutting_force) any = any || f > 0.0;
    return any;
  }
};

// What a law reports about itself (report.json's needle entry: "model", "friction", its parameters).
struct LawDescription {
  std::string model, friction;
  std::vector<std::pair<std::string, double>> parameters;
};

// A friction law: it sets `state.axial` of the active points and leaves the tissue solved with those
// values (its last TissueResponse::solve).
class FrictionLaw {
 public:
  virtual ~FrictionLaw() = default;
  // Called once before the first step with the number of shaft points.
  virtual void start(std::size_t n_points) = 0;
  virtual FrictionStep update(ShaftState& state, TissueResponse& tissue) = 0;
  // The law keeps an active set whose sweeps are recorded per step.
  virtual bool has_active_set() const { return false; }
  // The axial force of a needle advancing under this law never falls in linear elastic tissue (the
  // simulation warns where the discretisation makes it fall).
  virtual bool axial_force_never_falls() const { return false; }
  // The tip pushes the station its band has entered until the tissue there is cut (a cutting force).
  virtual bool tip_cuts() const { return false; }
  // The active point whose force is the tip force (the rest is the shaft's friction): the cutting
  // station (none without one), or the force model's tip point.
  virtual std::size_t tip_point(const ShaftState& state) const { return state.cutting; }
  virtual LawDescription describe() const = 0;
};

struct FrictionLawEntry {
  const char* name;   // FrictionOptions::law
  const char* model;  // the needle model it belongs to: "kinematic" or "force"
  std::unique_ptr<FrictionLaw> (*make)(const FrictionOptions&);
};

// The laws, in the order the scenario lists them.
const std::vector<FrictionLawEntry>& friction_laws();
// The names of the laws of one needle model, in registry order.
std::vector<std::string> friction_law_names(const std::string& model);
// The law named options.law; throws std::invalid_argument for a name not in friction_laws().
std::unique_ptr<FrictionLaw> make_friction_law(const FrictionOptions& options);

}  // namespace vim::needle
