// fesim's upper-limb model written as a MuJoCo (2.2) MJCF model, for the work-precision
// comparison of docs/performance.md "Work–precision against MuJoCo". Pure functions of
// ModelParams: no MuJoCo header is needed to write the text; bench/ and tests/ load it.
//
// What carries over exactly (same numbers as sim/upper_limb_model.cc builds into Simbody):
//   segments   one MuJoCo body per fesim segment (humerus, forearm, hand, three phalanges) with
//              mass (kg), centre of mass (m, body frame) and principal moments about it (kg·m²,
//              body axes) from SegmentParams; body origins at the proximal joint centres, each
//              child at (0, −length, 0) of its parent (the index MCP at (offset, −length, 0)).
//   joints     ten hinges with fesim's names, axes and order. Simbody's massless intermediate
//              bodies become several joints in one MuJoCo body, which MuJoCo composes in the
//              order written as rotations about the body's own (moving) axes — exactly Simbody's
//              chain of pins: shoulder Y (plane), −X (elevation), Y (rotation) in the humerus
//              ([Schearer 2014] Y–X–Y); pro/supination Y, wrist flexion X, deviation Z in the
//              hand; elbow Z; MCP, PIP, DIP X. Angles in rad (compiler angle="radian"). The
//              humerus is written at elevation kShoulderRefElevationRad (below), which changes
//              how the shoulder's axes are written, not its kinematics.
//   passive    joint stiffness = k (N·m/rad), springref = q₀ (rad), damping = b (N·m·s/rad) of
//              PassiveJointParams: MuJoCo's τ = −k (q − q₀) − b q̇ is eq. (14)'s linear part.
//   muscles    one fixed tendon per muscle, L = Σᵢ cᵢ qᵢ with cᵢ = ∂l_MT/∂qᵢ = −rᵢ(q_rest)
//              ([Hand Hammerstein] eq. 8; fesim's r = −∂l/∂q, tendons/landsmeer.h) at the rest
//              posture (every coordinate at its passive rest angle q₀, where fesim's fibres are at
//              optimal length, sim/default_model.h), driven by a general actuator of fixed gain
//              −F_max cos φ₀ (N per unit ctrl; negative: a muscle pulls, shortening L) with
//              ctrl ∈ [0, 1] the activation a. The joint torque is τ = c · (−F_max cos φ₀ a) =
//              r(q_rest) F_max cos φ₀ a — fesim's τ = R f at the rest posture, isometric.
//   activation ctrl is not MuJoCo state: ActivationTrack gives fesim's a(t) for the same
//              stimulation through the same electrode matrix (eq. 1), recruitment (eq. 3) and
//              activation dynamics (eq. 6, solved in closed form between stimulation changes,
//              as sim/integrator.h does), to be fed as ctrl.
//   support    each elastic band as a spatial tendon from a world site (the anchor) to a site on
//              its segment (the cuff) with stiffness k (N/m) and springlength L_s (m); each
//              weight compensation as a spatial tendon from its cuff to a world site kFarSiteM
//              (m) above it along −gravity, pulled by an actuator of constant force F_w (N,
//              affine bias, gain 0), listed after the muscles.
//   gravity    option gravity = ModelParams::gravity_m_s2; no contact (no geoms; flag off).
//
// Where the MuJoCo model differs from fesim's (the comparison measures each engine against its own
// reference, so these change the trajectories, not the error metric):
//   - Hill force–length–velocity and passive fibre force ([Hand Hammerstein] eq. 4, 7;
//     muscles/hill.h) are absent: the MuJoCo force is F_max cos φ₀ a at any fibre length and
//     speed, fesim's F_max (a f_L f_V + f_PE) cos φ. (MuJoCo's own muscle actuator has other
//     curves and a length range computed by the compiler, so it is not used.)
//   - Moment arms are constant (the rest posture's): fesim's Landsmeer eq. (10) arms of FDS, FDP
//     (MCP, PIP) and BIC, BRA, BRD (elbow) vary with posture.
//   - Joint range ends: fesim applies the smooth exponential limit moment of sim/passive_joint.h
//     (K_L, κ) inside the range; MuJoCo's limited hinges (range = [q_min, q_max]) act only past
//     the range, through its soft constraint solver.
//   - Elastic bands: MuJoCo 2.2's tendon spring has no slack — it pushes when L < L_s, fesim's
//     band goes slack. Same force while the band is taut.
//   - Weight compensation: the force points from the cuff to a world site kFarSiteM above, not
//     exactly along −gravity: its direction is off by at most (cuff's distance from the vertical
//     through the site) / kFarSiteM rad (1e-4 rad per metre).
//   - ctrl is held constant over each MuJoCo step (MuJoCo's RK4 uses one ctrl for its four
//     stages), so the caller samples the activation once per step (bench/: at the step's
//     midpoint); fesim integrates the continuous a(t).
//   - Not representable, rejected by WriteMjcf (std::invalid_argument, one line naming it):
//     locked or prescribed coordinates, the nonlinear passive terms (k₂, k₃), Coulomb/static
//     friction, the stretch reflex, fatigue, potentiation, tremor and electromechanical delay.
#pragma once

