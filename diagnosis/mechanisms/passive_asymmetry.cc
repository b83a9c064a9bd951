// passive_asymmetry (a control, Mechanism::control): a passive joint curve stiffer on one side of
// the rest angle than on the other — a normal person's, not a mechanism (passive moments measured
// on healthy wrists and fingers are fitted by double exponentials with unequal flexion and
// extension sides, Amankwah, Triolo & Kirsch 2004; the joints of the independent simulator's
// persons are symmetric — one factor on both sides, foreign/person.cc DrawPerson — and their
// passive moment is one-sided through the muscles' passive fibre forces, foreign/muscle.h F_pe
// for l̃ > 1 only). The person calibration (person.h) fits a symmetric curve, k and k₃;
// this control adds the second-order term of sim/passive_joint.h at each output joint:
// passive.asymmetry a, k₂ = a · k_j per rad (k_j the calibrated stiffness), so that at 0.5 rad
// from rest a = 1 adds ±½ of the linear moment. Range ±1 keeps k − 2k₂(q − q₀) > 0 within
// 0.5 rad of rest on the linear part alone.
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {

Mechanism PassiveAsymmetryControl() {
  Mechanism m;
  m.id = "passive_asymmetry";
  m.description = "a flexion/extension asymmetry of the passive joint curve (normal variation)";
  m.control = true;
  m.candidates = [](const sim::ModelParams&, const LibraryContext& ctx) {
    std::vector<Candidate> out;
    for (int j : OutputJoints(ctx)) {
      Candidate c;
      c.joint = sim::CoordinateNames()[j];
      c.params.push_back(Sensed(
          Param("passive.asymmetry", "1", 0.0, -1.0, 1.0, 0.3, [j](double v, sim::ModelParams* p) {
            auto& pj = p->coordinates[j].passive;
            pj.quadratic_stiffness_nm_per_rad2 = v * pj.stiffness_nm_per_rad;
          })));
      c.probes = {ProbeAt(c.params, 0, 0.3)};
      c.one_sided = {false};
      out.push_back(std::move(c));
    }
    return out;
  };
  m.plant = [](const PlantContext&, sim::ModelParams*, sim::SensorSuite*,
               std::vector<NamedValue>*) {};
  m.evidence = PostureEvidence;
  return m;
}

}  // namespace fesim::diagnosis
