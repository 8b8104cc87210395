// A scratch folder for tests, removed when the test ends (VIM_KEEP_TEST_OUTPUT=1 keeps it).
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <unistd.h>

namespace vim::test {

struct ScratchDir : std::filesystem::path {
  explicit ScratchDir(const std::filesystem::path& p) : std::filesystem::path(p) {
    std::filesystem::remove_all(*this);
    std::filesystem::create_directories(*this);
  }
  ~ScratchDir() {
    if (std::getenv("VIM_KEEP_TEST_OUTPUT")) return;
    std::error_code ec;
    std::filesystem::remove_all(*this, ec);
  }
};

// $TMPDIR/vim_test_<suite>_<name>_<pid>
inline ScratchDir scratch_dir(const std::string& suite, const std::string& name) {
  return ScratchDir(std::filesystem::temp_directory_path() /
                    ("vim_test_" + suite + "_" + name + "_" + std::to_string(::getpid())));
}

}  // namespace vim::test
