// Statistics shared by the C++ tests: chi-square critical values without a stats library.
#pragma once

#include <cmath>

namespace sss::test {

// Upper critical value of the chi-square distribution with `dof` degrees of freedom at
// the standard-normal quantile z (z = 3.719 for p = 1e-4), by the Wilson-Hilferty
// approximation (accurate to a few percent for dof >= 5).
inline double chi2_critical(int dof, double z = 3.719) {
    double k = dof, a = 2.0 / (9.0 * k);
    return k * std::pow(1.0 - a + z * std::sqrt(a), 3.0);
}

}  // namespace sss::test
