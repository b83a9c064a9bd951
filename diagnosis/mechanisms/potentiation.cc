// potentiation: post-activation potentiation, force rising with use (sim/mechanisms.h).
// Extension: potentiation.gain g (0 = off; up to 5: force × 6 when fully potentiated),
// potentiation.rise_time_s and potentiation.decay_time_s. The decay is a person's own:
// potentiation fades over tens of seconds to minutes (Tillin & Bishop 2009, Sports Med 39:147);
// held at the nominal 60 s, the candidate missed foreign persons whose potentiation fades in 30 s
// (docs/diagnosis.md, Candidates). Planted: g = 2 s.
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {

Mechanism PotentiationMechanism() {
  Mechanism m;
  m.id = "potentiation";
  m.description = "post-activation potentiation (force rising with use)";
  m.reduced_model_form = true;
  m.candidates = [](const sim::ModelParams& rig, const LibraryContext&) {
    Candidate c;
    c.params.push_back(
        Param("potentiation.gain", "1", 0.0, 0.0, 5.0, 0.1, [](double v, sim::ModelParams* p) {
          p->mechanisms.potentiation.enabled = v > 1e-12;
          p->mechanisms.potentiation.gain = v;
        }));
    const double rise = rig.mechanisms.potentiation.rise_time_s;
    c.params.push_back(
        Param("potentiation.rise_time_s", "s", rise, 0.5, 60.0, rise,
              [](double v, sim::ModelParams* p) { p->mechanisms.potentiation.rise_time_s = v; }));
    // At the shortest rise time p ≈ 1 within a second of any stimulation and decays over
    // T_decay (60 s nominal): a constant gain 1 + g on the active force, i.e. a stronger person
    // (registry_test: PotentiationCollapsesIntoAConstantGainAtItsShortestRiseTime).
    c.params.back().collapses_at = 0.5;
    const double decay = rig.mechanisms.potentiation.decay_time_s;
    c.params.push_back(
        Param("potentiation.decay_time_s", "s", decay, 10.0, 600.0, decay,
              [](double v, sim::ModelParams* p) { p->mechanisms.potentiation.decay_time_s = v; }));
    // Its upper bound is a potentiation that does not fade within a recording, a person's value
    // like any other, not a fit standing in for misfit (ParameterAtRangeBound): in fesim's own
    // data a planted 60 s decay fitted there (in-family 1002, docs/diagnosis.md Validation).
    c.params.back().range_is_plausible = false;
    c.probes = {ProbeAt(c.params, 0, 0.1)};
    c.one_sided = {true};
    return std::vector<Candidate>{c};
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    auto& p = truth->mechanisms.potentiation;
    p.enabled = true;
    p.gain = 2.0 * ctx.scale;
    planted->push_back({"potentiation:potentiation.gain", "1", p.gain, NAN});
    planted->push_back({"potentiation:potentiation.rise_time_s", "s", p.rise_time_s, NAN});
  };
  m.evidence = UseEvidence;
  return m;
}

}  // namespace fesim::diagnosis
