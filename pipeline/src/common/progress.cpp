// Log and Progress (see progress.hpp).
#include <cstdio>
#include <mutex>
#include <vim/pipeline/common/progress.hpp>

namespace vim::pipeline {

namespace {
Verbosity g_verbosity = Verbosity::normal;
const auto g_start = std::chrono::steady_clock::now();
std::mutex g_mutex;

void emit(const char* level, const std::string& stage, const std::string& message) {
  std::lock_guard<std::mutex> lock(g_mutex);
  std::fprintf(stderr, "[vim %7.1fs] %s%s: %s\n", Log::elapsed_seconds(), level, stage.c_str(),
               message.c_str());
  std::fflush(stderr);
}
}  // namespace

void Log::set_verbosity(Verbosity v) { g_verbosity = v; }
Verbosity Log::verbosity() { return g_verbosity; }
double Log::elapsed_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - g_start).count();
}
void Log::info(const std::string& stage, const std::string& message) {
  if (g_verbosity >= Verbosity::normal) emit("", stage, message);
}
void Log::detail(const std::string& stage, const std::string& message) {
  if (g_verbosity >= Verbosity::verbose) emit("", stage, message);
}
void Log::warning(const std::string& stage, const std::string& message) {
  if (g_verbosity >= Verbosity::normal) emit("warning: ", stage, message);
}

Progress::Progress(std::string stage, double total)
    : stage_(std::move(stage)), total_(total), start_(std::chrono::steady_clock::now()), last_(start_) {}

double Progress::seconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::report(double done, const std::string& message) {
  const auto now = std::chrono::steady_clock::now();
  const bool last = done >= total_;
  // At most one line a second, except with --verbose (every call) and for the last one.
  if (!last && g_verbosity < Verbosity::verbose && std::chrono::duration<double>(now - last_).count() < 1.0)
    return;
  last_ = now;
  const double elapsed = seconds();
  char buf[160];
  if (total_ > 0 && done > 0 && !last) {
    const double left = elapsed * (total_ - done) / done;
    std::snprintf(buf, sizeof buf, "%.0f/%.0f (%.0f%%), %.1fs elapsed, ~%.1fs left", done, total_,
                  100.0 * done / total_, elapsed, left);
  } else {
    std::snprintf(buf, sizeof buf, "%.0f/%.0f, %.1fs elapsed", done, total_, elapsed);
  }
  Log::info(stage_, std::string(buf) + (message.empty() ? "" : " — " + message));
}

}  // namespace vim::pipeline
