// InputError: a problem with the user's input (file, key, value) carrying one clear message for the
// user; the CLI prints it as `vim-pipeline: error: ...` and exits with 1. Kept free of Eigen so
// that translation units including ITK (which bundles an older Eigen) can use it.
#pragma once

#include <stdexcept>
#include <string>

namespace vim::pipeline {

struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Prints `vim-pipeline: error: MESSAGE` as one line on stderr (line breaks become spaces).
void print_error(std::string message);

}  // namespace vim::pipeline
