#include "sim/sensitivity_taylor.h"

#include <cvodes/cvodes.h>

#include <algorithm>
#include <utility>

namespace fesim::sim {

SensitivityTaylor::SensitivityTaylor(std::vector<int> components, int parameters)
    : components_(std::move(components)), parameters_(parameters) {}

SensitivityTaylor::~SensitivityTaylor() {
  if (work_ != nullptr) N_VDestroy(work_);
}

int SensitivityTaylor::Evaluate(void* cvode_mem, N_Vector like, double t,
                                std::vector<double>* out) {
  const std::size_t nc = components_.size();
  const std::size_t row = nc * static_cast<std::size_t>(parameters_);
  out->resize(row);
  if (row == 0) return 0;
  long steps = 0;
  if (const int flag = CVodeGetNumSteps(cvode_mem, &steps); flag < 0) return flag;
  if (steps != steps_) {
    if (const int flag = CVodeGetCurrentTime(cvode_mem, &tn_); flag < 0) return flag;
    if (work_ == nullptr) work_ = N_VClone(like);
    const double* work = N_VGetArrayPointer(work_);
    // The polynomial's degree is the order of the step just taken (CVODES changes its order only
    // when it starts the next step); before the first step, y(t₀) alone.
    int order = 0;
    if (const int flag = CVodeGetLastOrder(cvode_mem, &order); flag < 0) return flag;
    coefficients_.clear();
    double factorial = 1.0;
    for (int k = 0; k <= order; ++k) {
      if (k > 0) factorial *= k;
      for (int is = 0; is < parameters_; ++is) {
        if (const int flag = CVodeGetSensDky1(cvode_mem, tn_, k, is, work_); flag < 0) {
          steps_ = -1;
          return flag;
        }
        for (std::size_t m = 0; m < nc; ++m) {
          coefficients_.push_back(work[components_[m]] / factorial);
        }
      }
    }
    steps_ = steps;
  }
  // Horner's rule over whole rows (i = is · nc + m), highest order first.
  const std::size_t terms = coefficients_.size() / row;
  const double dt = t - tn_;
  double* v = out->data();
  const double* c = coefficients_.data() + (terms - 1) * row;
  std::copy(c, c + row, v);
  for (std::size_t k = terms - 1; k-- > 0;) {
    c -= row;
    for (std::size_t i = 0; i < row; ++i) v[i] = v[i] * dt + c[i];
  }
  return 0;
}

}  // namespace fesim::sim
