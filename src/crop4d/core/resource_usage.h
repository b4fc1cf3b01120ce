#pragma once

// The CPU time and resident memory of this process, for the per-stage figures of run records
// (pipeline/run_log.h) and the scaling bench (bench/season_scale.sh).

namespace crop4d {

// User + system CPU seconds of every thread of this process since it started (getrusage).
double ProcessCpuSeconds();

// The peak resident set size, MB (10^6 bytes), since the process started or since the last
// ResetPeakResidentMemory (VmHWM of /proc/self/status); NaN where it cannot be read.
double PeakResidentMemoryMb();

// Restarts the peak at the current resident size (writes 5 to /proc/self/clear_refs; Linux 4.0
// or later), so that PeakResidentMemoryMb covers what follows. False where it cannot.
bool ResetPeakResidentMemory();

}  // namespace crop4d
