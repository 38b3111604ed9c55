// The GIL released around long C++ work, made safe for a daemon thread that is still in
// that work when Python exits.
#pragma once

#include <pybind11/pybind11.h>

#include <atomic>
#include <chrono>
#include <optional>
#include <thread>

#include "core/cancel.h"

namespace sss {

// The thread that imported the module: Python's main thread, the one that runs
// Py_Finalize.
inline unsigned long& main_thread_ident() {
    static unsigned long ident = 0;
    return ident;
}

// Whether this thread must not take the GIL again: Python has begun to exit (Py_Finalize)
// and this is not the thread that does it. Python ends such a thread with pthread_exit
// when it takes the GIL, and an ending that starts in a C++ destructor (pybind11's
// gil_scoped_release) aborts the process.
inline bool gil_would_end_this_thread() {
#if PY_VERSION_HEX >= 0x030D0000
    const bool exiting = Py_IsFinalizing();
#else
    const bool exiting = _Py_IsFinalizing();
#endif
    return exiting && PyThread_get_thread_ident() != main_thread_ident();
}

// Calls into C++ that run with the GIL released, now: Py_AtExit (module.cpp) waits for
// them to reach their end, so that exit() does not tear down what they use under them.
inline std::atomic<int>& released_calls() {
    static std::atomic<int> n{0};
    return n;
}

// At a module's import: records Python's main thread, and (`wait_at_exit`) makes Python's
// exit wait, up to 10 s, for the released calls of other threads to end (a render stops
// at its next progress check, a tenth of a second, once Python is exiting).
inline void init_released_gil(bool wait_at_exit) {
    main_thread_ident() = pybind11::module_::import("threading")
                              .attr("main_thread")()
                              .attr("ident")
                              .cast<unsigned long>();
    if (wait_at_exit)
        Py_AtExit([] {
            for (int ms = 0; released_calls() > 0 && ms < 10000; ++ms)
                std::this_thread::sleep_for(std::chrono::milliseconds(1));
        });
}

// pybind11's gil_scoped_release, except that a thread whose work ends after Python began
// to exit does not take the GIL back: it waits, without touching Python, for the process
// to end (as Python 3.14 itself does with such threads).
struct __attribute__((visibility("hidden"))) ReleasedGil {
    ReleasedGil() { ++released_calls(); }
    ~ReleasedGil() {
        --released_calls();
        while (gil_would_end_this_thread())
            std::this_thread::sleep_for(std::chrono::hours(1));
    }
    pybind11::gil_scoped_release release;
};

// Ctrl-C for C++ work that runs with the GIL released and polls a StopFn (core/cancel.h):
// stop() turns true once a signal's Python handler raised (KeyboardInterrupt, or what
// the CLI's SIGTERM handler raises). Python runs its handlers on the main thread only,
// so only the thread that made this one checks, at most every 20 ms; the work's other
// threads see what it saw. Once the work has thrown Cancelled, rethrow() (GIL held)
// raises the handler's exception.
class __attribute__((visibility("hidden"))) SignalStop {
public:
    // Empty (never stops) on a thread other than Python's main one, which no signal
    // handler runs on. The work must run partly on this thread (a parallel loop does; a
    // wait for other threads would never check).
    StopFn stop() {
        if (PyThread_get_thread_ident() != main_thread_ident()) return {};
        return [this] { return poll(); };
    }
    [[noreturn]] void rethrow() {
        if (error_) throw *error_;
        throw pybind11::error_already_set();  // not reached: Cancelled comes from poll()
    }

private:
    bool poll() {
        if (stopped_) return true;
        if (std::this_thread::get_id() != owner_ || gil_would_end_this_thread())
            return false;
        const auto now = std::chrono::steady_clock::now();
        if (now - last_ < std::chrono::milliseconds(20)) return false;
        last_ = now;
        pybind11::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) {
            error_.emplace();  // takes the handler's exception
            stopped_ = true;
        }
        return stopped_;
    }

    const std::thread::id owner_ = std::this_thread::get_id();
    std::chrono::steady_clock::time_point last_{};
    std::atomic<bool> stopped_{false};
    std::optional<pybind11::error_already_set> error_;
};

}  // namespace sss
