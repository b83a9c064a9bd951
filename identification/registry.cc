#include "identification/method.h"

namespace fesim::identification {

std::vector<MethodEntry> BuiltinMethods() {
  std::vector<MethodEntry> methods;
  // Each method family appends its entries here (one line each).
  return methods;
}

}  // namespace fesim::identification
