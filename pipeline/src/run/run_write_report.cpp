// PipelineRun, stage 6 (pipeline_run.hpp): report.json, which lists every file of the run, then the
// output folder is committed (kept) and the summary goes to stdout.
#include <chrono>
#include <iostream>
#include <vim/pipeline/common/atomic_file.hpp>
#include <vim/pipeline/output/report.hpp>
#include <vim/pipeline/run/pipeline_run.hpp>

namespace vim::pipeline {

template <int dim>
void PipelineRun<dim>::write_report() {
  report_["timing"]["total"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  out().file("report.json");
  report_["outputs"] = out().files();
  write_text_atomically(out().path() / "report.json", [&](std::ostream& s) { s << report_.dump(2) << "\n"; });
  out().commit();
  if (options_.verbosity != Verbosity::quiet) print_summary(std::cout, report_);
}

template void PipelineRun<2>::write_report();
template void PipelineRun<3>::write_report();

}  // namespace vim::pipeline
