// RunOptions (run_options.hpp): the mesher table.
#include <vim/pipeline/run/run_options.hpp>

namespace vim::pipeline {

const std::vector<Mesher>& meshers() {
  static const std::vector<Mesher> table = {
      {MesherKind::vim, "vim", "VIM optimisation"},
      {MesherKind::grid, "grid", "the unoptimised initial grid with the same nodes"},
      {MesherKind::voxel, "voxel", "one cell per voxel (fine reference)"},
  };
  return table;
}

std::string to_string(MesherKind m) {
  for (const Mesher& row : meshers())
    if (row.kind == m) return row.name;
  return "?";
}

std::optional<MesherKind> mesher_kind(const std::string& name) {
  for (const Mesher& row : meshers())
    if (row.name == name) return row.kind;
  return std::nullopt;
}

}  // namespace vim::pipeline
