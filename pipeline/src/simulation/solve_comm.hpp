// Private to the simulation sources: the MPI communicator the solves and the step pieces of a
// simulation use, as its entry point gave it (SimulationOptions::mpi_comm; <mpi.h> stays out of the
// public headers).
#pragma once

#include <mpi.h>

#include <vim/pipeline/simulation/simulation.hpp>

namespace vim::pipeline {

// The communicator of options.mpi_comm, or MPI_COMM_SELF for one process.
inline MPI_Comm solve_comm(const SimulationOptions& options) {
  return options.mpi_comm ? *static_cast<const MPI_Comm*>(options.mpi_comm) : MPI_COMM_SELF;
}

}  // namespace vim::pipeline
