// crosstalk: stimulation current reaching muscles beyond the intended ones (sim/mechanisms.h).
// Only with array channels. Extension, two one-sided parameters:
//   crosstalk.fraction c            a second, wider Gaussian spread on the array (σ_x = 0.03 m);
//                                   on the hand rig it mostly strengthens a channel's own group
//                                   (at c = 1 own entries × 2.7, the other group's ≤ 0.13 of
//                                   them), which the person's strengths absorb;
//   crosstalk.antagonist_fraction f each stimulated channel also reaches the muscles the other
//                                   stimulated channels drive, with f × their own entry of A
//                                   (an explicit A entry, sim/model_params.h muscle_weights) —
//                                   co-activation of the antagonists by current spread.
// Planted: c = 0.06 s (at 0.015 s the effect RMS is ≈ the noise RMS, but 95 % of it is absorbed
// by the person calibration).
//
// Normal variation: f ≤ 0.04 with c indistinguishable from 0 (WithinNormalVariation with the
// fit's ci95). A foreign person's off-group entries of W are U[0, 0.02] against on-group entries
// of U[0.5, 1.5] (foreign/person.h), a reach of the antagonists of up to 0.02/0.5 = 0.04 in every
// clean person; clean foreign person 3003 fitted f = 0.030 ± 0.005, c = 0.003 ± 0.012
// (docs/diagnosis.md, Validation). Planted foreign reaches fit f = 0.19–0.53; the in-family plant
// is c ≥ 0.06.
#include <algorithm>

#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {
namespace {

/// A muscle is driven by a channel when its entry of A is at least this share of the channel's
/// largest (as the person's muscle groups, diagnosis/person.cc).
constexpr double kDrivenShare = 0.02;

/// f of a normal person (see the file comment).
constexpr double kNormalAntagonistFraction = 0.04;

/// One explicit A entry the antagonist fraction adds per unit f: channel `channel` reaching
/// `muscle` with the weight `weight` its own channel gives it.
struct Reach {
  int channel;
  std::string muscle;
  double weight;
};

/// The antagonist reaches of the stimulated channels `names` on `rig`.
std::vector<Reach> AntagonistReaches(const sim::ModelParams& rig,
                                     const std::vector<std::string>& names) {
  const muscles::ArrayMatrix a = sim::BuildElectrodeMatrix(rig);
  std::vector<int> stimulated;
  for (int k = 0; k < a.channels; ++k) {
    for (const auto& n : names) {
      if (rig.channels[k].name == n) stimulated.push_back(k);
    }
  }
  const auto driven = [&](int j, int k) {
    double top = 0.0;
    for (int i = 0; i < a.muscles; ++i) top = std::max(top, a(i, k));
    return top > 0.0 && a(j, k) >= kDrivenShare * top;
  };
  std::vector<Reach> out;
  for (int k : stimulated) {
    for (int other : stimulated) {
      if (other == k) continue;
      for (int j = 0; j < a.muscles; ++j) {
        if (driven(j, other) && !driven(j, k)) out.push_back({k, rig.muscles[j].name, a(j, other)});
      }
    }
  }
  return out;
}

}  // namespace

Mechanism CrosstalkMechanism() {
  Mechanism m;
  m.id = "crosstalk";
  m.description = "electrode crosstalk (current reaching other muscles)";
  m.reduced_model_form = true;
  m.candidates = [](const sim::ModelParams& rig, const LibraryContext& ctx) {
    Candidate c;
    bool array = false;
    for (const auto& ch : rig.channels) {
      for (const auto& name : ctx.channels) array |= ch.name == name && !ch.pads.empty();
    }
    if (!array) {
      c.applicable = false;
      c.not_applicable_reason = "no stimulated channel uses the electrode array";
      return std::vector<Candidate>{c};
    }
    c.params.push_back(
        Sensed(Param("crosstalk.fraction", "1", 0.0, 0.0, 1.0, 0.1,
                     [](double v, sim::ModelParams* p) { p->mechanisms.crosstalk.fraction = v; })));
    const std::vector<Reach> reaches = AntagonistReaches(rig, ctx.channels);
    c.params.push_back(Sensed(Param("crosstalk.antagonist_fraction", "1", 0.0, 0.0, 1.0, 0.1,
                                    [reaches](double v, sim::ModelParams* p) {
                                      if (v <= 0.0) return;
                                      for (const Reach& r : reaches) {
                                        p->channels[r.channel].muscle_weights.emplace_back(
                                            r.muscle, v * r.weight);
                                      }
                                    })));
    c.params.back().normal_half_width = kNormalAntagonistFraction;
    c.probes = {ProbeAt(c.params, 0, 0.1), ProbeAt(c.params, 1, 0.1)};
    c.one_sided = {true, true};
    // A strong antagonist reach is half-reproduced by stronger, stiffer muscles (extension.h):
    // the person refitted with it held at 0.15 and 0.45.
    c.profile_starts = {ProbeAt(c.params, 1, 0.15), ProbeAt(c.params, 1, 0.45)};
    return std::vector<Candidate>{c};
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    PlantViaCandidate("crosstalk", "crosstalk.fraction", 0.06 * ctx.scale, ctx.library, truth,
                      planted);
  };
  m.evidence = InputLagEvidence;
  return m;
}

}  // namespace fesim::diagnosis
