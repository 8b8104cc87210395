// The output folder of one run (output_directory.hpp).
#include <unistd.h>

#include <algorithm>
#include <system_error>
#include <vim/pipeline/common/input_error.hpp>
#include <vim/pipeline/common/output_directory.hpp>

namespace vim::pipeline {

namespace fs = std::filesystem;

OutputDirectory::OutputDirectory(fs::path dir, bool overwrite) : dir_(std::move(dir)) {
  std::error_code ec;
  if (dir_.empty()) throw InputError("--out: no output directory given");
  if (fs::exists(dir_, ec)) {
    if (!fs::is_directory(dir_, ec))
      throw InputError("--out " + dir_.string() + ": exists and is not a directory");
    if (!overwrite && !fs::is_empty(dir_, ec))
      throw InputError(
          "--out " + dir_.string() +
          ": output directory is not empty; choose a new or empty directory, or pass --overwrite");
  } else {
    // DIR is made by the first file, after the work: check now that it can be.
    fs::path ancestor = fs::absolute(dir_, ec).parent_path();
    while (!ancestor.empty() && !fs::exists(ancestor, ec) && ancestor != ancestor.parent_path())
      ancestor = ancestor.parent_path();
    if (fs::exists(ancestor, ec) && !fs::is_directory(ancestor, ec))
      throw InputError("--out " + dir_.string() + ": cannot be created: " + ancestor.string() +
                       " is not a directory");
    if (fs::is_directory(ancestor, ec) && ::access(ancestor.c_str(), W_OK) != 0)
      throw InputError("--out " + dir_.string() + ": cannot be created: " + ancestor.string() +
                       " is not writable");
  }
}

void OutputDirectory::create() {
  if (ready_) return;
  std::error_code ec;
  if (!fs::exists(dir_, ec)) {
    if (!fs::create_directories(dir_, ec) || ec)
      throw InputError("--out " + dir_.string() + ": cannot create the directory (" + ec.message() + ")");
    created_dir_ = true;
  }
  ready_ = true;
}

fs::path OutputDirectory::file(const std::string& relative) {
  create();
  const fs::path p = dir_ / relative;
  // Create intermediate folders (e.g. steps/, figures/), remembering those this run made.
  std::vector<fs::path> missing;
  for (fs::path d = p.parent_path(); d != dir_ && !d.empty() && !fs::exists(d); d = d.parent_path())
    missing.push_back(d);
  for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
    fs::create_directory(*it);
    created_subdirs_.push_back(*it);
  }
  if (std::find(relative_.begin(), relative_.end(), relative) == relative_.end()) {
    std::error_code ec;
    replaced_ = replaced_ || fs::exists(p, ec);  // a file of an earlier run (--overwrite)
    relative_.push_back(relative);
  }
  return p;
}

OutputDirectory::~OutputDirectory() {
  if (committed_ || !ready_) return;
  std::error_code ec;
  for (const auto& r : relative_) fs::remove(dir_ / r, ec);
  if (replaced_) fs::remove(dir_ / "report.json", ec);  // it lists files that are gone or not its own
  for (auto it = created_subdirs_.rbegin(); it != created_subdirs_.rend(); ++it)
    if (fs::is_empty(*it, ec)) fs::remove(*it, ec);
  if (created_dir_ && fs::is_empty(dir_, ec)) fs::remove(dir_, ec);
}

}  // namespace vim::pipeline
