#include "scenarios/scenario.h"

#include <dirent.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "scenarios/benchmark_spec.h"
#include "scenarios/study.h"
#include "sim/reaching.h"
#include "sim/upper_limb_model.h"

namespace fesim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

const char* kMinimal = R"(name: t
stimulation: {duration_s: 2, type: constant, values_us: {ext: 100}}
)";

std::string ErrorOf(const std::string& yaml) {
  try {
    ParseScenario(yaml, "s.yaml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Scenario, MinimalScenarioUsesDefaults) {
  const Scenario s = ParseScenario(kMinimal, "s.yaml");
  EXPECT_EQ(s.name, "t");
  EXPECT_EQ(s.model.muscles.size(), 14u);
  EXPECT_EQ(s.trial.duration_s, 2.0);
  ASSERT_EQ(s.trial.stimulation.values.size(), 1u);
  EXPECT_EQ(s.trial.stimulation.values[0][0], 100.0);
  EXPECT_EQ(s.trial.stimulation.values[0][1], 0.0);
  EXPECT_EQ(s.trial.sensors.angles.coordinates.size(), 10u);  // all free by default
}

TEST(Scenario, OverridesAreApplied) {
  const Scenario s = ParseScenario(R"(name: iso
participant: {height_m: 1.6, mass_kg: 60}
gravity_m_s2: [0, 0, -9.81]
coordinates:
  elbow_flexion: {mode: locked, initial_deg: 90, stiffness_nm_per_rad: 3}
  wrist_flexion: {mode: prescribed, prescription: {offset_deg: 10, amplitude_deg: 20, frequency_hz: 1}}
muscles:
  BIC: {max_isometric_force_n: 500, omega_rad_s: 7, deactivation_ratio: 0.4}
electrodes:
  channels: [{name: bic, muscles: {BIC: 1.0}}, {name: arr, pads: [0, 23]}]
support:
  bands: [{segment: forearm, cuff_m: [0, -0.1, 0], anchor_m: [0, 2, 0], stiffness_n_per_m: 50, slack_length_m: 0.5}]
stimulation:
  duration_s: 3
  type: steps
  steps: [{time_s: 0, values_us: {bic: 50}}, {time_s: 1, values_us: {arr: 200}}]
sensors:
  torques: {rate_hz: 500, noise_std_nm: 0.02, coordinates: [elbow_flexion]}
integrator: {method: simbody-rkm, tolerance: 1e-7}
)",
                                   "s.yaml");
  EXPECT_NEAR(s.model.segments[sim::kForearm].length_m, 0.146 * 1.6, 1e-12);
  EXPECT_EQ(s.model.gravity_m_s2[2], -9.81);
  const auto& elbow = s.model.coordinates[sim::kElbowFlexion];
  EXPECT_EQ(elbow.mode, sim::CoordinateMode::kLocked);
  EXPECT_NEAR(elbow.initial_rad, 90 * kDeg, 1e-12);
  EXPECT_EQ(elbow.passive.stiffness_nm_per_rad, 3.0);
  const auto& wrist = s.model.coordinates[sim::kWristFlexion];
  EXPECT_EQ(wrist.mode, sim::CoordinateMode::kPrescribed);
  EXPECT_NEAR(wrist.prescription.amplitude_rad, 20 * kDeg, 1e-12);
  EXPECT_EQ(s.model.muscles[8].hill.max_isometric_force_n, 500.0);
  EXPECT_EQ(s.model.muscles[8].deactivation_ratio, 0.4);
  ASSERT_EQ(s.model.channels.size(), 2u);
  EXPECT_EQ(s.model.channels[1].pads, (std::vector<int>{0, 23}));
  EXPECT_EQ(s.model.bands.size(), 1u);
  EXPECT_EQ(s.trial.stimulation.values[1], (std::vector<double>{0, 200}));
  EXPECT_EQ(s.trial.sensors.torques.rate_hz, 500.0);
  EXPECT_EQ(s.trial.integrator.method, sim::IntegratorParams::Method::kSimbodyRkMerson);
}

TEST(Scenario, EveryBadInputClassNamesFileKeyAndRange) {
  // Unknown key.
  EXPECT_EQ(ErrorOf(std::string(kMinimal) + "colour: red\n"),
            "s.yaml: colour: unknown key (allowed: coordinates, electrodes, gravity_m_s2, "
            "integrator, mechanisms, muscles, name, participant, sensors, stimulation, support)");
  // Missing required key.
  EXPECT_EQ(ErrorOf("name: t\n"), "s.yaml: stimulation: missing required key");
  EXPECT_EQ(ErrorOf("stimulation: {duration_s: 2, type: constant, values_us: {}}\n"),
            "s.yaml: name: missing required key");
  // Wrong type.
  EXPECT_EQ(ErrorOf("name: t\nparticipant: {height_m: tall}\nstimulation: {duration_s: 2, type: "
                    "constant, values_us: {}}\n"),
            "s.yaml: participant.height_m: expected a number in [1.2, 2.2]");
  // Out of range.
  EXPECT_EQ(ErrorOf(std::string(kMinimal) + "coordinates: {elbow_flexion: {initial_deg: 200}}\n"),
            "s.yaml: coordinates.elbow_flexion.initial_deg: 200 is outside [0, 150]");
  EXPECT_EQ(
      ErrorOf("name: t\nstimulation: {duration_s: 2, type: constant, values_us: {ext: 400}}\n"),
      "s.yaml: stimulation.values_us.ext: 400 is outside [0, 300]");
  // Unknown names.
  EXPECT_EQ(ErrorOf(std::string(kMinimal) + "muscles: {XYZ: {alpha: 0.5}}\n"),
            "s.yaml: muscles.XYZ: unknown muscle (allowed: ECRL, ECRB, ECU, FCR, FCU, EDC, FDS, "
            "FDP, BIC, BRA, BRD, TRI, DELT1, DELT3)");
  EXPECT_NE(ErrorOf(std::string(kMinimal) + "coordinates: {knee: {}}\n")
                .find("unknown coordinate 'knee'"),
            std::string::npos);
  EXPECT_EQ(ErrorOf("name: t\nstimulation: {duration_s: 2, type: ramp}\n"),
            "s.yaml: stimulation.type: 'ramp' is not one of constant|csv|protocol|reaching|steps");
  EXPECT_EQ(ErrorOf(std::string(kMinimal) + "electrodes: {channels: [{name: a, pads: [24]}]}\n"),
            "s.yaml: electrodes.channels[0].pads: element 0 = 24 is not an integer in [0, 23]");
  EXPECT_NE(ErrorOf("name: [\n").find("s.yaml:"), std::string::npos);  // YAML syntax
  EXPECT_EQ(ErrorOf(std::string(kMinimal) + "sensors: {torques: {coordinates: [elbow_flexion]}}\n"),
            "s.yaml: sensors.torques.coordinates: torque sensor on free coordinate elbow_flexion "
            "(allowed: locked or prescribed ones)");
}

TEST(Scenario, MechanismsAndArtefacts) {
  const Scenario s = ParseScenario(std::string(kMinimal) + R"(mechanisms:
  fatigue: {fatigue_time_s: 20, recovery_time_s: 200, min_fitness: 0.2}
  potentiation: {gain: 0.3}
  electromechanical_delay_s: 0.04
  tremor: {coordinate: elbow_flexion, frequency_hz: 5, amplitude_nm: 0.1}
  crosstalk: {fraction: 0.1, spread_m: 0.04}
  stretch_reflex: {gain: 0.2, threshold_per_s: 0.3, muscles: [FCR, FDS]}
coordinates:
  elbow_flexion: {static_friction_nm: 0.4, coulomb_friction_nm: 0.2, reflex_gain_nms_per_rad: 1,
                  reflex_threshold_deg_s: 60, reflex_direction_bias: 0.5}
sensors:
  angles: {offset_drift_deg_per_s: 0.1, dropout_probability: 0.1, outlier_probability: 0.02,
           outlier_std_deg: 10}
)",
                                   "s.yaml");
  const auto& m = s.model.mechanisms;
  EXPECT_TRUE(m.fatigue.enabled);
  EXPECT_EQ(m.fatigue.min_fitness, 0.2);
  EXPECT_TRUE(m.potentiation.enabled);
  EXPECT_EQ(m.electromechanical_delay_s, 0.04);
  EXPECT_TRUE(m.tremor.enabled);
  EXPECT_EQ(m.tremor.coordinate, sim::kElbowFlexion);
  EXPECT_EQ(m.crosstalk.fraction, 0.1);
  EXPECT_TRUE(m.stretch_reflex.enabled());
  EXPECT_EQ(m.stretch_reflex.threshold_per_s, 0.3);
  EXPECT_EQ(m.stretch_reflex.loop_delay_s, 0.04);
  EXPECT_EQ(m.stretch_reflex.muscles, (std::vector<std::string>{"FCR", "FDS"}));
  const auto& elbow = s.model.coordinates[sim::kElbowFlexion].passive;
  EXPECT_EQ(elbow.static_friction_nm, 0.4);
  EXPECT_NEAR(elbow.reflex_threshold_rad_s, 60 * kDeg, 1e-12);
  EXPECT_EQ(elbow.reflex_direction_bias, 0.5);
  EXPECT_NEAR(s.trial.sensors.angles.offset_drift_per_s, 0.1 * kDeg, 1e-15);
  EXPECT_NEAR(s.trial.sensors.angles.outlier_std, 10 * kDeg, 1e-12);
  EXPECT_EQ(ErrorOf(std::string(kMinimal) + "mechanisms: {tremor: {frequency_hz: 20}}\n"),
            "s.yaml: mechanisms.tremor.frequency_hz: 20 is outside [3, 12]");
  EXPECT_EQ(ErrorOf(std::string(kMinimal) +
                    "mechanisms: {stretch_reflex: {gain: 0.2, muscles: [FCR, XYZ]}}\n"),
            "s.yaml: mechanisms.stretch_reflex: muscles: unknown muscle 'XYZ'");
}

