// Needle-insertion scenario (docs/architecture.md): the YAML file given to `--simulate`, parsed
// and validated in one place. Every error is a ScenarioError whose message names the file, the
// YAML line, the key and the value, and says what is valid.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>
#include <vim/image.hpp>
#include <vim/needle/needle_path.hpp>
#include <vim/pipeline/common/model.hpp>
#include <vim/pipeline/image/image_io.hpp>

namespace vim::pipeline {

// ν of a scenario without material.poisson_ratio, and of the exports without a scenario: nearly
// incompressible soft tissue.
inline constexpr double kDefaultPoissonRatio = 0.49;

struct ScenarioError : InputError {
  using InputError::InputError;
};

// A region in WORLD coordinates (ITK physical points), except box faces, which name a face of the
// image box: x_min/x_max are the faces normal to the image's first index axis (i), y_* to j, z_* to k
// (for an identity direction matrix these are the world x/y/z faces).
// The region types a scenario's `region:` takes (box_face, box, sphere, cylinder), from the parser's
// table (pipeline/src/scenario/scenario.cpp); README's scenario block and docs/architecture.md list them.
std::vector<std::string> region_types();

struct RegionSpec {
  enum class Kind { box_face, box, sphere, cylinder, label } kind = Kind::box_face;
  int axis = 0;                                     // box_face: 0..dim-1
  bool upper = false;                               // box_face: *_max
  std::string face;                                 // box_face name as written
  std::vector<double> center, axis_vector, lo, hi;  // dim values each (world)
  double radius = 0.0;
  double length = 0.0;  // cylinder: its length, centred at center (0: infinite)
  // label: the label's name or number as written, and the label it names (a number: set by the parser;
  // a name: set by the run from the label image and the `labels:` table, docs/labels.md).
  std::string label;
  int label_value = 0;
  std::string describe() const;
};

struct BoundaryConditionSpec {
  enum class Type { fixed, displacement, pressure, traction } type = Type::fixed;
  RegionSpec region;
  std::vector<double> value;     // displacement / traction: dim values (world axes); pressure: 1 value
  std::vector<bool> components;  // fixed/displacement: which world components (default all)
  int line = 0;                  // YAML line (1-based) of the list entry
  // How a `fixed` condition on a volume region (box, sphere, cylinder) holds the tissue:
  //  * nodes: the mesh nodes (support points) inside the region are clamped. On a coarse mesh the
  //    support then depends on where the nodes happen to fall (a region may hold no node at all).
  //  * elastic: an elastic foundation of stiffness k (modulus per length²) on a lattice of sample
  //    points filling the region (pitch `spacing`, anchored at the region, weights spacing^dim): the
  //    energy ½ ∫_R k |u|² dx, the same for every mesh and for the voxel reference
  //    (fem::VolumeSupport). Box faces are always clamped node by node (every mesh has nodes on them).
  enum class Support { nodes, elastic } support = Support::nodes;
  double support_stiffness = 0.0;  // elastic: k
  double support_spacing = 0.0;    // elastic: lattice pitch; 0 = automatic (region size / 6)
  bool is_dirichlet() const { return type == Type::fixed || type == Type::displacement; }
};

// An entry of needle.tissues: where it applies (a scenario region, or the elements whose Young's modulus
// lies in [modulus_min, modulus_max]) and the needle's parameters there (a value not given is the
// needle's own). The first entry that holds a shaft point gives that point's values.
struct TissueSpec {
  std::optional<RegionSpec> region;             // absent: the modulus range
  double modulus_min = 0.0, modulus_max = 0.0;  // modulus units
  std::optional<double> cutting_force;          // the tip's cutting force in this tissue
  std::optional<double> max_shear_per_length;   // the stick-slip limit per length here
  bool fit = true;                              // --fit-forces adjusts its values
  int line = 0;                                 // YAML line of the entry
  std::string describe() const;
};

// needle.flexible: the shaft is an Euler–Bernoulli beam, a steel tube of outer diameter
// NeedleSpec::diameter (docs/needle-model.md, the flexible needle).
struct FlexibleSpec {
  double youngs_modulus = 0.0;  // the tube's E, modulus units (steel: 2e8 kPa)
  double inner_diameter = 0.0;  // d_i, 0 ≤ d_i < diameter
  double free_length = 0.0;     // the base is clamped this far before the entry (0: at the entry)
  // The holder moved across the needle by this vector (world, normal to the needle) at the last
  // insertion step, the needle fully inserted along the channel it cut: the base held there, in the
  // needle's direction. Zero: the holder stays on the planned line.
  std::vector<double> base_offset{0.0, 0.0, 0.0};
  int line = 0;  // YAML line of the key
};

// needle.bevel: the tip's bevel, its angle to the axis and the side its face faces at entry (world,
// normal to the needle; normalised by the parser). needle.rotations: the needle turns about its axis
// by `angle` degrees (right-handed about its direction) when its end reaches `depth`.
struct BevelSpec {
  double angle = 0.0;  // degrees, 0 < angle < 90
  std::vector<double> side;
  int line = 0;
};
struct RotationSpec {
  double depth = 0.0, angle = 0.0;  // length units, degrees
  int line = 0;
};

struct NeedleSpec {
  std::string name = "needle";
  std::vector<double> entry, direction;  // world; direction normalised by the parser
  double depth = 0.0;                    // travel after entry
  int steps = 0;
  double diameter = 0.0;
  enum class Model { kinematic, force } model = Model::kinematic;
  // The parser's default is stick-slip, whose limit has no default (the key is then required); stick is
  // the no-slip limit.
  enum class Friction { stick, stick_slip } friction = Friction::stick;
  double max_shear_per_length = 0.0;  // stick-slip limit (force per unit length of shaft, e.g. mN/mm)
  double sample_spacing = 0.0;        // distance between embedded shaft points; 0 = automatic
  // Kinematic model: the tip cuts a material point (it joins the shaft) once the tip has passed the
  // point's current position by this distance; until then it is tissue ahead of the tip (not held by
  // the needle). 0 = as soon as the tip reaches it. A length of the needle (e.g. its bevel), the same
  // for every mesh.
  double cutting_distance = 0.0;
  // Kinematic model: the tissue at the tip is pushed until its force reaches this cutting force, then
  // it is cut and joins the shaft (force units: mN in 3D, mN/mm in 2D); 0 = the tip cuts without
  // resistance.
  double cutting_force = 0.0;
  // 3D: radius of the cylinder whose band means the shaft stations hold (docs/needle-model.md);
  // 0 = automatic (from the diameter and the element size near the path).
  double coupling_radius = 0.0;
  double tip_force = 0.0;  // force model: cutting force at the tip (modulus × length²: kPa·mm² = mN in
                           // 3D; per unit thickness, mN/mm, in 2D)
  double friction_per_length = 0.0;      // force model: friction force per unit shaft length
  std::vector<TissueSpec> tissues;       // kinematic model: parameters per tissue (needle.tissues)
  bool fit = true;                       // --fit-forces adjusts the needle's own cutting force and limit
  std::optional<FlexibleSpec> flexible;  // absent: the rigid needle
  std::optional<BevelSpec> bevel;        // absent: a symmetric tip (needs flexible)
  std::vector<RotationSpec> rotations;   // in order of depth (needs bevel)
  int line = 0;
  // A procedure's insertion (scenario_procedure.cpp): the seeds' planned depths along the path (in
  // (0, depth], increasing), released as the tip passes them on the way out; the withdrawal's steps
  // (0: the needle stays in at the end of its run) and the line of the action that withdraws it.
  // stay: the needle is left in the tissue; its stations keep holding the tissue where its last step
  // left it during the later actions (docs/procedure.md), to the end or to the action that withdraws it:
  // then withdraw_action is that action's number in the procedure and withdraw_after the number of
  // insertions before it (the withdrawal runs after them, its withdraw_steps after the insertion's run).
  std::vector<double> seeds;
  int withdraw_steps = 0;
  int withdraw_line = 0;
  bool stay = false;
  int withdraw_action = -1;
  std::size_t withdraw_after = 0;
  bool withdrawn_later() const { return stay && withdraw_action >= 0; }
};

// `dose:` of a procedure (docs/dose.md): the TG-43U1 dose of its seeds at their planned and final
// positions on a grid over the image box, and D90/V100/V150 over the points of `region`.
struct DoseSpec {
  std::string seed_model;           // a name of dose::seed_model_names()
  double air_kerma_strength = 0.0;  // S_K per seed, U (µGy m² h⁻¹)
  double prescription = 145.0;      // Gy (AAPM TG-137's I-125 monotherapy prescription)
  double grid = 0.0;                // spacing of the dose grid, length units (mm)
  RegionSpec region;                // a volume: box, sphere or cylinder
  int line = 0;
};

// `probe:` (docs/procedure.md, the probe): a rigid TRUS probe, the tissue bonded to it over a cylinder
// (its axis the probe's) through an elastic foundation: `hold` is a fixed condition on that cylinder with
// an elastic support (BoundaryConditionSpec::Support::elastic). A procedure's `probe:` actions move it:
// the foundation's base follows the probe's rigid motion (a change of the load alone, linear model).
struct ProbeMotionSpec {
  std::vector<double> translate;  // world, dim values; empty: a rotation
  double rotate = 0.0;            // degrees about the probe's axis (right-handed), when translate is empty
  int steps = 0;
  std::size_t after = 0;  // the number of Scenario::needles run before it (each withdrawn or left in)
  int action = 0;         // its index in `procedure`
  int line = 0;
};
struct ProbeSpec {
  BoundaryConditionSpec hold;            // a cylinder, support elastic
  std::vector<ProbeMotionSpec> motions;  // in the procedure's order
  int line = 0;
};

struct TargetSpec {
  std::string name;
  std::vector<double> position;  // world (a label target: set by the run, docs/labels.md)
  // `{label: NAME, at: centroid}`: the centroid of the label's voxels in the label image, in world
  // coordinates; the label's name or number as written.
  std::string label;
  int line = 0;
};

// One entry of the scenario's `labels:` table (docs/labels.md): a label of the label image, its name
// and its Young's modulus (a number; nullopt: `image`, the modulus image's Eq. 15 mean).
struct LabelSpec {
  int label = 0;
  std::string name;
  std::optional<double> youngs_modulus;
  int line = 0;
};

struct Scenario {
  std::string source;  // file name (for messages)
  std::string text;    // the YAML as read (echoed into report.json)
  int dim = 3;

