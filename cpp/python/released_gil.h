// The GIL released around long C++ work, made safe for a daemon thread that is still in
// that work when Python exits.
#pragma once

#include <pybind11/pybind11.h>

#include <atomic>
#include <chrono>
#include <thread>

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

}  // namespace sss
