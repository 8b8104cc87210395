// Every XML file the pipeline writes (.feb, .vtu, .pvtu, .pvd) is well-formed XML, read by VTK's
// expat-based parser (vtkXMLDataParser, which also reads a .vtu's appended data): the files of a
// mesh-only run with every export, of a needle simulation with --export feb, and a .pvtu from its
// writer (a serial run writes none). A comment holding "--" (not allowed in XML) is refused by the parser.
#include <gtest/gtest.h>
#include <vtkNew.h>
#include <vtkXMLDataElement.h>
#include <vtkXMLDataParser.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/image/phantoms.hpp>
#include <vim/pipeline/output/vtk_output.hpp>

#include "run_cli.hpp"

namespace fs = std::filesystem;
using namespace vim;
using namespace vim::pipeline;
using vim::test::quote;
using vim::test::run_pipeline;

namespace {

// True if the file parses as XML; its root element's name in `root`.
bool parses(const fs::path& file, std::string* root = nullptr) {
  vtkNew<vtkXMLDataParser> parser;
  parser->SetFileName(file.c_str());
  if (parser->Parse() != 1) return false;
  if (root && parser->GetRootElement()) *root = parser->GetRootElement()->GetName();
  return parser->GetRootElement() != nullptr;
}

// Every .feb, .vtu, .vtp, .pvtu and .pvd under `dir` parses; returns how many of each extension there are.
std::map<std::string, int> check_xml_files(const fs::path& dir) {
  std::map<std::string, int> count;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string ext = e.path().extension().string();
    if (ext != ".feb" && ext != ".vtu" && ext != ".vtp" && ext != ".pvtu" && ext != ".pvd") continue;
    ++count[ext];
    std::string root;
    EXPECT_TRUE(parses(e.path(), &root)) << e.path() << " is not well-formed XML";
    EXPECT_EQ(root, ext == ".feb" ? "febio_spec" : "VTKFile") << e.path();
  }
  return count;
}

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

}  // namespace

TEST(XmlOutputs, TheParserRefusesADoubleHyphenInAComment) {
  vim::test::TempDir dir("xml_control");
  write_text(dir / "good.xml", "<?xml version=\"1.0\"?>\n<!-- a - b -->\n<r/>\n");
  write_text(dir / "bad.xml", "<?xml version=\"1.0\"?>\n<!-- run with --simulate -->\n<r/>\n");
  EXPECT_TRUE(parses(dir / "good.xml"));
  EXPECT_FALSE(parses(dir / "bad.xml"));
}

TEST(XmlOutputs, MeshOnlyRunWritesWellFormedXml) {
  vim::test::TempDir dir("xml_mesh");
  write_image(phantoms::table1(10), dir / "in.mha");
  const fs::path out = dir.path / "out";
  const auto r = run_pipeline(quote(dir / "in.mha") +
                              " --nodes 64 --max-iterations 2 --export all -q --out " + quote(out.string()));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto count = check_xml_files(out);
  EXPECT_EQ(count.count(".feb") ? count.at(".feb") : 0, 1);  // the mesh-only deck, with its comments
  EXPECT_EQ(count.count(".vtu") ? count.at(".vtu") : 0, 1);
}

TEST(XmlOutputs, SimulationRunWritesWellFormedXml) {
  vim::test::TempDir dir("xml_sim");
  write_image(phantoms::table1(10), dir / "in.mha");
  write_text(dir / "needle.yaml",
             "material: {youngs_modulus: image, scale: 10.0, poisson_ratio: 0.45}\n"
             "boundary_conditions:\n"
             "  - {type: fixed, region: {box_face: z_max}}\n"
             "needle:\n"
             "  name: a--b\n"
             "  entry: [1.5, 1.5, 0.0]\n"
             "  direction: [0, 0, 1]\n"
             "  depth: 1.5\n"
             "  steps: 3\n"
             "  diameter: 0.1\n"
             "  model: kinematic\n"
             "  friction: {model: stick}\n");
  const fs::path out = dir.path / "out";
  const auto r =
      run_pipeline(quote(dir / "in.mha") + " --nodes 64 --max-iterations 2 --export feb --simulate " +
                   quote(dir / "needle.yaml") + " -q --out " + quote(out.string()));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto count = check_xml_files(out);
  EXPECT_EQ(count.count(".feb") ? count.at(".feb") : 0, 1);      // with the needle's name in a comment
  EXPECT_GE(count.count(".vtu") ? count.at(".vtu") : 0, 1 + 4);  // mesh.vtu and steps 0..3
  EXPECT_EQ(count.count(".vtp") ? count.at(".vtp") : 0, 4);      // the needle at steps 0..3
  EXPECT_EQ(count.count(".pvd") ? count.at(".pvd") : 0, 1);
}

TEST(XmlOutputs, PvtuIsWellFormedXml) {
  vim::test::TempDir dir("xml_pvtu");
  UnstructuredGrid fields;
  fields.point_data["displacement"] = Field{3, {}};
  fields.point_data["a<b&\"c\""] = Field{2, {}};
  fields.cell_data["youngs_modulus"] = Field{1, {}};
  write_pvtu(dir / "step_0001.pvtu", 3, fields);
  std::string root;
  EXPECT_TRUE(parses(dir / "step_0001.pvtu", &root));
  EXPECT_EQ(root, "VTKFile");
  write_pvd(dir / "simulation.pvd", {{0.0, "steps/step_0000.pvtu"}, {1.5, "steps/a&b\"<c>.pvtu"}});
  EXPECT_TRUE(parses(dir / "simulation.pvd", &root));
}
