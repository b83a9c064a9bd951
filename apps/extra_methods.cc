#include "apps/commands.h"

namespace fesim {

std::vector<identification::MethodEntry> ExtraIdentificationMethods() {
  std::vector<identification::MethodEntry> methods;
  // Methods outside identification/'s Eigen-only core register here.
  return methods;
}

}  // namespace fesim
