// Fuzz target for the model file reader: parse_decoder on the input text. A decoder that
// parses is then evaluated once by both evaluators (the scalar reference and the SIMD
// decoder), so that the layer shapes the parser accepts are checked against the code that
// relies on them.
#include <vector>

#include "fuzz/fuzz.h"
#include "nn/decoder.h"
#include "nn/simd_decoder.h"

namespace sss::fuzz {

int fuzz_model(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    return guarded([&] {
        const Decoder d = parse_decoder(text, "fuzz input");
        std::vector<float> x(size_t(d.input_width), 0.f);
        std::vector<float> mean(size_t(d.num_outputs())), logvar(size_t(d.num_outputs()));
        evaluate_reference(d, x.data(), mean.data(), logvar.data());
        const SimdDecoder simd(d);
        std::vector<float> xs(size_t(simd.input_width()), 0.f);
        std::vector<float> ms(size_t(simd.num_outputs())), ls(size_t(simd.num_outputs()));
        simd.evaluate(xs.data(), ms.data(), ls.data());
    });
}

}  // namespace sss::fuzz
