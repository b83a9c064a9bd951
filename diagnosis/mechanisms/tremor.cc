// tremor: a periodic joint torque, 3–12 Hz (papers/001_50576a960b4d02ae.txt §2; sim/mechanisms.h).
// Extension at each output joint: tremor.amplitude_nm A, tremor.phase_rad φ, tremor.frequency_hz
// f (start f from the residual spectrum peak, within ±0.15 Hz); with several training trials one
// φ per trial (Candidate::phase_per_trial, registry.cc). Planted on the wrist: A = 0.08 s
// N·m, f drawn in [5, 8] Hz, φ seeded.
#include "diagnosis/mechanisms/library.h"

namespace fesim::diagnosis {
namespace {

constexpr double kHalfPi = 1.5707963267948966;

Candidate TremorAt(const sim::ModelParams& rig, int j, double f0) {
  Candidate c;
  c.joint = sim::CoordinateNames()[j];
  // The amplitude's plausible range ends at the torque that moves the joint by about 1 rad at
  // the tremor's frequency (PeriodicTorqueScale: inertia, stiffness and damping), not at the
  // static stiffness alone, which a strong tremor's fit reaches (docs/diagnosis.md, Candidates);
  // the probes and the fit's scale stay on the static torque scale tj.
  const double tj = JointTorqueScale(rig, j);
  const double upper = PeriodicTorqueScale(rig, j, f0);
  c.params.push_back(Sensed(Param("tremor.amplitude_nm", "N*m", 0.0, 0.0, upper, 0.05 * tj,
                                  [j](double v, sim::ModelParams* p) {
                                    p->mechanisms.tremor.enabled = v > 0.0;
                                    p->mechanisms.tremor.coordinate = j;
                                    p->mechanisms.tremor.amplitude_nm = v;
                                  })));
  c.params.push_back(
      Sensed(Param("tremor.phase_rad", "rad", 0.0, -10.0, 10.0, 1.0,
                   [](double v, sim::ModelParams* p) { p->mechanisms.tremor.phase_rad = v; })));
  c.params.push_back(Sensed(
      Param("tremor.frequency_hz", "Hz", f0, std::max(3.0, f0 - 0.15), std::min(12.0, f0 + 0.15),
            0.1, [](double v, sim::ModelParams* p) { p->mechanisms.tremor.frequency_hz = v; })));
  c.params[1].range_is_plausible = c.params[2].range_is_plausible = false;  // search windows
  c.free_phase_param = 1;
  // Two quadrature probes (sine and cosine at f0): the test is a harmonic regression.
  const double a0 = 0.01 * tj;
  Eigen::VectorXd p0 = Starts(c.params), p1 = Starts(c.params);
  p0(0) = a0;
  p1(0) = a0;
  p1(1) = kHalfPi;
  c.probes = {p0, p1};
  c.one_sided = {false, false};
  const std::vector<ModelParameter> params = c.params;
  // θ: (sine, cosine) weights, one pair per training trial when the directions are split per
  // trial (screening.h): the mean amplitude, the first trial's phase.
  c.start_from_step = [params, a0, f0](const Eigen::VectorXd& theta) {
    const Eigen::Index pairs = theta.size() / 2;
    double amplitude = 0.0;
    for (Eigen::Index t = 0; t < pairs; ++t) {
      amplitude += std::hypot(theta(2 * t), theta(2 * t + 1)) / static_cast<double>(pairs);
    }
    Eigen::VectorXd x(3);
    x << std::min(a0 * amplitude, params[0].upper), std::atan2(theta(1), theta(0)), f0;
    return x;
  };
  return c;
}

}  // namespace

Mechanism TremorMechanism() {
  Mechanism m;
  m.id = "tremor";
  m.description = "a tremor (periodic joint torque)";
  m.reduced_model_form = true;
  m.joint_by_fit = true;  // a wrist tremor shakes the fingers too (mechanism.h)
  m.candidates = [](const sim::ModelParams& rig, const LibraryContext& ctx) {
    std::vector<Candidate> out;
    const std::vector<int> joints = OutputJoints(ctx);
    for (std::size_t o = 0; o < joints.size(); ++o) {
      const double f0 = o < ctx.tremor_frequency_hz.size() ? ctx.tremor_frequency_hz[o] : 6.0;
      out.push_back(TremorAt(rig, joints[o], f0));
    }
    return out;
  };
  m.plant = [](const PlantContext& ctx, sim::ModelParams* truth, sim::SensorSuite*,
               std::vector<NamedValue>* planted) {
    auto& t = truth->mechanisms.tremor;
    t.enabled = true;
    t.coordinate = sim::kWristFlexion;
    t.amplitude_nm = 0.08 * ctx.scale;
    t.frequency_hz = ctx.tremor_frequency_hz;
    t.phase_rad = ctx.tremor_phase_rad;
    planted->push_back({"tremor@wrist_flexion:tremor.amplitude_nm", "N*m", t.amplitude_nm, NAN});
    planted->push_back({"tremor@wrist_flexion:tremor.frequency_hz", "Hz", t.frequency_hz, NAN});
  };
  m.evidence = [](const OutputSignature& s) {
    return Fmt("residual spectrum peak %.3f Hz at %.1fx the median (3-12 Hz)", s.spectrum_peak_hz,
               s.spectrum_peak_ratio);
  };
  return m;
}

}  // namespace fesim::diagnosis
