// Temporary-name-then-rename writes (see atomic_file.hpp).
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <vim/pipeline/common/atomic_file.hpp>

namespace vim::pipeline {

namespace fs = std::filesystem;

fs::path temporary_path_for(const fs::path& final_path) {
  static std::atomic<unsigned> counter{0};
  const fs::path dir = final_path.has_parent_path() ? final_path.parent_path() : fs::path(".");
  return dir / ("." + final_path.filename().string() + "." + std::to_string(::getpid()) + "." +
                std::to_string(counter++) + ".partial");
}

void write_atomically(const fs::path& final_path, const std::function<void(const fs::path&)>& write) {
  const fs::path tmp = temporary_path_for(final_path);
  try {
    write(tmp);
    if (!fs::exists(tmp)) throw std::runtime_error("writer produced no file for " + final_path.string());
    fs::rename(tmp, final_path);
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
}

void write_text_atomically(const fs::path& final_path, const std::function<void(std::ostream&)>& write) {
  write_atomically(final_path, [&](const fs::path& tmp) {
    std::ofstream out(tmp);
    if (!out) throw std::runtime_error("cannot open " + tmp.string() + " for writing");
    out.precision(17);
    errno = 0;
    write(out);
    out.close();
    if (!out) {
      // errno of the failed write() (EFBIG, ENOSPC, EIO, ...), as the VTK and PNG writers report it.
      const std::string why = errno != 0 ? std::string(": ") + std::strerror(errno) : std::string();
      throw std::runtime_error("cannot write " + final_path.string() + why + " (is the disk full?)");
    }
  });
}

}  // namespace vim::pipeline
