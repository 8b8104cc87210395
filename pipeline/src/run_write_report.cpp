// MeshingRun, stage 6 (meshing_run.hpp): report.json, which lists every file of the run, then the
// output folder is committed (kept) and the summary goes to stdout.
#include <chrono>
#include <iostream>
#include <vim/pipeline/atomic_file.hpp>
#include <vim/pipeline/meshing_run.hpp>
#include <vim/pipeline/report.hpp>

namespace vim::pipeline {

template <int dim>
void MeshingRun<dim>::write_report() {
  report_["timing"]["total"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  out_.file("report.json");
  report_["outputs"] = out_.files();
  write_text_atomically(out_.path() / "report.json", [&](std::ostream& s) { s << report_.dump(2) << "\n"; });
  out_.commit();
  if (options_.verbosity != Verbosity::quiet) print_summary(std::cout, report_);
}

template void MeshingRun<2>::write_report();
template void MeshingRun<3>::write_report();

}  // namespace vim::pipeline
