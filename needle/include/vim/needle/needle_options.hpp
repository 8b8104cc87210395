// A needle as the needle library takes it: its path in the model's frame, its stepping, its geometry
// and its friction law (the pipeline translates a scenario's needle into these in one place,
// pipeline/src/simulation/needle_options.cpp).
#pragma once

#include <vim/needle/friction_law.hpp>
#include <vim/needle/needle_path.hpp>

namespace vim::needle {

template <int dim>
struct NeedleOptions {
  NeedlePath<dim> path;   // frame: entry, unit axis and the depth of the insertion
  int steps = 1;          // the insertion advances depth / steps per step
  double diameter = 0.0;  // 3D: the band coupling's needle 2a (2D: a blade, unused)
  // Spacing of the shaft points (3D: the stations' band length); 0: the element size near the path
  // (3D), half the mean element edge (2D).
  double sample_spacing = 0.0;
  double coupling_radius = 0.0;  // 3D: R of the bands; 0: default_coupling_radius
  FrictionOptions friction;      // the law and its parameters, the cutting distance and force
};

}  // namespace vim::needle
