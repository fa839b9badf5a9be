// SPDX-License-Identifier: Apache-2.0
// Exceptions thrown by hapticopt's public functions (never inside a real-time loop: the
// analysis runs at startup).
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace hapticopt {

/// A parameter is NaN, infinite or outside its accepted range. The message reads
/// "<function>: <parameter> = <value> is invalid; accepted range: <range>".
class InvalidParameter : public std::invalid_argument {
  public:
    InvalidParameter(const std::string& function, const std::string& parameter, double value,
                     const std::string& accepted_range)
        : std::invalid_argument(compose(function, parameter, value, accepted_range)),
          parameter_(parameter),
          value_(value) {}

    const std::string& parameter() const noexcept { return parameter_; }
    double value() const noexcept { return value_; }

  private:
    static std::string compose(const std::string& function, const std::string& parameter, double value,
                               const std::string& accepted_range) {
        std::ostringstream out;
        out.precision(17);
        out << function << ": " << parameter << " = " << value << " is invalid; accepted range: " << accepted_range;
        return out.str();
    }

    std::string parameter_;
    double value_;
};

namespace detail {

/// Throws InvalidParameter unless `value` is finite and `lower <= value` (or `lower < value`
/// when `strict`), and `value <= upper`.
inline void require_in_range(const char* function, const char* parameter, double value, double lower, bool strict_lower,
                             double upper, const char* accepted_range) {
    const bool ok = std::isfinite(value) && (strict_lower ? value > lower : value >= lower) && value <= upper;
    if (!ok) throw InvalidParameter(function, parameter, value, accepted_range);
}

inline void require_positive(const char* function, const char* parameter, double value) {
    require_in_range(function, parameter, value, 0.0, true, HUGE_VAL, "finite and > 0");
}

inline void require_non_negative(const char* function, const char* parameter, double value) {
    require_in_range(function, parameter, value, 0.0, false, HUGE_VAL, "finite and >= 0");
}

inline void require_finite(const char* function, const char* parameter, double value) {
    require_in_range(function, parameter, value, -HUGE_VAL, false, HUGE_VAL, "finite");
}

}  // namespace detail
}  // namespace hapticopt
