// Determinism through the CLI (in the optimised suite: threads, not memory, are under test). Truth: the
// 1-thread run, compared bit for bit (brute force): a 3D image meshed from 2197 nodes with --sizing on at
// --threads 1, 2, 4 and 8 gives byte-identical mesh.vtu files (every array, every bit) and identical
// report.json numbers once the timings, the thread count and the output paths are taken out.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vim/pipeline/image/image_io.hpp>

#include "run_cli.hpp"

using namespace vim;
using namespace vim::pipeline;
using namespace vim::test;
using nlohmann::json;

namespace {

// Replaces every occurrence of `from` in the text of `j`, then drops the keys that measure time or
// depend on the thread count.
json comparable(const json& j, const std::string& from) {
  std::string text = j.dump();
  for (std::size_t p = text.find(from); p != std::string::npos; p = text.find(from, p))
    text.replace(p, from.size(), "OUT");
  json r = json::parse(text);
  r.erase("command_line");
  r.erase("timing");
  r["options"].erase("threads");
  for (auto& h : r["optimization"]["history"])
    for (const char* k : {"seconds", "node_seconds", "swap_seconds"}) h.erase(k);
  return r;
}

// A density image on IMAGE's grid: 1 far from the cube's corner (0, 0, 0), up to 9 close to it.
void write_sizing(const std::string& image, const std::string& sizing) {
  OrientedImage<3> img = read_image<3>(image);
  const auto& size = img.image.size;
  for (long k = 0; k < size[2]; ++k)
    for (long j = 0; j < size[1]; ++j)
      for (long i = 0; i < size[0]; ++i) {
        const double r2 = double(i * i + j * j + k * k) / double(size[0] * size[0]);
        img.image.data[i + size[0] * (j + size[1] * k)] = static_cast<float>(1.0 + 8.0 * std::exp(-4.0 * r2));
      }
  write_image<3>(img, sizing);
}

}  // namespace

TEST(DeterminismCli, SameMeshAndReportAtOneTwoFourEightThreadsWithSizing) {
  TempDir dir("determinism_cli");
  const std::string image = dir / "table1.mha", sizing = dir / "sizing.mha";
  ASSERT_EQ(run_command(VIM_PHANTOM_EXE, "table1 " + quote(image) + " --size 24").code, 0);
  write_sizing(image, sizing);
  auto run_at = [&](int threads) {
    const std::string out = dir / ("t" + std::to_string(threads));
    const CliResult r = run_pipeline(quote(image) + " --nodes 2200 --sizing " + quote(sizing) +
                                     " --max-iterations 3 --export none -q --threads " +
                                     std::to_string(threads) + " --out " + quote(out));
    EXPECT_EQ(r.code, 0) << r.err;
    return out;
  };
  const std::string one = run_at(1);
  const json report_one = json::parse(slurp(one + "/report.json"));
  ASSERT_GE(report_one["mesh"]["nodes"].get<long>(), 2000);
  ASSERT_FALSE(report_one["sizing"].is_null());
  const std::string vtu_one = slurp(one + "/mesh.vtu");
  ASSERT_GT(vtu_one.size(), 1000u);
  for (int threads : {2, 4, 8}) {
    SCOPED_TRACE(std::to_string(threads) + " threads");
    const std::string out = run_at(threads);
    EXPECT_TRUE(slurp(out + "/mesh.vtu") == vtu_one) << "mesh.vtu differs from the 1-thread run";
    const json report = json::parse(slurp(out + "/report.json"));
    EXPECT_EQ(comparable(report, out), comparable(report_one, one));
  }
}
