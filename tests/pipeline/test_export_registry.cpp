// The export table (export_registry.hpp) is the one list of formats: a row registered at run time (a
// tiny writer of the cell count) is accepted by --export, listed by --help, part of the default, and
// written by write_exports and by a whole run, which lists it in report.json; an unknown name is refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>
#include <vim/pipeline/app/cli.hpp>
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/image/phantoms.hpp>
#include <vim/pipeline/output/export_registry.hpp>
#include <vim/pipeline/output/exports.hpp>

#include "cli_in_process.hpp"
#include "oblique_grid.hpp"
#include "run_cli.hpp"
#include "scratch_dir.hpp"

namespace fs = std::filesystem;
using namespace vim;
using namespace vim::pipeline;

namespace {

template <int dim>
void write_count(const fs::path& path, const ExportData<dim>& data) {
  write_text_atomically(path, [&](std::ostream& out) { out << "cells " << data.world.n_cells() << "\n"; });
}

// A grid with a modulus per cell.
template <int dim>
MeshModel<dim> model(const std::array<int, dim>& nodes) {
  MeshModel<dim> m = vim::test::oblique_grid<dim>(nodes);
  m.youngs_modulus.assign(m.mesh.n_cells(), 10.0);
  return m;
}

// Registers the "cells" format (3D only) for one test and removes it afterwards.
class ExportRegistry : public ::testing::Test {
 protected:
  void SetUp() override {
    ExportFormat row;
    row.name = "cells";
    row.option_help = "the cell count";
    row.reader = "any text editor";
    row.write_3d = write_count<3>;
    row.skipped_why = "cells is written for 3D models only";
    register_export_format(row);
  }
  void TearDown() override { unregister_export_format("cells"); }

  // parse_command_line on `args` after the program name; the exit code in `code`.
  static std::optional<RunOptions> parse(std::vector<std::string> args, int& code) {
    return vim::test::parse_in_process(std::move(args), code);
  }
};

}  // namespace

TEST_F(ExportRegistry, TheCommandLineAcceptsARegisteredRow) {
  EXPECT_EQ(export_formats(), (std::vector<std::string>{"vtk", "feb", "msh", "inp", "cells"}));
  EXPECT_THROW(register_export_format(export_format("vtk")), std::invalid_argument);
  int code = -1;
  const auto o = parse({"in.mha", "--out", "dir", "--export", "cells,msh"}, code);
  ASSERT_TRUE(o.has_value());
  EXPECT_EQ(code, 0);
  EXPECT_EQ(o->exports, (std::vector<std::string>{"cells", "msh"}));
  const auto all = parse({"in.mha", "--out", "dir"}, code);
  ASSERT_TRUE(all.has_value());
  EXPECT_EQ(all->exports, export_formats());  // the default is every row
  EXPECT_FALSE(parse({"in.mha", "--out", "dir", "--export", "stl"}, code).has_value());
  EXPECT_EQ(code, 2);
  EXPECT_EQ(parse_export_formats("all"), export_formats());
}

TEST_F(ExportRegistry, HelpListsTheRow) {
  const auto r = vim::test::run_command(VIM_PIPELINE_EXE, "--help");  // the table's own rows
  EXPECT_NE(r.out.find("vtk (legacy, deal.II GridIn), feb (FEBio), msh (Gmsh 4.1), inp (Abaqus)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("mesh.vtk mesh.feb mesh.msh mesh.inp"), std::string::npos) << r.out;
  testing::internal::CaptureStdout();
  int code = -1;
  EXPECT_FALSE(parse({"--help"}, code).has_value());
  const std::string help = testing::internal::GetCapturedStdout();
  EXPECT_EQ(code, 0);
  EXPECT_NE(help.find("cells (the cell count)"), std::string::npos) << help;
  EXPECT_NE(help.find("mesh.inp mesh.cells"), std::string::npos) << help;
  EXPECT_NE(help.find("Abaqus, any text editor"), std::string::npos) << help;
}

TEST_F(ExportRegistry, WriteExportsRunsTheRowsWriter) {
  const auto dir = vim::test::scratch_dir("export_registry", "write");
  nlohmann::json report;
  const MeshModel<3> m3 = model<3>({{3, 3, 3}});
  report["exports"] = write_exports(m3, dir / "3d", {"cells"});
  EXPECT_EQ(vim::test::slurp(dir / "3d" / "mesh.cells"), "cells " + std::to_string(m3.mesh.n_cells()) + "\n");
  EXPECT_TRUE(report["exports"]["files"].contains("cells"));
  nlohmann::json report2;
  report2["exports"] = write_exports(model<2>({{3, 3}}), dir / "2d", {"cells", "vtk"});
  EXPECT_FALSE(fs::exists(dir / "2d" / "mesh.cells"));
  EXPECT_EQ(report2["exports"]["skipped"]["cells"], "cells is written for 3D models only");
  EXPECT_TRUE(fs::exists(dir / "2d" / "mesh.vtk"));
}

TEST_F(ExportRegistry, ARunWritesAndListsTheRow) {
  const auto dir = vim::test::scratch_dir("export_registry", "run");
  write_image(phantoms::table1(10), (dir / "in.mha").string());
  int code = -1;
  const auto o = parse({(dir / "in.mha").string(), "--nodes", "27", "--max-iterations", "1", "--export",
                        "cells", "-q", "--out", (dir / "out").string()},
                       code);
  ASSERT_TRUE(o.has_value());
  ASSERT_EQ(run(*o), 0);
  EXPECT_EQ(vim::test::slurp(dir / "out" / "mesh.cells").rfind("cells ", 0), 0u);
  const auto report = nlohmann::json::parse(vim::test::slurp(dir / "out" / "report.json"));
  EXPECT_EQ(report["exports"]["files"]["cells"], "mesh.cells");
  EXPECT_NE(report.dump().find("\"mesh.cells\""), std::string::npos);
}

TEST(ExportTable, ArchitectureDocListsEveryRow) {
  const std::string doc = vim::test::slurp(fs::path(VIM_SOURCE_DIR) / "docs" / "architecture.md");
  for (const auto& row : export_table())
    EXPECT_NE(doc.find("| `" + row.name + "` | `mesh." + row.name + "` |"), std::string::npos) << row.name;
}
