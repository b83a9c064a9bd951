// Forward sensitivities at report times from one Taylor polynomial per CVODES step.
//
// CVODES' CVodeGetSens interpolates every sensitivity vector, whole, at each report time from the
// Nordsieck history of the step that contains it. The fits report at 40 Hz while CVODES takes
// about one step per 13 reports (docs/performance.md "Full-model fit local step"), and they read
// only the free coordinates' q rows of each sensitivity: interpolating all of them at every report
// was ≈ 16 % of an augmented simulation. The polynomial is the same either way — the Nordsieck
// history z_j = h^j y⁽ʲ⁾(t_n)/j! (Hindmarsh et al. 2005, "SUNDIALS", ACM TOMS 31(3) §2.1) gives
//   y(t) = Σ_j z_j ((t − t_n)/h)^j = Σ_k y⁽ᵏ⁾(t_n) (t − t_n)ᵏ / k!,   t_n − h_u ≤ t ≤ t_n,
// so the derivatives at t_n (CVodeGetSensDky1, k up to the last step's order) are read once per
// step for the components asked for, and each report evaluates the polynomial by Horner's rule.
#pragma once

#include <sundials/sundials_nvector.h>

#include <vector>

namespace fesim::sim {

/// The sensitivities of a few state components at any time inside CVODES' last step.
class SensitivityTaylor {
 public:
  /// `components`: indices into CVODES' state vector; `parameters`: the number of sensitivities
  /// CVODES integrates (CVodeSensInit's Ns).
  SensitivityTaylor(std::vector<int> components, int parameters);
  ~SensitivityTaylor();
  SensitivityTaylor(const SensitivityTaylor&) = delete;
  SensitivityTaylor& operator=(const SensitivityTaylor&) = delete;

  /// ∂y_c/∂θ_k at t for c = components[m], k < parameters, into (*out)[k · components + m]; t
  /// inside CVODES' last step (as after CVode(…, CV_NORMAL) returned t), `like` a vector of
  /// CVODES' length. Reads the step's derivatives when CVODES took a step since the last call.
  /// Returns CVODES' first failing flag (< 0), or 0.
  int Evaluate(void* cvode_mem, N_Vector like, double t, std::vector<double>* out);

 private:
  std::vector<int> components_;
  int parameters_;
  std::vector<double> coefficients_;  // y⁽ᵏ⁾(t_n)/k!, [(k · parameters + is) · components + m]
  double tn_ = 0.0;
  long steps_ = -1;  // CVODES' step count when coefficients_ were read
  N_Vector work_ = nullptr;
};

}  // namespace fesim::sim
