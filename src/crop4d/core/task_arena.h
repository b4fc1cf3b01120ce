#pragma once

// Running a parallel section on a bounded number of threads (an option `num_threads`).

#include <tbb/task_arena.h>

namespace crop4d {

// Runs `body` in a TBB arena of `num_threads` threads, so that the parallel loops inside it use
// at most that many; 0 or less runs it in the caller's arena (all cores by default).
template <typename Body>
void InArena(int num_threads, Body&& body) {
  if (num_threads <= 0) {
    body();
    return;
  }
  tbb::task_arena arena(num_threads);
  arena.execute(body);
}

}  // namespace crop4d
