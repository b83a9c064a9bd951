// Boundary checks of the foreign simulator: one-line std::invalid_argument messages naming the
// field and its allowed range.
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace fesim::foreign {

/// Throws std::invalid_argument "foreign: FIELD = V, allowed [LO, HI]" unless lo ≤ v ≤ hi (and v is
/// not NaN).
inline void CheckRange(double value, double lo, double hi, const std::string& field) {
  if (!(value >= lo && value <= hi)) {
    std::ostringstream msg;
    msg << "foreign: " << field << " = " << value << ", allowed [" << lo << ", " << hi << "]";
    throw std::invalid_argument(msg.str());
  }
}

/// As CheckRange with an open lower end: lo < v ≤ hi.
inline void CheckAbove(double value, double lo, double hi, const std::string& field) {
  if (!(value > lo && value <= hi)) {
    std::ostringstream msg;
    msg << "foreign: " << field << " = " << value << ", allowed (" << lo << ", " << hi << "]";
    throw std::invalid_argument(msg.str());
  }
}

}  // namespace fesim::foreign
