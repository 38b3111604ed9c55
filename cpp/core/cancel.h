// Stopping long work that is not a render (a distance grid's build, first-hit AOVs) from
// outside it, on Ctrl-C. The work polls a StopFn between pieces of a few milliseconds at
// most, from any of its threads at once, and throws Cancelled once it returns true.
// (Renders stop through their progress callback instead: render/scheduler.h.)
#pragma once

#include <functional>
#include <stdexcept>

namespace sss {

// Not an Error (bad input): the caller asked the work to stop, and nothing it was to
// make exists.
struct Cancelled : std::runtime_error {
    Cancelled() : std::runtime_error("cancelled") {}
};

// True: stop. Must be safe to call from several threads at once. Empty: never stops.
using StopFn = std::function<bool()>;

inline void throw_if_stopped(const StopFn& stop) {
    if (stop && stop()) throw Cancelled();
}

}  // namespace sss
