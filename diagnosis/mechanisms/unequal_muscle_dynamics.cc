// unequal_muscle_dynamics: the wrist extensors and flexors activate at different rates (eq. 6 of
// papers/000_0a6c0de9fc69df7c.txt; its Assumption 6, equal Ω, broken). Extension:
// omega.ext_flex_ratio s — Ω_i × s for the wrist extensors, × 1/s for the flexors (the person
// calibration fits one common Ω scale, person.h). Planted: ratio 1 + 0.4 s.
//
// Normal variation: |s − 1| ≤ 0.1. The groups' rates of a normal person differ by the spread of
// single muscles: ±5 % per muscle in a foreign person (foreign/person.h activation_per_muscle), so
// at most ≈ 10 % between group means, s² ≈ 1.1, s ≈ 1.05 — the band doubles that for the misfit
// the ratio also absorbs; the in-family persons share one Ω scale (diagnosis/planted.cc). A clean
// foreign person fitted s = 1.078 (docs/diagnosis.md, Validation); planted ones 0.65–0.82 and
// 1.36 in-family.
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {
namespace {
constexpr double kNormalRatioHalfWidth = 0.1;  ///< |s − 1| of a normal person (see above).
}  // namespace

Mechanism UnequalMuscleDynamicsMechanism() {
  Mechanism m;
  m.id = "unequal_muscle_dynamics";
  m.description = "unequal activation dynamics of the muscle groups";
  m.candidates = [](const sim::ModelParams& rig, const LibraryContext&) {
    Candidate c;
    const std::vector<int> ext = WristGroup(rig, true), flex = WristGroup(rig, false);
    c.params.push_back(Sensed(Param("omega.ext_flex_ratio", "1", 1.0, 0.2, 5.0, 1.0,
                                    [ext, flex](double v, sim::ModelParams* p) {
                                      // Relative to the model's current Ω (which the person's
                                      // common scale has set), so the two compose.
                                      for (int k : ext) p->muscles[k].activation_omega_rad_s *= v;
                                      for (int k : flex) p->muscles[k].activation_omega_rad_s /= v;
                                    })));
    c.params.back().normal_half_width = kNormalRatioHalfWidth;
    c.probes = {ProbeAt(c.params, 0, 1.3)};
    c.one_sided = {false};
    return std::vector<Candidate>{c};
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    PlantViaCandidate("unequal_muscle_dynamics", "omega.ext_flex_ratio", 1.0 + 0.4 * ctx.scale,
                      ctx.library, truth, planted);
  };
  m.evidence = InputLagEvidence;
  return m;
}

}  // namespace fesim::diagnosis
