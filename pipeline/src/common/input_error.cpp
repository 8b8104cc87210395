#include <iostream>
#include <vim/pipeline/common/input_error.hpp>

namespace vim::pipeline {

void print_error(std::string msg) {
  for (char& c : msg)
    if (c == '\n' || c == '\r') c = ' ';
  std::cerr << "vim-pipeline: error: " << msg << "\n";
}

}  // namespace vim::pipeline
