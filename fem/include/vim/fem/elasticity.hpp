// The fem module's serial interface in one include: regions and conditions, material, point
// constraints, the point locator and the elastic model. The MPI solve is in <vim/fem/distributed.hpp>
// (the only fem header that needs <mpi.h>).
#pragma once

#include <vim/fem/cell_locator.hpp>
#include <vim/fem/conditions.hpp>
#include <vim/fem/material.hpp>
#include <vim/fem/model.hpp>
#include <vim/fem/point_constraints.hpp>
