#include "apps/commands.h"
#include "identification/fullmodel/full_model_fit.h"

namespace fesim {

std::vector<identification::MethodEntry> ExtraIdentificationMethods() {
  std::vector<identification::MethodEntry> methods;
  // Methods outside identification/'s Eigen-only core register here.
  // Full model (12) fit through the simulator; `fesim identify --scenario` passes the rig as the
  // trials' `scenario_path` metadata.
  methods.push_back(identification::fullmodel::FullModelMethod());
  return methods;
}

}  // namespace fesim
