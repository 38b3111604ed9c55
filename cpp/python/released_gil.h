// The GIL released around long C++ work, made safe for a daemon thread that is still in
// that work when Python exits.
#pragma once

#include <pybind11/pybind11.h>

#include <chrono>
#include <thread>

namespace sss {

// Whether Python has begun to exit (Py_Finalize). From then on a thread other than the
// exiting one that takes the GIL is ended by Python with pthread_exit, and an ending
// that starts in a C++ destructor (pybind11's gil_scoped_release) aborts the process.
inline bool python_exiting() {
#if PY_VERSION_HEX >= 0x030D0000
    return Py_IsFinalizing();
#else
    return _Py_IsFinalizing();
#endif
}

// pybind11's gil_scoped_release, except that a thread whose work ends after Python began
// to exit does not take the GIL back: it waits, without touching Python, for the process
// to end (as Python 3.14 itself does with such threads).
struct __attribute__((visibility("hidden"))) ReleasedGil {
    pybind11::gil_scoped_release release;
    ~ReleasedGil() {
        while (python_exiting()) std::this_thread::sleep_for(std::chrono::hours(1));
    }
};

}  // namespace sss
