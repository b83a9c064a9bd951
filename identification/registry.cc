#include "identification/method.h"
#include "identification/hammerstein_mimo.h"
#include "identification/spline_hammerstein.h"
#include "identification/tremor_arx.h"

#include "identification/ekf.h"
#include "identification/inverse_dynamics.h"
#include "identification/shoulder_models.h"

namespace fesim::identification {

std::vector<MethodEntry> BuiltinMethods() {
  std::vector<MethodEntry> methods;
  // Each method family appends its entries here (one line each).
  methods.push_back(ShoulderModel1Method());
  methods.push_back(ShoulderModel2Method());
  methods.push_back(ShoulderEkfMethod());
  methods.push_back(InvDynParametricMethod());
  methods.push_back(InvDynGpMethod());
  methods.push_back(InvDynSemiparametricMethod());
  methods.push_back(SplineArxMethod());
  methods.push_back(SplineOeMethod());
  methods.push_back(HammersteinMimoMethod());
  methods.push_back(TremorArxMethod());
  return methods;
}

}  // namespace fesim::identification
