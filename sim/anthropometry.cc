#include "sim/anthropometry.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace fesim::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTissueDensity = 1100.0;  // kg/m³, assumed

// Winter 2009 Fig. 4.1 segment lengths as fractions of height.
constexpr double kUpperArmLength = 0.186, kForearmLength = 0.146, kHandLength = 0.108;
// de Leva 1996 Table 4, males: mass fraction, COM fraction from proximal joint, radii of
// gyration (sagittal, transverse, longitudinal) as fractions of segment length.
constexpr double kUpperArmMass = 0.0271, kUpperArmCom = 0.5772;
constexpr double kUpperArmRg[3] = {0.285, 0.269, 0.158};
constexpr double kForearmMass = 0.0162, kForearmCom = 0.4574;
constexpr double kForearmRg[3] = {0.276, 0.265, 0.121};
// Winter 2009 Table 4.1, hand.
constexpr double kHandMass = 0.006, kHandCom = 0.506, kHandRg = 0.297;
// Buchholz et al. 1992 Table 1, index phalanges / hand length.
constexpr double kPhalanxLength[3] = {0.245, 0.143, 0.097};
constexpr double kPhalanxRadius175[3] = {0.009, 0.008, 0.007};  // m at H = 1.75 m (assumed)
constexpr double kPalmLength = 0.463;  // wrist to index MCP / hand length (assumed)

SegmentParams LongBone(double mass, double length, double com_frac, const double rg[3]) {
  SegmentParams s;
  s.mass_kg = mass;
  s.length_m = length;
  s.com_in_body_m = {0.0, -com_frac * length, 0.0};
  // Body frame: Y longitudinal; X, Z transverse (sagittal ≈ about Z, transverse ≈ about X).
  const double ix = mass * std::pow(rg[1] * length, 2);
  const double iy = mass * std::pow(rg[2] * length, 2);
  const double iz = mass * std::pow(rg[0] * length, 2);
  s.inertia_about_com_kg_m2 = {ix, iy, iz};
  return s;
}

SegmentParams Cylinder(double length, double radius) {
  SegmentParams s;
  s.mass_kg = kTissueDensity * kPi * radius * radius * length;
  s.length_m = length;
  s.com_in_body_m = {0.0, -0.5 * length, 0.0};
  const double it = s.mass_kg * (3 * radius * radius + length * length) / 12.0;
  s.inertia_about_com_kg_m2 = {it, 0.5 * s.mass_kg * radius * radius, it};
  return s;
}

}  // namespace

std::array<SegmentParams, kNumSegments> ScaledSegments(double height_m, double mass_kg) {
  if (!(height_m >= 1.2 && height_m <= 2.2)) {
    throw std::invalid_argument("height_m " + std::to_string(height_m) + " outside [1.2, 2.2]");
  }
  if (!(mass_kg >= 30.0 && mass_kg <= 150.0)) {
    throw std::invalid_argument("mass_kg " + std::to_string(mass_kg) + " outside [30, 150]");
  }
  std::array<SegmentParams, kNumSegments> s;
  s[kHumerus] =
      LongBone(kUpperArmMass * mass_kg, kUpperArmLength * height_m, kUpperArmCom, kUpperArmRg);
  s[kForearm] =
      LongBone(kForearmMass * mass_kg, kForearmLength * height_m, kForearmCom, kForearmRg);
  const double hand_length = kHandLength * height_m;
  const double scale = height_m / 1.75;
  double finger_mass = 0.0;
  for (int k = 0; k < 3; ++k) {
    s[kProximalPhalanx + k] =
        Cylinder(kPhalanxLength[k] * hand_length, kPhalanxRadius175[k] * scale);
    finger_mass += s[kProximalPhalanx + k].mass_kg;
  }
  SegmentParams& hand = s[kHand];
  hand.length_m = kPalmLength * hand_length;
  hand.mass_kg = kHandMass * mass_kg - finger_mass;
  // Winter's COM and radius of gyration refer to the wrist–knuckle length, ≈ the palm here.
  hand.com_in_body_m = {0.0, -kHandCom * hand.length_m, 0.0};
  const double i = hand.mass_kg * std::pow(kHandRg * hand.length_m, 2);
  hand.inertia_about_com_kg_m2 = {i, 0.5 * i, i};  // longitudinal half of transverse (assumed)
  return s;
}

}  // namespace fesim::sim