  std::string length_unit = "mm", modulus_unit = "kPa";  // labels only

  // material
  bool modulus_from_image = true;
  double youngs_modulus = 0.0;  // when not from the image
  double scale = 1.0;
  std::optional<std::pair<double, double>> clamp;
  double poisson_ratio = kDefaultPoissonRatio;
  // material.model: small-strain linear elasticity (default) or the compressible neo-Hookean solid of
  // fem::solve_neo_hookean (static load cases; docs/finite-strain.md), and the key's line.
  enum class MaterialModel { linear, neo_hookean } material_model = MaterialModel::linear;
  int material_model_line = 0;

  // mesh (the CLI options override these)
  std::optional<long> nodes;
  std::optional<double> lambda;
  std::optional<unsigned> degree;
  std::optional<double> min_dihedral;  // mesh.min_dihedral: VIM quality floor in degrees (--min-dihedral)
  // mesh.needle_refinement: VIM keeps elements near the needle paths about size_ratio times the size
  // of the others (a density-weighted E_G, paper §VI-E; needle::needle_density).
  struct NeedleRefinement {
    double size_ratio = 1.0;  // (0, 1]
    double radius = 0.0;      // length units: the refined tube's 1/e radius around each path
  };
  std::optional<NeedleRefinement> needle_refinement;

