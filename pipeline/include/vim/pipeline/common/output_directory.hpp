// The output folder of one run: refuses a non-empty DIR before any work and removes what a failed
// run wrote.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace vim::pipeline {

// The output folder of one run. Files are registered before they are written so a failed run can
// remove exactly what it created (and the folder itself if this run created it and it is empty).
class OutputDirectory {
 public:
  // Throws InputError if `dir` exists, is not empty and overwrite is false (message names DIR), if it
  // exists and is not a directory, or if it cannot be created (a parent is a file, or not writable) —
  // before any work, although DIR itself is only created by the first file.
  OutputDirectory(std::filesystem::path dir, bool overwrite);
  OutputDirectory(const OutputDirectory&) = delete;
  OutputDirectory& operator=(const OutputDirectory&) = delete;
  ~OutputDirectory();

  // Creates DIR (and parents) on first use, creates the parent folders of `relative`
  // (e.g. "steps/step_0001.vtu"), records it, and returns the absolute path to write to.
  std::filesystem::path file(const std::string& relative);
  const std::filesystem::path& path() const { return dir_; }
  const std::vector<std::string>& files() const { return relative_; }

  // Call once everything is written; otherwise the destructor removes the registered files, and, if
  // they replaced files of an earlier run (--overwrite), that run's report.json, which would describe
  // files that are gone or no longer its own.
  void commit() { committed_ = true; }

 private:
  void create();
  std::filesystem::path dir_;
  bool created_dir_ = false, ready_ = false, committed_ = false, replaced_ = false;
  std::vector<std::filesystem::path> created_subdirs_;
  std::vector<std::string> relative_;
};

}  // namespace vim::pipeline
