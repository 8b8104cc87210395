// The vim-pipeline command line: parses argv into RunOptions, runs PipelineRun (pipeline_run.hpp) for
// the image's dimension and maps errors to exit codes.
#pragma once

#include <optional>
#include <vim/pipeline/common/input_error.hpp>
#include <vim/pipeline/common/output_directory.hpp>
#include <vim/pipeline/run/run_options.hpp>

namespace vim::pipeline {

// Parses argv into options. Returns std::nullopt and sets `exit_code` when the program should stop
// (help/version: 0 after printing; usage error: 2 after one `vim-pipeline: error:` line).
std::optional<RunOptions> parse_command_line(int argc, char** argv, int& exit_code);

// Runs a parsed command. Returns the exit code; prints `vim-pipeline: error: ...` (one line) and
// returns 1 on InputError / std::invalid_argument / other failures, leaving DIR without partial files.
int run(const RunOptions& options);

// parse_command_line + run: the whole program (main.cpp calls this).
int main_cli(int argc, char** argv);

}  // namespace vim::pipeline
