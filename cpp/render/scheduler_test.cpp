// The shared render loop on its own: a tile function whose sample k of pixel p has the
// value f(p, k), so every film sum is known in closed form.
#include "render/scheduler.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/check.h"

namespace sss {
namespace {

float value(int x, int y, int k) { return float(x + 7 * y) + 0.25f * float(k); }

// Adds value(x, y, k) for every pixel and sample of the work, counting the tiles.
struct Values {
    int width;
    std::atomic<int> tiles{0};
    bool operator()(const TileWork& w, Film& film, const std::atomic<bool>&) {
        ++tiles;
        for (int y = w.y0, i = 0; y < w.y1; ++y)
            for (int x = w.x0; x < w.x1; ++x, ++i)
                for (int k = w.s0; k < w.s1; ++k) {
                    const float v = value(x, y, k);
                    const float rgb[3] = {v, 2 * v, 0};
                    film.add_sample(size_t(i), rgb, uint64_t(k), 1);
                }
        return true;
    }
};

// Values, each tile taking `ms` milliseconds longer: renders that last long enough to
// stop.
TileFn slow_values(int ms) {
    return [ms](const TileWork& w, Film& film, const std::atomic<bool>& cancel) {
        std::this_thread::sleep_for(std::chrono::milliseconds(ms));
        Values values{w.width()};
        return values(w, film, cancel);
    };
}

ScheduleOptions options(int width, int height, int spp, int threads) {
    ScheduleOptions o;
    o.width = width;
    o.height = height;
    o.spp = spp;
    o.tile = 4;
    o.threads = threads;
    o.passes.max_size = (spp + 15) / 16;
    return o;
}

// The mean of samples 0 .. spp-1 of every pixel, and that it agrees with the film.
void expect_samples_0_to(const Scheduled& s, int width, int height, int spp) {
    RenderResult r;
    s.film.finish(spp, r);
    ASSERT_EQ(s.spp, spp);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            double mean = 0;
            for (int k = 0; k < spp; ++k) mean += value(x, y, k) / double(spp);
            const size_t p = size_t(y) * width + x;
            EXPECT_NEAR(r.image[3 * p], mean, 1e-5 * (1 + mean)) << x << "," << y;
            EXPECT_NEAR(r.image[3 * p + 1], 2 * mean, 2e-5 * (1 + mean));
            EXPECT_FLOAT_EQ(r.sphere_steps[p], 1.0f);
            EXPECT_FLOAT_EQ(r.events[p], float(spp - 1) / 2);
        }
}

TEST(Scheduler, EveryPixelGetsEverySampleOnceOnAnyThreadCount) {
    // 10 x 7 pixels in 4 x 4 tiles: partial tiles in the last row and column.
    for (int threads : {0, 1, 3}) {
        Values values{10};
        const Scheduled s = schedule(options(10, 7, 40, threads), std::ref(values), {});
        expect_samples_0_to(s, 10, 7, 40);
        EXPECT_FALSE(s.cancelled || s.time_limit_reached);
        // Passes 1, 2, 3, 3, ... (growth 2, at most ceil(40/16) = 3): 1 + 2 + 3 * 12 + 1
        // = 40 in 15 passes of 6 tiles.
        EXPECT_EQ(values.tiles, 15 * 6) << threads;
    }
}

TEST(Scheduler, FilmIsBitIdenticalForAnyThreadCount) {
    auto image = [](int threads) {
        Values values{9};
        RenderResult r;
        const Scheduled s = schedule(options(9, 9, 33, threads), std::ref(values), {});
        s.film.finish(s.spp, r);
        return r.image;
    };
    const std::vector<float> one = image(1);
    EXPECT_EQ(image(0), one);
    EXPECT_EQ(image(4), one);
}

TEST(Scheduler, CancelKeepsWholePasses) {
    for (int threads : {0, 2}) {
        // A slow tile function, stopped at the 12th progress call: on the calling thread
        // (threads = 0) that call comes before the 12th tile, the third of pass 1 (9
        // tiles a pass), so pass 0 alone is kept; with workers it comes after about 1.1
        // s.
        std::atomic<int> calls{0};
        const TileFn slow = slow_values(2);
        ScheduleOptions o = options(12, 12, 1 << 12, threads);
        o.passes.max_size = 4;  // about 1000 passes of 9 tiles: seconds
        const Scheduled s = schedule(o, slow, [&](double) { return ++calls < 12; });
        EXPECT_TRUE(s.cancelled);
        if (threads == 0) {
            EXPECT_EQ(s.spp, 1);
        }
        EXPECT_GE(s.spp, 1);
        EXPECT_LT(s.spp, 1 << 12);
        expect_samples_0_to(s, 12, 12, s.spp);
        EXPECT_EQ(calls, 12);  // no call after the one that cancelled
    }
}

TEST(Scheduler, TimeLimitStopsAfterTheFirstPassWithWholePasses) {
    for (int threads : {0, 2}) {
        const TileFn slow = slow_values(5);
        ScheduleOptions o = options(8, 8, 1 << 20, threads);
        o.time_limit = 0.2;
        o.passes.max_size = 1 << 16;
        o.passes.target_seconds = o.time_limit / 16;
        const Scheduled s = schedule(o, slow, {});
        EXPECT_TRUE(s.time_limit_reached);
        EXPECT_GE(s.spp, 1);
        EXPECT_LT(s.seconds, 10.0);
        expect_samples_0_to(s, 8, 8, s.spp);
    }
}

TEST(Scheduler, AnExceptionOfATileStopsTheRenderAndIsRethrown) {
    for (int threads : {0, 1, 3}) {
        std::atomic<int> tiles{0};
        auto failing = [&](const TileWork& w, Film&, const std::atomic<bool>&) {
            if (++tiles == 5) fail("tile at ", w.x0, ",", w.y0, " failed");
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
            return true;
        };
        // 18 passes (1, 2, 4, ..., 4, 1) of 16 tiles: 288 tiles if it went on.
        EXPECT_THROW(schedule(options(16, 16, 64, threads), failing, {}), Error);
        EXPECT_LT(tiles, 100) << "the render went on after the error";
    }
}

TEST(Scheduler, AnExceptionOfTheProgressCallbackIsRethrownOnceTheWorkersEnded) {
    for (int threads : {0, 2}) {
        const TileFn slow = slow_values(5);
        ScheduleOptions o = options(8, 8, 1 << 12, threads);
        o.passes.max_size = 1;
        EXPECT_THROW(
            schedule(o, slow,
                     [](double) -> bool { throw std::runtime_error("callback"); }),
            std::runtime_error);
    }
}

}  // namespace
}  // namespace sss
