#pragma once

// Wall-clock timing of stages and phases: the seconds that summaries, reports and run records
// give.

#include <chrono>

namespace crop4d {

// Seconds elapsed since `start` on the steady clock.
inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace crop4d
