// Parallel loops on oneTBB's thread pool, the one pool of the program (Embree builds its
// BVHs on it too): threads are made once per process, not per loop. The render loop
// keeps threads of its own (render/scheduler.cpp says why).
#pragma once

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <cstdint>

// ThreadSanitizer cannot see oneTBB's synchronisation (libtbb is not instrumented): it
// would report every hand-over of a chunk as a race. Under TSan the same chunks run on
// plain threads, so that what TSan checks is our code (docs/fuzzing.md).
#if defined(__SANITIZE_THREAD__)
#define SSS_PARALLEL_PLAIN_THREADS 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define SSS_PARALLEL_PLAIN_THREADS 1
#endif
#endif
#ifdef SSS_PARALLEL_PLAIN_THREADS
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>
#endif

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
#ifdef SSS_PARALLEL_PLAIN_THREADS
    std::atomic<int64_t> next{0};
    std::exception_ptr error;
    std::mutex error_mutex;
    auto work = [&] {
        try {
            for (int64_t c; (c = next.fetch_add(1)) < chunks;) run(c);
        } catch (...) {
            std::lock_guard<std::mutex> lock(error_mutex);
            if (!error) error = std::current_exception();
            next = chunks;
        }
    };
    std::vector<std::thread> pool;
    for (int64_t t = 1; t < T; ++t) pool.emplace_back(work);
    work();
    for (std::thread& t : pool) t.join();
    if (error) std::rethrow_exception(error);
#else
    tbb::task_arena arena{static_cast<int>(T)};
    arena.execute([&] {
        tbb::parallel_for(
            tbb::blocked_range<int64_t>(0, chunks, 1),
            [&](const tbb::blocked_range<int64_t>& r) {
                for (int64_t c = r.begin(); c != r.end(); ++c) run(c);
            },
            tbb::simple_partitioner());
    });
#endif
}

}  // namespace sss
