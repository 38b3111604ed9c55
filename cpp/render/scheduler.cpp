#include "render/scheduler.h"

#include <cxxabi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include "core/check.h"

namespace sss {

namespace {

// Passes a tile may run ahead of the film (the passes every tile has finished): at most
// this many passes of tiles wait in memory for a slow tile.
constexpr int kPassesAhead = 4;

// The state of one schedule() call. Tasks are numbered pass by pass:
// task = pass * num_tiles + tile.
class PassRunner {
public:
    PassRunner(const ScheduleOptions& options, const TileFn& render_tile)
        : opt_(options),
          render_tile_(render_tile),
          row0_(options.row0),
          row1_(options.row1 > 0 ? options.row1 : options.height),
          tiles_x_((options.width + options.tile - 1) / options.tile),
          num_tiles_(tiles_x_ * ((row1_ - row0_ + options.tile - 1) / options.tile)),
          pixels_(size_t(options.width) * (row1_ - row0_)),
          timed_(options.time_limit > 0.0),
          film_(size_t(options.width) * options.height) {}

    Scheduled run(const ProgressFn& progress) {
        start_ = std::chrono::steady_clock::now();
        Scheduled s;
        if (opt_.threads == 0)
            run_inline(progress, s);
        else
            run_threads(progress, s);
        if (error_) std::rethrow_exception(error_);
        if (progress && !s.cancelled) progress(1.0);
        s.spp = pass_starts_[passes_merged_];
        s.seconds = elapsed();
        s.film = std::move(film_);
        return s;
    }

private:
    double elapsed() const {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_)
            .count();
    }

    // The fraction done for the progress callback.
    double fraction() const {
        double f = double(done_samples_) / (double(pixels_) * opt_.spp);
        if (timed_) f = std::max(f, elapsed() / opt_.time_limit);
        return std::min(1.0, f);
    }

    // Whether the time limit has come (once a pass is in). Under film_mutex_ or on the
    // only thread.
    bool out_of_time() const {
        return timed_ && passes_merged_ > 0 && elapsed() >= opt_.time_limit;
    }

    // The samples [s0, s1) of pass p, or false when the passes before it hold all spp.
    // Passes are sized as the first tile reaches them (PassPolicy).
    bool pass_bounds(int p, int& s0, int& s1) {
        std::lock_guard<std::mutex> lock(schedule_mutex_);
        const PassPolicy& policy = opt_.passes;
        while (int(pass_starts_.size()) <= p + 1 && pass_starts_.back() < opt_.spp) {
            int size = last_size_ == 0
                           ? policy.first
                           : std::min(policy.growth * last_size_, policy.max_size);
            size = std::max(1, size);
            double seconds = policy.target_seconds;
            if (timed_) seconds = std::min(seconds, opt_.time_limit - elapsed());
            const double spp_done = double(done_samples_) / double(pixels_),
                         t = elapsed();
            if (std::isfinite(seconds) && spp_done > 0 && t > 0)
                size = int(std::clamp(spp_done / t * seconds, 1.0, double(size)));
            last_size_ = size;
            pass_starts_.push_back(std::min(opt_.spp, pass_starts_.back() + size));
        }
        if (int(pass_starts_.size()) <= p + 1) return false;
        s0 = pass_starts_[p];
        s1 = pass_starts_[p + 1];
        return true;
    }

    TileWork tile_work(int tile, int s0, int s1) const {
        const int x0 = (tile % tiles_x_) * opt_.tile,
                  y0 = row0_ + (tile / tiles_x_) * opt_.tile;
        return {
            x0, y0, std::min(opt_.width, x0 + opt_.tile), std::min(row1_, y0 + opt_.tile),
            s0, s1};
    }

    // Under film_mutex_: adds every pass all tiles have finished, in order.
    void merge_finished_passes() {
        for (auto it = pending_.begin();
             it != pending_.end() && it->first == passes_merged_ &&
             tiles_finished_[passes_merged_] == num_tiles_;
             it = pending_.erase(it)) {
            for (int tile = 0; tile < num_tiles_; ++tile) {
                const TileWork w = tile_work(tile, 0, 0);
                for (int y = w.y0, i = 0; y < w.y1; ++y)
                    for (int x = w.x0; x < w.x1; ++x, ++i)
                        film_.add_pixel(size_t(y) * opt_.width + x, it->second[tile], i);
            }
            tiles_finished_.erase(passes_merged_);
            ++passes_merged_;
            film_changed_.notify_all();
        }
    }

    // Stops every worker, also those waiting for the film.
    void stop() {
        cancel_ = true;
        std::lock_guard<std::mutex> lock(film_mutex_);
        film_changed_.notify_all();
    }

    // The work of a task once its pass may start; false when the passes before it hold
    // all spp or the render stops.
    bool claim(int64_t task, TileWork& work) {
        const int pass = int(task / num_tiles_);
        int s0, s1;
        if (!pass_bounds(pass, s0, s1)) return false;
        {
            std::unique_lock<std::mutex> lock(film_mutex_);
            film_changed_.wait(
                lock, [&] { return pass < passes_merged_ + kPassesAhead || cancel_; });
        }
        work = tile_work(int(task % num_tiles_), opt_.first_sample + s0,
                         opt_.first_sample + s1);
        return !cancel_;
    }