TEST(Scenario, ProtocolStimulation) {
  const Scenario grid = ParseScenario(R"(name: g
stimulation:
  type: protocol
  protocol: {name: step_grid, channels: [ext, flex], u_max_us: 100, step_duration_s: 2}
)",
                                      "s.yaml");
  // Points (u_ext, u_flex) on a 50 µs grid with u_ext + u_flex ≤ 100: 6 points of 2 s.
  EXPECT_EQ(grid.trial.stimulation.times.size(), 6u);
  EXPECT_NEAR(grid.trial.duration_s, 12.0, 1e-12);
  EXPECT_EQ(grid.trial.steady_state_times_s.size(), 6u);
  for (const auto& u : grid.trial.stimulation.values) {
    EXPECT_LE(u[0] + u[1], 100.0);
    EXPECT_EQ(u[2], 0.0);  // bic untouched
  }
  const Scenario ramp = ParseScenario(R"(name: r
coordinates: {elbow_flexion: {mode: locked, initial_deg: 90}}
stimulation: {type: protocol, protocol: {name: ramp, channel: bic, u_max_us: 200}}
)",
                                      "s.yaml");
  EXPECT_NEAR(ramp.trial.duration_s, 30.0, 1e-12);
  double peak = 0.0;
  for (const auto& u : ramp.trial.stimulation.values) peak = std::max(peak, u[2]);
  EXPECT_NEAR(peak, 200.0, 1e-9);
  const Scenario reach = ParseScenario(
      "name: r\nstimulation: {type: reaching, reaching: {repetitions: 1, hold_s: 0.5}}\n",
      "s.yaml");
  ASSERT_TRUE(reach.reaching.has_value());
  EXPECT_EQ(reach.reaching->repetitions, 1);
  EXPECT_EQ(ErrorOf("name: r\nstimulation: {type: reaching, reaching: {homes_m: [[0, 1]]}}\n"),
            "s.yaml: stimulation.reaching.homes_m[0]: expected a list of 3 numbers");
  // Issue 27: explicit paths ([Schearer 2014]'s subject with SCI) and the reaching sensors.
  const Scenario paths = ParseScenario(
      "name: r\nstimulation: {type: reaching, reaching: {paths: [{home: 1, target: 8}, "
      "{home: 0, target: 2}]}}\nsensors: {angles: {noise_std_deg: 0.5, lowpass_hz: 2}, "
      "force: {noise_std_n: 0.2}}\n",
      "s.yaml");
  ASSERT_EQ(paths.reaching->paths.size(), 2u);
  EXPECT_EQ(paths.reaching->paths[0], (std::array<int, 2>{1, 8}));
  EXPECT_NEAR(paths.trial.sensors.angles.noise_std, 0.5 * M_PI / 180.0, 1e-15);
  EXPECT_EQ(paths.trial.sensors.angles.lowpass_hz, 2.0);
  EXPECT_EQ(paths.trial.sensors.force.noise_std, 0.2);
  EXPECT_EQ(paths.trial.sensors.force.lowpass_hz, 0.0);
  EXPECT_EQ(reach.trial.sensors.angles.noise_std, 0.0);  // reaching without sensors: noiseless
  EXPECT_EQ(ErrorOf("name: r\nstimulation: {type: reaching, reaching: {paths: [{home: 2, "
                    "target: 0}]}}\n"),
            "s.yaml: stimulation.reaching: ReachingParams.paths[0] home index 2 is outside [0, 1]");
  EXPECT_EQ(ErrorOf("name: r\nstimulation: {type: reaching, reaching: {paths: [{home: 0, "
                    "target: 0}, {home: 0, target: 0}]}}\n"),
            "s.yaml: stimulation.reaching: ReachingParams.paths[1] repeats path [0, 0]; each pair "
            "at most once");
  EXPECT_EQ(ErrorOf("name: r\nstimulation: {type: reaching, reaching: {sample_rate_hz: 10}}\n"
                    "sensors: {angles: {lowpass_hz: 5}}\n"),
            "s.yaml: sensors.angles.lowpass_hz: 5 is outside [0, 5) (below half of "
            "stimulation.reaching.sample_rate_hz)");
  EXPECT_EQ(ErrorOf("name: r\nstimulation: {type: reaching}\nsensors: {angles: {rate_hz: 5}}\n"),
            "s.yaml: sensors.angles.rate_hz: unknown key (allowed: lowpass_hz, noise_std_deg)");
  EXPECT_EQ(ErrorOf("name: c\nstimulation: {type: constant, duration_s: 1, values_us: {}}\n"
                    "sensors: {force: {noise_std_n: 1}}\n"),
            "s.yaml: sensors.force: unknown key (allowed: angles, torques, truth_rate_hz, "
            "velocities)");
  EXPECT_EQ(ErrorOf("name: c\nstimulation: {type: constant, duration_s: 1, values_us: {}}\n"
                    "sensors: {angles: {lowpass_hz: 1}}\n"),
            "s.yaml: sensors.angles.lowpass_hz: only for robot-driven reaching (stimulation type "
            "reaching)");
  EXPECT_EQ(ErrorOf("name: p\nstimulation: {type: protocol, protocol: {name: chirp}}\n"),
            "s.yaml: stimulation.protocol.name: 'chirp' is not one of filtered_noise|multisine|"
            "prms|ramp|shoulder_steps|staircase|step_grid");
  EXPECT_EQ(ErrorOf("name: p\nstimulation: {type: protocol, protocol: {name: ramp, channel: x}}\n"),
            "s.yaml: stimulation.protocol.channel: unknown channel 'x'");
  EXPECT_NE(ErrorOf("name: p\nstimulation: {type: protocol, protocol: {name: prms, channel: bic, "
                    "num_levels: 4}}\n")
                .find("s.yaml: stimulation.protocol: "),
            std::string::npos);
}

