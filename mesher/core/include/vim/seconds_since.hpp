// Wall time of a stage: the steady clock and the seconds elapsed since a point of it (the timings of the
// mesher's history and of the pipeline's report).
#pragma once

#include <chrono>

namespace vim {

using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

}  // namespace vim
