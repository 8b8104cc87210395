// Atomic outputs: every file is written under a temporary name in the same folder and renamed to
// its final name only when complete, so an interrupted run never leaves a valid-looking partial file.
#pragma once

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

namespace vim::pipeline {

// Temporary sibling name used while writing `final_path` (hidden, ends in .partial).
std::filesystem::path temporary_path_for(const std::filesystem::path& final_path);

// Calls write(tmp) to produce the file at a temporary path, then renames it to final_path.
// On any exception the temporary file is removed and the exception propagates.
void write_atomically(const std::filesystem::path& final_path,
                      const std::function<void(const std::filesystem::path& tmp)>& write);

// Convenience for text files: write(stream) fills the stream.
void write_text_atomically(const std::filesystem::path& final_path,
                           const std::function<void(std::ostream&)>& write);

}  // namespace vim::pipeline