TEST(Scenario, EveryShippedScenarioLoadsAndSimulates) {
  const std::string dir = std::string(FESIM_SOURCE_DIR_PATH) + "/scenarios";
  DIR* d = opendir(dir.c_str());
  ASSERT_NE(d, nullptr);
  int count = 0;
  while (dirent* e = readdir(d)) {
    const std::string f = e->d_name;
    if (f.size() < 5 || f.substr(f.size() - 5) != ".yaml") continue;
    if (IsStudy(ReadFile(dir + "/" + f))) {  // a study: its items must load
      EXPECT_FALSE(LoadStudy(dir + "/" + f, 1).items.empty()) << f;
      continue;
    }
    if (ReadFile(dir + "/" + f).find("\nbenchmark:") != std::string::npos ||
        ReadFile(dir + "/" + f).rfind("benchmark:", 0) == 0) {  // a benchmark study: it loads
      const BenchmarkSpec b = LoadBenchmarkSpec(dir + "/" + f);
      EXPECT_FALSE(b.name.empty()) << f;
      continue;
    }
    Scenario sc = LoadScenario(dir + "/" + f);
    if (sc.reaching) {  // robot-driven: one home, one target, once
      sc.reaching->homes_m.resize(1);
      sc.reaching->targets_m.resize(1);
      sc.reaching->repetitions = 1;
      sc.reaching->paths.clear();
      const auto trials = sim::SimulateReaching(sc.model, *sc.reaching, {}, sc.trial.sensors);
      ASSERT_EQ(trials.size(), 1u) << f;
      EXPECT_TRUE(trials[0].Has("f.robot_x")) << f;
      ++count;
      continue;
    }
    sc.trial.duration_s = std::min(sc.trial.duration_s, 1.0);
    const sim::UpperLimbModel model(sc.model);
    const auto r = sim::RunTrial(model, sc.trial);
    ASSERT_GT(r.truth.size(), 10u) << f;
    for (const auto& col : r.truth.columns) {
      for (double v : col) ASSERT_TRUE(std::isfinite(v)) << f;
    }
    ++count;
  }
  closedir(d);
  EXPECT_GE(count, 3);
}

TEST(Scenario, CsvStimulationFileIsReadRelativeToScenario) {
  const std::string dir = ::testing::TempDir();
  WriteFileAtomic(dir + "u.csv",
                  "time,u.ext,u.flex,u.bic,u.tri,u.delt_ant,u.delt_post\n0,0,0,0,0,0,0\n"
                  "0.5,100,50,0,0,0,0\n");
  const Scenario s = ParseScenario(
      "name: c\nstimulation: {duration_s: 1, type: csv, file: u.csv}\n", dir + "c.yaml");
  ASSERT_EQ(s.trial.stimulation.times.size(), 2u);
  EXPECT_EQ(s.trial.stimulation.values[1][1], 50.0);
  WriteFileAtomic(dir + "bad.csv", "time,u.ext\n0,0\n");
  try {
    ParseScenario("name: c\nstimulation: {duration_s: 1, type: csv, file: bad.csv}\n",
                  dir + "c.yaml");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("has no column u.flex"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace fesim