    // Renders a claimed task and files its tile; false when the render stops.
    bool render(int64_t task, const TileWork& work) {
        const int pass = int(task / num_tiles_), tile = int(task % num_tiles_);
        Film film(size_t(work.pixels()));
        if (!render_tile_(work, film, cancel_)) {
            stop();  // a tile only stops for a cancel; no worker may wait for it
            return false;
        }
        done_samples_ += int64_t(work.pixels()) * (work.s1 - work.s0);
        std::lock_guard<std::mutex> lock(film_mutex_);
        if (cancel_) return false;  // nothing is added after a stop
        std::vector<Film>& row = pending_[pass];
        if (row.empty()) row.resize(num_tiles_, Film(0));
        row[tile] = std::move(film);
        ++tiles_finished_[pass];
        merge_finished_passes();
        return true;
    }

    // threads == 0: the tasks in order on the calling thread, progress and the time
    // limit between them.
    void run_inline(const ProgressFn& progress, Scheduled& s) {
        TileWork work;
        for (int64_t task = 0; claim(task, work); ++task) {
            if (out_of_time()) {
                s.time_limit_reached = true;
                return;
            }
            if (progress && !progress(fraction())) {
                s.cancelled = true;
                return;
            }
            if (!render(task, work)) return;
        }
    }

    // Worker threads of its own, not oneTBB's pool (core/parallel.h): a worker blocks
    // while it is kPassesAhead passes ahead of the film, and the calling thread must stay
    // free to report progress and answer Ctrl-C (Python checks signals on it) about ten
    // times a second, which no task is short enough to allow between tasks; TBB counts
    // the calling thread as one of its pool's workers, so its own workers alone would
    // leave a core idle.
    void run_threads(const ProgressFn& progress, Scheduled& s) {
        std::mutex done_mutex;
        std::condition_variable done_cv;
        int running = opt_.threads;
        std::vector<std::thread> pool;
        // The first exception of a worker or of the progress callback stops the render;
        // schedule() rethrows it once every worker has ended.
        auto keep_error = [&] {
            {
                std::lock_guard<std::mutex> lock(done_mutex);
                if (!error_) error_ = std::current_exception();
            }
            stop();
        };
        auto work = [&] {
            TileWork work;
            while (!cancel_) {
                const int64_t task = next_task_++;
                if (!claim(task, work) || !render(task, work)) return;
            }
        };
        for (int t = 0; t < opt_.threads; ++t)
            pool.emplace_back([&] {
                try {
                    work();
                } catch (...) {
                    keep_error();
                }
                std::lock_guard<std::mutex> lock(done_mutex);
                --running;
                done_cv.notify_all();
            });
        std::unique_lock<std::mutex> lock(done_mutex);
        while (running > 0) {
            double wait = 0.1;
            if (timed_) wait = std::clamp(opt_.time_limit - elapsed(), 0.001, wait);
            done_cv.wait_for(lock, std::chrono::duration<double>(wait));
            if (running == 0) break;
            lock.unlock();
            if (!s.cancelled && !s.time_limit_reached) {
                {
                    std::lock_guard<std::mutex> film_lock(film_mutex_);
                    s.time_limit_reached = out_of_time();
                }
                try {
                    if (!s.time_limit_reached && progress && !progress(fraction()))
                        s.cancelled = true;
                } catch (abi::__forced_unwind&) {
                    // This thread is being ended (pthread_exit: the progress callback
                    // waited for Python's lock while Python exited): the workers, which
                    // use this stack, end first, then the unwinding goes on.
                    stop();
                    for (std::thread& t : pool) t.join();
                    throw;
                } catch (...) {
                    keep_error();
                    s.cancelled = true;
                }
                if (s.cancelled || s.time_limit_reached) stop();
            }
            lock.lock();
        }
        lock.unlock();
        for (std::thread& t : pool) t.join();
    }

    const ScheduleOptions& opt_;
    const TileFn& render_tile_;
    const int row0_, row1_;  // the rows rendered
    const int tiles_x_, num_tiles_;
    const size_t pixels_;  // rendered
    const bool timed_;
    std::chrono::steady_clock::time_point start_;

    std::mutex schedule_mutex_;  // pass_starts_, last_size_
    std::vector<int> pass_starts_{0};
    int last_size_ = 0;

    std::atomic<int64_t> next_task_{0};
    std::atomic<int64_t> done_samples_{0};  // rendered, merged or not
    std::atomic<bool> cancel_{false};
    std::exception_ptr error_;  // the first exception a worker threw

    std::mutex film_mutex_;  // the members below
    std::condition_variable film_changed_;
    Film film_;
    std::map<int, std::vector<Film>> pending_;  // pass -> its finished tiles
    std::map<int, int> tiles_finished_;         // pass -> how many
    int passes_merged_ = 0;
};

}  // namespace

Scheduled schedule(const ScheduleOptions& options, const TileFn& render_tile,
                   const ProgressFn& progress) {
    SSS_CHECK(options.width > 0 && options.height > 0 && options.spp > 0 &&
              options.first_sample >= 0 && options.row0 >= 0 && options.row1 >= 0 &&
              options.row1 <= options.height &&
              options.row0 < (options.row1 > 0 ? options.row1 : options.height) &&
              options.tile > 0 && options.threads >= 0 && options.time_limit >= 0.0);
    return PassRunner(options, render_tile).run(progress);
}

}  // namespace sss
