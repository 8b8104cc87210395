// The command-line tool under `mpirun -np RANKS` (as root, oversubscribed: the CI machine has 2 cores).
#pragma once

#include <string>

#include "run_cli.hpp"

namespace vim::test {

inline CliResult run_on_ranks(int ranks, const std::string& args) {
  return run_command("env", "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 " +
                                quote(VIM_MPIEXEC) + " -np " + std::to_string(ranks) + " --oversubscribe " +
                                quote(VIM_PIPELINE_EXE) + " " + args);
}

}  // namespace vim::test
