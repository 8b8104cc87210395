// `vim-pipeline IMAGE --simulate S.yaml --fit-forces measured.csv --out DIR` through the real CLI: a
// curve simulated by --simulate with hidden needle values is fitted from other starting values; the
// hidden values come back, DIR holds fit.json, fitted.yaml and figures/force_fit.png, and --simulate
// on fitted.yaml gives the fitted curve.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/output/png.hpp>

#include "run_cli.hpp"

using namespace vim;
using namespace vim::pipeline;
using vim::test::quote;
using vim::test::run_pipeline;
namespace fs = std::filesystem;

namespace {

std::string scenario(double cutting_force, double limit) {
  std::ostringstream s;
  s << "material: {youngs_modulus: image, poisson_ratio: 0.4}\n"
       "boundary_conditions: [{type: fixed, region: {box_face: z_max}}]\n"
       "needle: {entry: [0, 0, -8], direction: [0, 0, 1], depth: 10, steps: 10, diameter: 1, cutting_force: "
    << cutting_force << ", friction: {model: stick-slip, max_shear_per_length: " << limit
    << "}}\noutput: {every: 0}\n";
  return s.str();
}

// needle.csv's columns depth and axial_force, by header name.
std::vector<std::pair<double, double>> force_curve(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> head;
  std::stringstream hs(line);
  for (std::string c; std::getline(hs, c, ',');) head.push_back(c);
  const auto col = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(head.begin(), head.end(), name) - head.begin());
  };
  std::vector<std::pair<double, double>> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ls(line);
    for (std::string c; std::getline(ls, c, ',');) cells.push_back(c);
    rows.emplace_back(std::stod(cells.at(col("depth"))), std::stod(cells.at(col("axial_force"))));
  }
  return rows;
}

}  // namespace

TEST(CliFit, FitForcesWritesTheFitFilesAndFittedYamlReproducesTheFittedCurve) {
  vim::test::TempDir dir("clifit");
  OrientedImage<3> im;
  im.image = Image<3>({{10, 10, 16}}, {{1, 1, 1}}, {{-4.5, -4.5, -7.5}}, 15.0f);
  write_image<3>(im, dir / "block.mha");
  const std::string common = quote(dir / "block.mha") + " --mesher grid --nodes 300 --export none -q ";
  std::ofstream(dir / "hidden.yaml") << scenario(1.2, 0.3);
  const auto truth =
      run_pipeline(common + "--simulate " + quote(dir / "hidden.yaml") + " --out " + quote(dir / "truth"));
  ASSERT_EQ(truth.code, 0) << truth.err;
  const auto curve = force_curve(dir.path / "truth" / "needle.csv");
  {
    std::ofstream m(dir / "measured.csv");
    m.precision(17);
    m << "time,force,depth\n";  // extra column, other order
    for (std::size_t k = 1; k < curve.size(); ++k)
      m << k << "," << curve[k].second << "," << curve[k].first << "\n";
  }
  std::ofstream(dir / "start.yaml") << scenario(2.0, 0.15);
  const auto fit = run_pipeline(common + "--simulate " + quote(dir / "start.yaml") + " --fit-forces " +
                                quote(dir / "measured.csv") + " --out " + quote(dir / "fit"));
  ASSERT_EQ(fit.code, 0) << fit.err;
  for (const char* f : {"fit.json", "fitted.yaml", "figures/force_fit.png", "needle.csv", "report.json"})
    EXPECT_TRUE(fs::exists(dir.path / "fit" / f)) << f;
  const auto j = nlohmann::json::parse(vim::test::slurp(dir.path / "fit" / "fit.json"));
  ASSERT_EQ(j["parameters"].size(), 2u);
  EXPECT_EQ(j["parameters"][0]["name"], "needle.cutting_force");
  // needle.csv holds 6 significant digits: the values come back within 1%.
  EXPECT_NEAR(j["parameters"][0]["value"].get<double>(), 1.2, 0.012);
  EXPECT_NEAR(j["parameters"][1]["value"].get<double>(), 0.3, 0.003);
  EXPECT_GT(j["iterations"].get<int>(), 0);
  EXPECT_GE(j["parameters"][0]["standard_error"].get<double>(), 0.0);
  const Canvas png = Canvas::read_png(dir.path / "fit" / "figures" / "force_fit.png");
  EXPECT_GE(png.width(), 100);
  // --simulate runs fitted.yaml as it is, and its curve is the fitted one.
  const auto again =
      run_pipeline(common + "--simulate " + quote((dir.path / "fit" / "fitted.yaml").string()) + " --out " +
                   quote(dir / "again"));
  ASSERT_EQ(again.code, 0) << again.err;
  const auto refit = force_curve(dir.path / "again" / "needle.csv");
  const auto fitted = j["curve"]["fitted"].get<std::vector<double>>();
  ASSERT_EQ(refit.size(), fitted.size() + 1);
  for (std::size_t k = 1; k < refit.size(); ++k)
    EXPECT_NEAR(refit[k].second, fitted[k - 1], 1e-5 * std::abs(fitted[k - 1]) + 1e-9) << "step " << k;
}
