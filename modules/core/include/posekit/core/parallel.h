#pragma once
// posekit's one thread helper: work split over threads, exceptions carried back to the caller.
#include <functional>

namespace posekit {

/// The threads to use for `requested`: itself when positive, else the hardware's (at least 1).
int resolve_threads(int requested);

/// Runs body(begin, end) over [0, n) split into contiguous chunks on `threads` threads (0: the
/// hardware's), each with at least `min_items_per_thread` items; the calling thread takes a chunk too.
/// For work of even cost per item; the chunks do not depend on timing, so a result summed chunk by
/// chunk is the same on every run. An exception thrown by body is rethrown once every thread has finished.
void parallel_for_ranges(long n, int threads, const std::function<void(long, long)>& body, long min_items_per_thread = 1024);

/// Runs item(i) for every i in [0, n), handed out one at a time to `threads` threads (0: the
/// hardware's), the calling thread among them: for items of uneven cost (a subject's fit, a body's
/// layers). After an exception no new item starts; the first one is rethrown once every thread has finished.
void parallel_for_each(long n, int threads, const std::function<void(long)>& item);

/// Runs `beside` on a second thread while `main` runs on this one, and returns when both have ended
/// (with `threads` < 2: beside, then main); an exception of either is rethrown then, main's first.
void run_beside(int threads, const std::function<void()>& beside, const std::function<void()>& main);

}  // namespace posekit
