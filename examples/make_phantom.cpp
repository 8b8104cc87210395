// vim-make-phantom: writes the synthetic phantoms of phantoms.hpp (the paper's Table I sphere, its
// 2D diamond and two-circle images, a 2D two-inclusion and a 3D prostate elastogram) as images.
#include <CLI/CLI.hpp>
#include <iostream>
#include <vim/pipeline/image/image_io.hpp>
#include <vim/pipeline/image/phantoms.hpp>
#include <vim/version.hpp>

using namespace vim::pipeline;

int main(int argc, char** argv) {
  std::string kind, out;
  int size = 0;
  std::uint64_t seed = 1;

  std::string kinds;
  for (const auto& n : phantoms::names()) kinds += "  " + n + ": " + phantoms::description(n) + "\n";
  CLI::App app{"vim-make-phantom: write a synthetic phantom image (float voxels, physical spacing).",
               "vim-make-phantom"};
  app.get_formatter()->column_width(26);
  app.set_version_flag("--version", std::string("vim-make-phantom ") + VIM_VERSION_STRING);
  app.add_option("kind", kind, "Phantom to write (see below)")
      ->required()
      ->type_name("KIND")
      ->check(CLI::IsMember(phantoms::names()));
  app.add_option("out", out, "Output image: .mha, .nrrd, .nii or .nii.gz")->required()->type_name("OUT");
  app.add_option("--size", size,
                 "Voxels along the first axis (default: the phantom's own, listed below; range [8, 2000])")
      ->type_name("N")
      ->check(CLI::Range(8, 2000));
  app.add_option("--seed", seed, "Noise seed for the prostate phantom (default 1)")->type_name("S");
  app.footer(
      "Phantoms:\n" + kinds +
      "\nExamples:\n  vim-make-phantom table1 table1.mha\n  vim-make-phantom prostate prostate.mha --seed 7\n"
      "  vim-make-phantom two-circles circles.nrrd --size 100");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "vim-make-phantom: error: " << e.what() << " (see vim-make-phantom --help)\n";
    return 2;
  }

  try {
    auto n = [&](int fallback) { return size > 0 ? size : fallback; };
    if (kind == "table1")
      write_image(phantoms::table1(n(100)), out);
    else if (kind == "prostate")
      write_image(phantoms::prostate(n(120), seed), out);
    else if (kind == "prostate-labels")
      write_image(phantoms::prostate_labels(n(120)), out);
    else if (kind == "diamond")
      write_image(phantoms::diamond(n(100)), out);
    else if (kind == "two-circles")
      write_image(phantoms::two_circles(n(200)), out);
    else if (kind == "two-circles-sizing")
      write_image(phantoms::two_circles_sizing(n(200)), out);
    else if (kind == "two-inclusions")
      write_image(phantoms::two_inclusions(n(120)), out);
  } catch (const std::exception& e) {
    std::cerr << "vim-make-phantom: error: " << e.what() << "\n";
    return 1;
  }
  std::cout << "vim-make-phantom: wrote " << kind << " to " << out << "\n";
  return 0;
}
