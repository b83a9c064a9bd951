// fesim's foreign simulator: an independent simulator of the hand under FES that makes test data
// for fesim's diagnosis ("data fesim did not make"). It shares no physics code with fesim (sim/,
// muscles/, tendons/, identification/, diagnosis/ are never included); it uses only Eigen and
// fesim's plain records (base/trial.h, protocols/protocols.h).
//
// Model (each form in its header, with sources) and how it differs from fesim's:
//   body.h     planar 3-DOF chain wrist/MCP/PIP, DIP = 2/3·PIP coupled, closed-form Lagrange
//              equations, de Leva 1996 + Buchholz 1992 anthropometry   (fesim: Simbody 3-D)
//   joint.h    double-exponential elastic moment about a rest angle + linear damping
//              (fesim: linear spring + exponential limits + Stribeck friction)
//   muscle.h   polynomial moment arms with exactly integrated l_MT; smoothstep threshold–
//              saturation recruitment (fesim: exponential-rational); two first-order activation
//              stages with act/deact asymmetry (fesim: critically damped 2nd order); rigid tendon,
//              no pennation, parabolic f_L, Hill-hyperbola f_V, quadratic F_pe (fesim: Thelen 2003)
//   effects.h  15 plantable mechanisms and sensor artefacts, own forms
//   plant.h    state, right-hand side, passive equilibrium, RK4 between breakpoints
//              (fesim: CVODES BDF)
//   sensor.h   hand tracker: rate, Gaussian noise, Markov dropout bursts, rounded time stamps
//
// Nominal person (1.75 m, 75 kg; tests/foreign/simulate_test.cc checks the ranges): passive
// equilibrium wrist 6°, MCP 24°, PIP 29° (gravity palmar); a 300 µs step on ext moves wrist/MCP/
// PIP by −43°/−17°/−18° (wrist to −37°), on flex by +26°/+21°/+42° (wrist to +33°); 10–90 % rise
// 0.2–0.3 s, 98 % settling 0.45–0.6 s (0.6–0.75 s at 150 µs). A 60 s trial costs ≈ 0.13 s on one
// core (0.2–0.6 s with force_length_velocity or spasticity, whose stiffer dynamics shorten h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "base/trial.h"
#include "foreign/effects.h"
#include "foreign/person.h"
#include "foreign/plant.h"
#include "foreign/sensor.h"
#include "protocols/protocols.h"

namespace fesim::foreign {

/// A simulated trial: what the tracker recorded and the noiseless truth at the same times.
///
/// measured: time (s, rounded to SensorSpec::time_decimals), u.ext, u.flex (µs, the program's
/// value held at the sample time), q.wrist_flexion, q.mcp_flexion, q.pip_flexion (rad, noisy,
/// NaN in dropouts). truth: the same columns noiseless and without dropouts — q.* is what a
/// noiseless tracker reads, i.e. the joint angle plus the planted sensor artefacts (sensor_drift,
/// wander, slip) — plus qbody.<joint> (the physical joint angle, rad) and a.<muscle> (activation,
/// 0–1). Metadata: source, person_seed, trial_seed, effects ("id:scale,…" or "none"), kind.
struct ForeignTrial {
  fesim::Trial measured;
  fesim::Trial truth;
};

/// Simulates `program` (channels "ext" and "flex") on the person with the planted effects, from
/// the passive equilibrium under gravity, for program.duration_s; sensor noise, dropouts and the
/// effects' random draws come from `seed`. Throws std::invalid_argument on bad input (message
/// names the field and range), std::runtime_error when the integration fails.
ForeignTrial SimulateTrial(const Person& person, const std::vector<PlantedEffect>& effects,
                           const protocols::StimulationProgram& program, const SensorSpec& sensor,
                           std::uint64_t seed, const IntegrationSpec& integration = {});

/// The truth trial only (no sensor noise drawn); SimulateTrial's truth for the same arguments.
fesim::Trial SimulateTruth(const Person& person, const std::vector<PlantedEffect>& effects,
                           const protocols::StimulationProgram& program, const SensorSpec& sensor,
                           std::uint64_t seed, const IntegrationSpec& integration = {});

/// RMS over the three q.* truth columns and all samples of truth(with effects) − truth(without),
/// same person, program, sensor times and seed, rad.
double EffectRms(const Person& person, const std::vector<PlantedEffect>& effects,
                 const protocols::StimulationProgram& program, const SensorSpec& sensor,
                 std::uint64_t seed);

/// Multiplies effect.scale (by clamp(1.2·floor/rms, 1.25, 4) each round, at most max_rounds
/// rounds) until EffectRms ≥ floor_ratio·sensor.noise_std_rad; returns the effect at the scale
/// reached (the last one tried if the floor was not reached; *rms_rad, when given, receives its
/// RMS). floor_ratio in (0, 100], max_rounds in [1, 50].
PlantedEffect ScaleToFloor(const Person& person, const PlantedEffect& effect,
                           const protocols::StimulationProgram& program, const SensorSpec& sensor,
                           double floor_ratio, std::uint64_t seed, int max_rounds = 12,
                           double* rms_rad = nullptr);

}  // namespace fesim::foreign
