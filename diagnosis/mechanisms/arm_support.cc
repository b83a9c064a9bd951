// arm_support: the support lifts the forearm more (or less) than the rig says. Extension:
// support.weight_compensation_n F_w, N — the vertical weight-compensation force on the forearm
// cuff (sim/arm_support.h; the rig's forearm entry, or a cuff at the forearm's centre of mass
// with start 0 when the rig has none) — and, when the rig has elastic bands,
// support.band_stiffness_scale (k of every band × s). Applicable only when an output is the elbow
// or a shoulder coordinate (the support moves nothing distal to the forearm). Planted: the force
// raised by 0.25 s × the forearm weight.
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {
namespace {

Candidate SupportCandidate(const sim::ModelParams& rig) {
  Candidate c;
  const SupportCuff cuff = ForearmSupportCuff(rig);
  const double weight = ForearmWeightN(rig);
  c.params.push_back(Param(
      "support.weight_compensation_n", "N", cuff.force_n, 0.0, cuff.force_n + 2.0 * weight,
      0.1 * weight, [cuff](double v, sim::ModelParams* p) { SetForearmSupportForce(cuff, v, p); }));
  if (!rig.bands.empty()) {
    std::vector<double> k;
    for (const auto& b : rig.bands) k.push_back(b.stiffness_n_per_m);
    c.params.push_back(Param("support.band_stiffness_scale", "1", 1.0, 0.0, 5.0, 1.0,
                             [k](double v, sim::ModelParams* p) {
                               for (std::size_t i = 0; i < k.size(); ++i) {
                                 p->bands[i].stiffness_n_per_m = v * k[i];
                               }
                             }));
  }
  // The score test is local: a probe of 2 % of the forearm weight stays where the outputs are
  // linear in the force (at 10 % the Σr² profile over the force was past its minimum on an
  // elbow-rig calibration, and the secant pointed the one-sided test the wrong way).
  c.probes = {ProbeAt(c.params, 0, cuff.force_n + 0.02 * weight)};
  c.one_sided = {cuff.force_n == 0.0};  // no support: only a lifting force can appear
  // Profile starts over the force, 10–50 % of the forearm's weight on top of the rig's: the
  // force's Σr² valley runs through the strength–stiffness trade-off, which a fit from the
  // calibration (where F_w = 0 was absorbed) does not follow (diagnose_test:
  // ArmSupportIsNamedWithItsForceOnTheElbowRig).
  for (const double f : {0.1, 0.2, 0.3, 0.4, 0.5}) {
    c.profile_starts.push_back(ProbeAt(c.params, 0, cuff.force_n + f * weight));
  }
  if (c.params.size() > 1) {
    c.probes.push_back(ProbeAt(c.params, 1, 1.2));
    c.one_sided.push_back(false);
  }
  return c;
}

}  // namespace

Mechanism ArmSupportMechanism() {
  Mechanism m;
  m.id = "arm_support";
  m.description = "the arm support";
  m.candidates = [](const sim::ModelParams& rig, const LibraryContext& ctx) {
    bool arm_output = false;
    for (int j : OutputJoints(ctx)) arm_output |= j <= sim::kElbowFlexion;
    if (arm_output) return std::vector<Candidate>{SupportCandidate(rig)};
    Candidate c;
    c.applicable = false;
    c.not_applicable_reason =
        "no output joint is a shoulder or elbow coordinate (the support acts there)";
    return std::vector<Candidate>{c};
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    PlantViaCandidate(
        "arm_support", "support.weight_compensation_n",
        ForearmSupportCuff(*truth).force_n + 0.25 * ctx.scale * ForearmWeightN(*truth), ctx.library,
        truth, planted);
  };
  m.evidence = PostureEvidence;
  return m;
}

}  // namespace fesim::diagnosis
