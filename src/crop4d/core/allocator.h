#pragma once

// Process-wide tuning of glibc's allocator for crop4d's pattern of work: every image or tile
// allocates and frees the same large buffers (the SIFT scale space of a 640×480 image, doubled
// by OpenCV, is ≈ 70 MB of float images). With glibc's defaults such blocks are mmap()ed and
// unmapped, or trimmed back to the kernel as soon as they are freed, so every image pays for
// fresh zeroed pages again: page faults took ≈ 11 % of the CPU time of `crop4d slam` on a pass
// of the demo field (perf), and keeping freed memory for reuse (the same policy set through
// glibc's tunables) took the pass's system time from 2.6–3.6 s to 0.1–0.2 s. Under
// AddressSanitizer, which has its own allocator, this does nothing.

namespace crop4d {

// Serves blocks up to 32 MiB (glibc's largest allowed threshold) from the heap instead of mmap,
// and returns freed memory to the kernel only when more than 256 MiB are free at the top of a
// heap. Call once at start-up, before threads are created. Returns false when the C library
// refused a setting (then its defaults stay; nothing else changes).
bool KeepFreedMemoryForReuse();

// Returns the memory freed so far to the kernel (glibc's malloc_trim), where the kept memory
// would otherwise stay with the process: between the stages of a run, so that what one stage
// freed neither stays resident through the next nor counts in its peak. The next stage's first
// buffers then fault in fresh pages once. Returns false where it does nothing (not glibc).
bool ReturnFreedMemory();

}  // namespace crop4d
