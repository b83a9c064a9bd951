#include "muscles/recruitment.h"

#include <cmath>

namespace fesim::muscles {

double Recruitment(const RecruitmentParams& p, double v_us) {
  if (v_us <= 0.0) return 0.0;
  const double e = std::exp(-p.beta_per_us * v_us);  // e^{−βv} ∈ (0, 1]
  return p.alpha * (1.0 - e) / (1.0 + p.gamma * e);
}

double RecruitmentSlope(const RecruitmentParams& p, double v_us) {
  if (v_us <= 0.0) return 0.0;
  const double e = std::exp(-p.beta_per_us * v_us);
  const double den = 1.0 + p.gamma * e;
  // d/dv [(1 − e)/(1 + γe)] with de/dv = −βe:  βe(1 + γ)/(1 + γe)²
  return p.alpha * p.beta_per_us * e * (1.0 + p.gamma) / (den * den);
}

}  // namespace fesim::muscles
