// vim-pipeline's command line run in the test's own process: main_cli (the executable's whole main,
// pipeline/src/app/main.cpp) with an argv built from ARGS, its stdout and stderr captured. For command
// lines that stop while parsing (usage errors, --help, --version): the same code path as the
// executable without a process start, which costs more than a second under the sanitizers.
#pragma once

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>
#include <vim/pipeline/app/cli.hpp>

#include "run_cli.hpp"

namespace vim::test {

// argv for ARGS, "vim-pipeline" first: the strings live in ARGS.
inline std::vector<char*> argv_of(std::vector<std::string>& args) {
  args.insert(args.begin(), "vim-pipeline");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  return argv;
}

inline std::optional<pipeline::RunOptions> parse_in_process(std::vector<std::string> args, int& code) {
  std::vector<char*> argv = argv_of(args);
  return pipeline::parse_command_line(static_cast<int>(args.size()), argv.data(), code);
}

inline CliResult run_pipeline_in_process(std::vector<std::string> args) {
  std::vector<char*> argv = argv_of(args);
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  CliResult r;
  r.code = pipeline::main_cli(static_cast<int>(args.size()), argv.data());
  r.out = testing::internal::GetCapturedStdout();
  r.err = testing::internal::GetCapturedStderr();
  return r;
}

}  // namespace vim::test