#include <string>
#include <vector>

#include "sim/integrator.h"
#include "sim/model_params.h"

namespace fesim::sim {

/// Shoulder elevation (rad) at which the MJCF defines the humerus body (its joint ref; the
/// plane axis and the body orientation follow, so the kinematics are Simbody's for every q):
/// MuJoCo's compiler evaluates the model at qpos0 = ref, where the Y–X–Y shoulder must not be
/// singular (at elevation 0 the plane and rotation axes coincide). π/4, mid-range.
inline constexpr double kShoulderRefElevationRad = 0.78539816339744831;

/// Distance (m) of the world site above each weight-compensation cuff (see the header comment).
inline constexpr double kFarSiteM = 1e4;

/// MuJoCo's integrators (option integrator="Euler" | "RK4" | "implicit" in 2.2).
enum class MjcfIntegrator { kEuler, kRk4, kImplicit };

/// Name of an integrator as MJCF writes it ("Euler", "RK4", "implicit").
const char* MjcfIntegratorName(MjcfIntegrator integrator);

struct MjcfOptions {
  double timestep_s = 0.0005;  ///< MuJoCo time step, s, > 0.
  MjcfIntegrator integrator = MjcfIntegrator::kEuler;
  std::string model_name = "fesim";  ///< <mujoco model="…">.
};

/// The MJCF text of `params` (see the header comment for what maps to what). Joints are named
/// as fesim's coordinates (CoordinateNames()), bodies as its segments (SegmentNames()), tendons
/// and their actuators as the muscles (actuators 0 … n_muscles − 1, in params.muscles order),
/// then the weight-compensation actuators "support<k>"; a keyframe "initial" holds the initial
/// angles (rad) and speeds (rad/s). Throws std::invalid_argument with a one-line reason for a
/// model the MJCF cannot express (header comment) or bad options.
std::string WriteMjcf(const ModelParams& params, const MjcfOptions& options = {});

/// The fixed-tendon coefficients WriteMjcf writes, coordinates × muscles row-major (m/rad):
/// [i · n_muscles + j] = ∂l_MT,j/∂qᵢ = −rᵢⱼ(q_rest) (tendons::MomentArmMatrix at the rest angles).
std::vector<double> MjcfTendonCoefficients(const ModelParams& params);

/// fesim's muscle activations a(t) (dimensionless) under a piecewise-constant stimulation, from
/// rest (a = ȧ = 0) at t = 0: w = H_IRC(A u) per interval (eq. 1, 3; RecruitedFractions of
/// upper_limb_model.h) and the exact solution of eq. (6) between the schedule's times
/// (muscles::ActivationFreeResponse, at each interval's muscles::IntervalOmega) — the values
/// fesim's integrator gives the activation states.
/// No electromechanical delay: RunTrial shifts the schedule's times by it, so would the caller.
class ActivationTrack {
 public:
  /// Throws std::invalid_argument when a schedule row has the wrong number of channels, the
  /// times are not strictly increasing or a time is negative.
  ActivationTrack(const ModelParams& params, const StimulationSchedule& schedule);
  /// a(t) of every muscle into a[0 … n_muscles − 1], t ≥ 0 in s.
  void At(double t_s, double* a) const;
  std::vector<double> At(double t_s) const;
  int num_muscles() const { return static_cast<int>(segments_.front().w.size()); }

 private:
  struct Segment {
    double t0_s = 0.0;
    std::vector<double> w;           // recruited fraction per muscle over [t0, next t0)
    std::vector<double> a0, a_dot0;  // activation and its rate at t0
    std::vector<double> omega;       // Ω_j over the interval, rad/s (muscles::IntervalOmega)
  };
  std::vector<Segment> segments_;
};

}  // namespace fesim::sim
