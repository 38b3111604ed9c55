// The libFuzzer entry point of one target: built once per target (cpp/CMakeLists.txt),
// with SSS_FUZZ_FUNCTION naming its function in fuzz/fuzz.h.
#include "fuzz/fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    return sss::fuzz::SSS_FUZZ_FUNCTION(data, size);
}
