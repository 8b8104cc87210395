// Progress and log lines on stderr: `[vim  12.3s] stage: message`, with --quiet / --verbose, and an
// estimate of what is left for stages that know their total work.
#pragma once

#include <chrono>
#include <string>

namespace vim::pipeline {

enum class Verbosity { quiet = 0, normal = 1, verbose = 2 };

class Log {
 public:
  static void set_verbosity(Verbosity v);
  static Verbosity verbosity();
  static void info(const std::string& stage, const std::string& message);     // normal and verbose
  static void detail(const std::string& stage, const std::string& message);   // verbose only
  static void warning(const std::string& stage, const std::string& message);  // unless quiet
  static double elapsed_seconds();                                            // since program start
};

// A stage with `total` units of work: report(done, msg) prints at most ~once a second (and always
// the last unit) with elapsed time and the estimated time left.
class Progress {
 public:
  Progress(std::string stage, double total);
  void report(double done, const std::string& message = "");
  double seconds() const;

 private:
  std::string stage_;
  double total_;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace vim::pipeline
