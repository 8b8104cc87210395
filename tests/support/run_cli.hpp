// Test helpers for driving the real executables (VIM_PIPELINE_EXE, VIM_PHANTOM_EXE) through the
// shell: exit code, stdout and stderr captured, plus fresh temporary folders.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace vim::test {

struct CliResult {
  int code = -1;
  std::string out, err;
};

inline std::string quote(const std::string& s) {
  std::string r = "'";
  for (char c : s) r += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return r + "'";
}

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Runs `exe args` (args already quoted as needed) and captures everything.
inline CliResult run_command(const std::string& exe, const std::string& args) {
  static int counter = 0;
  const auto base = std::filesystem::temp_directory_path() /
                    ("vim_cli_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  const std::string cmd = quote(exe) + " " + args + " >" + quote(base.string() + ".out") + " 2>" +
                          quote(base.string() + ".err");
  const int status = std::system(cmd.c_str());
  CliResult r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(base.string() + ".out");
  r.err = slurp(base.string() + ".err");
  std::filesystem::remove(base.string() + ".out");
  std::filesystem::remove(base.string() + ".err");
  return r;
}

inline CliResult run_pipeline(const std::string& args) { return run_command(VIM_PIPELINE_EXE, args); }

// A new empty folder under the system temporary directory, removed by the destructor.
struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& tag) {
    static int counter = 0;
    path = std::filesystem::temp_directory_path() /
           ("vim_test_" + tag + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

// Number of regular files (any name, including hidden temporaries) below `dir`; 0 if it is absent.
inline long count_files(const std::filesystem::path& dir) {
  if (!std::filesystem::exists(dir)) return 0;
  long n = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.is_regular_file()) ++n;
  return n;
}

inline long count_lines(const std::string& s) {
  long n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

}  // namespace vim::test
