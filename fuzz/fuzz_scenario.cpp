// libFuzzer target for the needle-scenario YAML parser (scenario.hpp, parse_scenario_text): any
// byte string must either parse or throw ScenarioError/InputError with a message; any other
// exception, crash, leak or sanitizer report is a bug. Built by scripts/fuzz.sh (fuzz/CMakeLists.txt).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vim/pipeline/scenario/scenario.hpp>

// The image dimension the scenario is checked against follows the input's length parity (even: 3D,
// odd: 2D), so every input is parsed once and the mutator reaches both paths without a prefix byte
// (the seed files stay plain YAML).
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const int dim = size % 2 == 0 ? 3 : 2;
  try {
    const vim::pipeline::Scenario s = vim::pipeline::parse_scenario_text(text, dim, "fuzz.yaml");
    (void)s.where(1);
  } catch (const vim::pipeline::InputError& e) {
    if (std::string(e.what()).empty()) __builtin_trap();  // every error must say something
  }
  return 0;
}
