#include "tendons/landsmeer.h"

#include <cmath>

namespace fesim::tendons {
namespace {

constexpr double kSeriesLimit = 0.15;  // |q| below which the Taylor series is used (rad)

// Odd series of g: coefficients of q, q³, …, q¹¹ (exact rationals, computed symbolically).
constexpr double kG[] = {-1.0 / 12.0,        -17.0 / 720.0,        -43.0 / 10080.0,
                         -769.0 / 1209600.0, -4097.0 / 47900160.0, -4717457.0 / 435891456000.0};
// Even series of G: coefficients of q², q⁴, …, q¹².
constexpr double kGInt[] = {-1.0 / 24.0,           -17.0 / 2880.0,
                            -43.0 / 60480.0,       -769.0 / 9676800.0,
                            -4097.0 / 479001600.0, -4717457.0 / 5230697472000.0};

double SeriesOdd(double q) {
  const double q2 = q * q;
  double s = 0.0;
  for (int k = 5; k >= 0; --k) s = s * q2 + kG[k];
  return s * q;
}

double SeriesEven(double q) {
  const double q2 = q * q;
  double s = 0.0;
  for (int k = 5; k >= 0; --k) s = s * q2 + kGInt[k];
  return s * q2;
}

}  // namespace

double LandsmeerShape(double q) {
  if (std::abs(q) < kSeriesLimit) return SeriesOdd(q);
  const double s = std::sin(q);
  return (s - q) / (2.0 * s * s);
}

double LandsmeerShapeIntegral(double q) {
  if (std::abs(q) < kSeriesLimit) return SeriesEven(q);
  return 0.5 * (q / std::tan(q) - std::log(1.0 + std::cos(q)) - 1.0 + std::log(2.0));
}

double MomentArm(const MomentArmParams& p, double q) {
  if (p.model == MomentArmParams::Model::kConstant) return p.d_m;
  return p.d_m + p.d_tilde_m * LandsmeerShape(q);
}

double LengthChange(const MomentArmParams& p, double q) {
  if (p.model == MomentArmParams::Model::kConstant) return -p.d_m * q;
  return -(p.d_m * q + p.d_tilde_m * LandsmeerShapeIntegral(q));
}

}  // namespace fesim::tendons
