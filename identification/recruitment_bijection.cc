#include "identification/recruitment_bijection.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace fesim::identification {

double SaturationRatioBound() { return std::log(20.0) / std::log(20.0 / 19.0); }

double MinimumSaturationRatio() { return SaturationRatio(1e300); }

double SigmoidRecruitment(const SigmoidParams& phi, const Eigen::VectorXd& u_us) {
  if (phi.delta.size() != u_us.size()) {
    throw std::invalid_argument("SigmoidRecruitment: " + std::to_string(u_us.size()) +
                                " inputs for " + std::to_string(phi.delta.size()) + " gains");
  }
  const double x = phi.delta.dot(u_us);
  if (x > 700.0) return 1.0;  // e^x overflows; the limit of eq. (22)
  const double e = std::exp(x);
  return (e - 1.0) / (e + phi.gamma);
}

double SaturationRatio(double gamma) {
  return std::log(19.0 * gamma + 20.0) / std::log1p((gamma + 1.0) / 19.0);
}

CutoffParams CutoffsFromSigmoid(const SigmoidParams& phi) {
  if (!(phi.gamma > 0.0) || phi.delta.size() == 0 || !(phi.delta.array() > 0.0).all()) {
    throw std::invalid_argument("recruitment: need gamma > 0 and every delta > 0 (set Q, eq. 36)");
  }
  CutoffParams psi;
  const double a = std::log1p((phi.gamma + 1.0) / 19.0);  // ln((γ+20)/19)
  psi.u_db_us = a * phi.delta.cwiseInverse();
  psi.u_sat_us = std::log(19.0 * phi.gamma + 20.0) / phi.delta(0);
  return psi;
}

bool InRecruitmentSet(const CutoffParams& psi) {
  if (psi.u_db_us.size() == 0 || !(psi.u_db_us.array() > 0.0).all()) return false;
  if (!(psi.u_sat_us > 0.0) || !std::isfinite(psi.u_sat_us)) return false;
  const double ratio = psi.u_sat_us / psi.u_db_us(0);
  return ratio > MinimumSaturationRatio() && ratio < SaturationRatioBound();
}

SigmoidParams SigmoidFromCutoffs(const CutoffParams& psi) {
  if (!InRecruitmentSet(psi)) {
    throw std::invalid_argument("recruitment: cut-offs outside P (eq. 40): need u_db > 0 and " +
                                std::to_string(MinimumSaturationRatio()) + " u_db_1 < u_sat < " +
                                std::to_string(SaturationRatioBound()) + " u_db_1");
  }
  const double target = psi.u_sat_us / psi.u_db_us(0);
  // f is strictly decreasing in γ: safeguarded Newton on s = ln γ inside a bisection bracket.
  double lo = -60.0, hi = std::log(1e300);
  while (SaturationRatio(std::exp(lo)) < target && lo > -700.0) lo -= 60.0;
  double s = 0.0;
  for (int it = 0; it < 200; ++it) {
    const double g = std::exp(s);
    const double A = std::log(19.0 * g + 20.0);
    const double B = std::log1p((g + 1.0) / 19.0);
    const double r = A / B - target;
    if (r > 0.0) {
      lo = s;
    } else {
      hi = s;
    }
    // d f / d s = γ (A' B − A B') / B², A' = 19/(19γ + 20), B' = 1/(γ + 20)
    const double dfds = g * (19.0 / (19.0 * g + 20.0) * B - A / (g + 20.0)) / (B * B);
    double next = dfds < 0.0 ? s - r / dfds : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    const double step = std::abs(next - s);
    s = next;
    if (step <= 1e-14 * (1.0 + std::abs(s)) || hi - lo <= 1e-14 * (1.0 + std::abs(s))) break;
  }
  SigmoidParams phi;
  phi.gamma = std::exp(s);
  const double a = std::log1p((phi.gamma + 1.0) / 19.0);
  phi.delta = a * psi.u_db_us.cwiseInverse();
  return phi;
}

std::vector<SigmoidParams> SigmoidsFromCutoffs(const std::vector<CutoffParams>& Psi) {
  std::vector<SigmoidParams> out;
  out.reserve(Psi.size());
  for (const auto& p : Psi) out.push_back(SigmoidFromCutoffs(p));
  return out;
}

}  // namespace fesim::identification
