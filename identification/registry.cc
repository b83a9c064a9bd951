#include "identification/method.h"
#include "identification/spline_hammerstein.h"

namespace fesim::identification {

std::vector<MethodEntry> BuiltinMethods() {
  std::vector<MethodEntry> methods;
  // Each method family appends its entries here (one line each).
  methods.push_back(SplineArxMethod());
  methods.push_back(SplineOeMethod());
  return methods;
}

}  // namespace fesim::identification