  std::vector<LabelSpec> labels;  // `labels:` (for --labels), in the file's order

  std::vector<BoundaryConditionSpec> boundary_conditions;
  std::vector<NeedleSpec> needles;  // empty: a static load case (the boundary conditions alone, step 0)
  bool needle_list = false;         // `needles:` given: one sub-folder per needle + summary.csv
  // `procedure:` given: its insertions are `needles` in order (needle_list is then true), each withdrawn
  // before the next action (docs/procedure.md).
  bool procedure = false;
  std::optional<DoseSpec> dose;  // only with a procedure
  std::optional<ProbeSpec> probe;

  std::vector<TargetSpec> targets;

  int output_every = 1;
  std::vector<std::string> output_fields = {"displacement", "strain", "stress", "von_mises",
                                            "youngs_modulus"};
  bool wants(const std::string& field) const;

  std::string solver_type = "auto";  // auto | direct | amg | multigrid (voxel model, matrix-free)
  double solver_tolerance = 1e-10;

  // "file.yaml:LINE: " prefix for messages (line <= 0: just "file.yaml: ").
  std::string where(int line) const;
};

// Parses and validates a scenario for a `dim`-dimensional image (vectors must have dim values).
// Throws ScenarioError for syntax errors, missing/unknown keys, wrong types and ranges.
Scenario parse_scenario_text(const std::string& yaml_text, int dim,
                             const std::string& source_name = "scenario");
Scenario read_scenario(const std::string& path, int dim);

// A coordinate list of the scenario (a position, direction or corner; at least dim values) as a vector.
template <int dim>
Eigen::Matrix<double, dim, 1> spec_vector(const std::vector<double>& x) {
  Eigen::Matrix<double, dim, 1> v;
  for (int d = 0; d < dim; ++d) v[d] = x[d];
  return v;
}

// Checks the scenario against the image geometry (world = transform.to_world(frame)): needle entry
// inside the image box (on its surface is fine, as for a transperineal entry at the skin), the whole
// path inside the box, targets inside the box. box_min/box_max are the image box in the frame.
template <int dim>
void check_scenario_geometry(const Scenario& scenario, const Eigen::Matrix<double, dim, 1>& box_min,
                             const Eigen::Matrix<double, dim, 1>& box_max,
                             const WorldTransform<dim>& transform);

// A needle's straight path (entry → entry + depth·direction) in frame coordinates; needle_paths: every
// needle's.
template <int dim>
needle::NeedlePath<dim> needle_path(const NeedleSpec& needle, const WorldTransform<dim>& transform);
template <int dim>
std::vector<needle::NeedlePath<dim>> needle_paths(const Scenario& scenario,
                                                  const WorldTransform<dim>& transform);

// The mesh density of mesh.needle_refinement on the grid of `image` (needle_density over
// needle_paths), or nothing when the scenario has no needle refinement.
template <int dim>
std::optional<Image<dim>> needle_refinement_density(const Scenario& scenario, const Image<dim>& image,
                                                    const WorldTransform<dim>& transform);

// A modulus image with negative, zero or NaN values (after `scale`) needs `material.clamp`.
template <int dim>
void check_modulus_image(const Scenario& scenario, const Image<dim>& image);

// Per-cell Young's modulus for the scenario's material (Eq. 15 for `image`: scale·mean, clamped;
// a constant for a number). Throws ScenarioError naming the element when the result is invalid.
std::vector<double> scenario_modulus(const Scenario& scenario, const std::vector<double>& element_mean);

}  // namespace vim::pipeline
