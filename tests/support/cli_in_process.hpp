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

// A command line as run_pipeline takes it (words separated by spaces, quote()'s single quotes) split
// into its arguments, then run in this process.
inline CliResult run_pipeline_in_process(const std::string& command_line) {
  std::vector<std::string> args;
  std::string word;
  bool in_word = false, quoted = false;
  for (std::size_t i = 0; i < command_line.size(); ++i) {
    const char c = command_line[i];
    if (quoted) {
      if (c == '\'')
        quoted = false;
      else
        word += c;
    } else if (c == '\'') {
      quoted = in_word = true;
    } else if (c == '\\' && i + 1 < command_line.size()) {
      word += command_line[++i];
      in_word = true;
    } else if (c == ' ') {
      if (in_word) args.push_back(word);
      word.clear();
      in_word = false;
    } else {
      word += c;
      in_word = true;
    }
  }
  if (in_word) args.push_back(word);
  return run_pipeline_in_process(std::move(args));
}

}  // namespace vim::test
