// Parallel loops on oneTBB's thread pool, the one pool of the program (Embree builds its
// BVHs on it too): threads are made once per process, not per loop. The CPU renderer
// keeps threads of its own (render/renderer.cpp says why).
#pragma once

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <cstdint>

namespace sss {

// Threads for a loop asked to run on `threads` (<= 0: every core this process may use).
inline int worker_threads(int threads) {
    return threads > 0 ? threads : std::max(1, tbb::info::default_concurrency());
}

// Calls body(begin, end) for the chunks [0, grain), [grain, 2 grain), ... of [0, n), the
// last one shorter, on at most `threads` threads (<= 0: every core; 1: in order, on the
// calling thread). The chunks do not depend on the thread count, so a body whose results
// depend on the indices alone gives the same results on any number of threads. Chunks
// are handed out one at a time: uneven chunk costs balance. The first exception a body
// throws is rethrown here (chunks not started by then may not run).
template <class Body>
void parallel_chunks(int threads, int64_t n, int64_t grain, Body&& body) {
    if (n <= 0) return;
    grain = std::max<int64_t>(1, grain);
    const int64_t chunks = (n + grain - 1) / grain;
    auto run = [&](int64_t c) { body(c * grain, std::min(n, (c + 1) * grain)); };
    const int64_t T = std::min<int64_t>(worker_threads(threads), chunks);
    if (T <= 1) {
        for (int64_t c = 0; c < chunks; ++c) run(c);
        return;
    }
    tbb::task_arena arena{static_cast<int>(T)};
    arena.execute([&] {
        tbb::parallel_for(
            tbb::blocked_range<int64_t>(0, chunks, 1),
            [&](const tbb::blocked_range<int64_t>& r) {
                for (int64_t c = r.begin(); c != r.end(); ++c) run(c);
            },
            tbb::simple_partitioner());
    });
}

}  // namespace sss
