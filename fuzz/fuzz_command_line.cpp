// libFuzzer target for the command-line parser (cli.hpp, parse_command_line): the input's lines are
// the arguments after "vim-pipeline". Every argument list must either give options that satisfy
// the documented ranges or stop with exit code 0 (--help, --version) or 2 (usage error); a crash, an
// exception or a sanitizer report is a bug. Only parsing runs: no file is read or written. Built by
// scripts/fuzz.sh (fuzz/CMakeLists.txt) against a normal build's libraries (VIM_BUILD_DIR).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>
#include <vim/pipeline/app/cli.hpp>

namespace {

void check_options(const vim::pipeline::RunOptions& o) {
  const bool ok = (o.info || !o.out.empty()) && o.nodes >= 4 && o.nodes <= 100000000 &&
                  std::isfinite(o.spacing) && o.spacing >= 0.0 && o.lambda >= 0.0 && o.lambda < 1.0 &&
                  o.max_dihedral_deg > 90.0 && o.max_dihedral_deg < 180.0 && o.threads >= 0 &&
                  o.threads <= 1024 && (o.degree == 1 || o.degree == 2) && o.max_memory >= 0.0 &&
                  (!o.threshold || std::isfinite(*o.threshold));
  if (!ok) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::string> args{"vim-pipeline"};
  std::string cur;
  for (std::size_t i = 0; i < size && args.size() < 64; ++i) {
    if (data[i] == '\n') {
      args.push_back(cur);
      cur.clear();
    } else {
      cur += static_cast<char>(data[i]);
    }
  }
  if (!cur.empty()) args.push_back(cur);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  int code = -1;
  const auto options = vim::pipeline::parse_command_line(static_cast<int>(args.size()), argv.data(), code);
  if (options) {
    if (code != 0) __builtin_trap();
    check_options(*options);
  } else if (code != 0 && code != 2) {
    __builtin_trap();
  }
  return 0;
}
