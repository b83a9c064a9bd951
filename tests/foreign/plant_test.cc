// Tests of foreign/plant.h: the passive equilibrium, energy conservation and power balance of the
// assembled right-hand side, the step-size bound against the linearised dynamics, RK4 convergence
// on a stimulated trial, and the stimulation schedule.
#include "foreign/plant.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "foreign/integrator.h"
#include "foreign/joint.h"
#include "foreign/muscle.h"

namespace fesim::foreign {
namespace {

constexpr double kEquilibriumTol = 1e-8;      // |dx/dt| at the passive equilibrium
constexpr double kEnergyRelTol = 1e-6;        // conservative runs, relative to the energy given
constexpr double kPowerBalanceRelTol = 1e-4;  // damped run, relative to the energy dissipated
constexpr double kConvergenceTolRad = 1e-6;   // h vs h/2 over a 5 s trial
constexpr double kEnergyStepS = 1e-4;         // RK4 step of the energy runs
constexpr double kRunS = 5.0;

Person WithoutMuscles(Person p) {
  for (MuscleParams& m : p.muscles) {
    m.contraction.max_force_n = 0.0;
    m.contraction.passive_coefficient = 0.0;
  }
  return p;
}

double MechanicalEnergy(const Plant& plant, const Eigen::VectorXd& x) {
  const Person& p = plant.person;
  const Eigen::Vector3d q = x.segment<3>(kStateQ), qd = x.segment<3>(kStateQd);
  double e = KineticEnergy(p.body, q, qd) + GravityPotential(p.body, p.gravity, q);
  for (int j = 0; j < kNumJoints; ++j) e += ElasticEnergy(p.joints[j], q[j]);
  for (const MuscleParams& m : p.muscles) {
    const double lm =
        MusculotendonLength(m, q, p.body.dip_pip_ratio) - m.contraction.tendon_slack_length_m;
    e += PassiveFibreEnergy(m.contraction, lm);
  }
  return e;
}

/// Integrates the plant without stimulation for kRunS, also accumulating D = ∫ Σ b_j q̇_j² dt in an
/// extra state; returns {E(0), E(T), D(T)}.
std::array<double, 3> EnergyRun(const Plant& plant, const Eigen::VectorXd& x0) {
  const int n = plant.state_size;
  Eigen::VectorXd y(n + 1);
  y.head(n) = x0;
  y[n] = 0.0;
  const OdeFunction f = [&](double t, const double* s, double* ds) {
    PlantDerivatives(plant, t, {0.0, 0.0}, s, ds);
    ds[n] = 0.0;
    for (int j = 0; j < kNumJoints; ++j) {
      ds[n] += plant.person.joints[j].damping_nm_s_per_rad * s[kStateQd + j] * s[kStateQd + j];
    }
  };
  Rk4 rk4(n + 1);
  const double e0 = MechanicalEnergy(plant, x0);
  rk4.Integrate(f, 0.0, kRunS, kEnergyStepS, y.data());
  return {e0, MechanicalEnergy(plant, y.head(n)), y[n]};
}

Eigen::VectorXd Perturbed(const Plant& plant) {
  Eigen::VectorXd x = RestState(plant, PassiveEquilibrium(plant));
  x.segment<3>(kStateQ) += Eigen::Vector3d(0.3, -0.3, 0.4);
  x.segment<3>(kStateQd) = Eigen::Vector3d(1.0, -2.0, 3.0);
  return x;
}

TEST(ForeignPlant, EquilibriumHasAllDerivativesZero) {
  std::vector<Plant> plants;
  plants.push_back(MakePlant(NominalPerson(), {}, 10, 1));
  plants.push_back(MakePlant(DrawPerson(PersonSpread{}, 3), {}, 10, 1));
  plants.push_back(MakePlant(DrawPerson(PersonSpread{}, 4),
                             {{"passive_stiffness_nonlinear", 2.0},
                              {"moment_arm_posture", 1.0},
                              {"fatigue", 1.0},
                              {"stiction", 1.0}},
                             10, 1));
  for (const Plant& plant : plants) {
    const Eigen::VectorXd x = RestState(plant, PassiveEquilibrium(plant));
    Eigen::VectorXd dx(plant.state_size);
    PlantDerivatives(plant, 0.0, {0.0, 0.0}, x.data(), dx.data());
    EXPECT_LT(dx.cwiseAbs().maxCoeff(), kEquilibriumTol) << dx.transpose();
  }
}

TEST(ForeignPlant, GravityAndSpringsWithoutMusclesOrDampingConserveEnergy) {
  Person p = WithoutMuscles(NominalPerson());
  for (JointParams& j : p.joints) j.damping_nm_s_per_rad = 0.0;
  for (double g : {p.gravity.magnitude_m_s2, 0.0}) {
    p.gravity.magnitude_m_s2 = g;
    const Plant plant = MakePlant(p, {}, kRunS, 1);
    const Eigen::VectorXd x0 = Perturbed(plant);
    const auto [e0, e1, dissipated] = EnergyRun(plant, x0);
    const double given = e0 - MechanicalEnergy(plant, RestState(plant, PassiveEquilibrium(plant)));
    EXPECT_EQ(dissipated, 0.0);
    EXPECT_LT(std::abs(e1 - e0), kEnergyRelTol * given) << "gravity " << g;
  }
}

TEST(ForeignPlant, PassiveMusclesAreConservativeToo) {
  // Relaxed muscles (a = 0) only pull with their passive fibres: energy V_pe(l_M(q)) closes the
  // balance only because ρ = −∂l_MT/∂q holds.
  Person p = NominalPerson();
  for (JointParams& j : p.joints) j.damping_nm_s_per_rad = 0.0;
  const Plant plant = MakePlant(p, {}, kRunS, 1);
  const Eigen::VectorXd x0 = Perturbed(plant);
  const auto [e0, e1, dissipated] = EnergyRun(plant, x0);
  const double given = e0 - MechanicalEnergy(plant, RestState(plant, PassiveEquilibrium(plant)));
  EXPECT_LT(std::abs(e1 - e0), kEnergyRelTol * given);
}

TEST(ForeignPlant, DampedEnergyLossEqualsTheDissipatedPower) {
  const Plant plant = MakePlant(WithoutMuscles(NominalPerson()), {}, kRunS, 1);
  const auto [e0, e1, dissipated] = EnergyRun(plant, Perturbed(plant));
  ASSERT_GT(dissipated, 0.0);
  EXPECT_LT(std::abs((e0 - e1) - dissipated), kPowerBalanceRelTol * dissipated);
}

TEST(ForeignPlant, StiffnessEstimateBoundsTheLinearisedMechanics) {
  for (const Person& person : {NominalPerson(), DrawPerson(PersonSpread{}, 5)}) {
    const Plant plant =
        MakePlant(person, {{"stiction", 1.0}, {"passive_stiffness_nonlinear", 3.0}}, 10, 1);
    for (double qw : {-0.6, 0.0, 0.6}) {
      Eigen::VectorXd x = RestState(plant, Eigen::Vector3d(qw, 0.5, 0.6));
      for (int m = 0; m < kNumMuscles; ++m) {  // every muscle fully active (u = 300 µs on both)
        x[kStateCoupling + m] = x[kStateActivation + m] =
            plant.person.muscles[m].recruitment.max_fraction;
      }
      const ChannelValues u{300.0, 300.0};
      x[kStateQd] = 0.2;  // sliding, outside the stiction band
      Eigen::Matrix<double, 6, 6> jac;
      Eigen::VectorXd dxp(plant.state_size), dxm(plant.state_size);
      for (int k = 0; k < 6; ++k) {
        const double h = 1e-7;
        Eigen::VectorXd xp = x, xm = x;
        xp[k] += h;
        xm[k] -= h;
        PlantDerivatives(plant, 0.0, u, xp.data(), dxp.data());
        PlantDerivatives(plant, 0.0, u, xm.data(), dxm.data());
        jac.col(k) = (dxp.head(6) - dxm.head(6)) / (2 * h);
      }
      const double largest = jac.eigenvalues().cwiseAbs().maxCoeff();
      EXPECT_LE(largest, StiffnessEstimate(plant, x.data(), u)) << qw;
    }
  }
}

protocols::StimulationProgram FiveSecondSteps() {
  protocols::StimulationProgram p;
  p.channels = {"ext", "flex"};
  p.times_s = {0.0, 0.5, 2.0, 2.5, 4.0};
  p.values_us = {{0, 0}, {300, 0}, {0, 0}, {0, 200}, {120, 60}};
  p.duration_s = kRunS;
  return p;
}

TEST(ForeignPlant, Rk4ConvergesHalvingTheStep) {
  const Plant plant = MakePlant(NominalPerson(), {}, kRunS, 1);
  const StimulationSchedule schedule = MakeSchedule(FiveSecondSteps(), 0.0);
  std::vector<double> times;
  for (int k = 0; k <= 500; ++k) times.push_back(k * 0.01);
  const Eigen::VectorXd x0 = RestState(plant, PassiveEquilibrium(plant));
  const IntegrationSpec h;  // ≤ 1 ms
  IntegrationSpec h2;
  h2.max_step_s = h.max_step_s / 2;
  h2.stability_factor = h.stability_factor / 2;
  const auto a = IntegratePlant(plant, schedule, x0, times, h);
  const auto b = IntegratePlant(plant, schedule, x0, times, h2);
  double worst = 0.0, moved = 0.0;
  for (std::size_t i = 0; i < times.size(); ++i) {
    worst = std::max(worst,
                     (a[i].segment<3>(kStateQ) - b[i].segment<3>(kStateQ)).cwiseAbs().maxCoeff());
    moved = std::max(moved, std::abs(a[i][kStateQ] - x0[kStateQ]));
  }
  EXPECT_GT(moved, 0.3);  // the trial does move
  EXPECT_LT(worst, kConvergenceTolRad);
}

TEST(ForeignPlant, NoStimulationStaysAtEquilibrium) {
  const Plant plant = MakePlant(DrawPerson(PersonSpread{}, 2), {}, kRunS, 1);
  protocols::StimulationProgram zero = FiveSecondSteps();
  for (auto& v : zero.values_us) v = {0.0, 0.0};
  const Eigen::VectorXd x0 = RestState(plant, PassiveEquilibrium(plant));
  const auto states = IntegratePlant(plant, MakeSchedule(zero, 0.0), x0, {0.0, 2.5, kRunS});
  for (const auto& x : states) EXPECT_LT((x - x0).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(ForeignPlant, ScheduleMapsChannelsByNameAndShiftsByTheDelay) {
  protocols::StimulationProgram p = FiveSecondSteps();
  p.channels = {"flex", "ext"};
  const StimulationSchedule s = MakeSchedule(p, 0.0);
  EXPECT_EQ(s.At(1.0)[kFlexChannel], 300.0);
  EXPECT_EQ(s.At(1.0)[kExtChannel], 0.0);
  const StimulationSchedule d = MakeSchedule(FiveSecondSteps(), 0.06);
  EXPECT_EQ(d.At(0.53)[kExtChannel], 0.0);
  EXPECT_EQ(d.At(0.57)[kExtChannel], 300.0);
  EXPECT_EQ(d.At(4.5)[kExtChannel], 120.0);
  protocols::StimulationProgram late = FiveSecondSteps();
  late.times_s[0] = 0.2;
  EXPECT_EQ(MakeSchedule(late, 0.0).At(0.1), (ChannelValues{0.0, 0.0}));  // ValueAt: first value
  late.values_us[0] = {50.0, 0.0};
  EXPECT_EQ(MakeSchedule(late, 0.0).At(0.1)[kExtChannel], 50.0);
}

TEST(ForeignPlant, ScheduleRejectsOtherChannelsAndBadValues) {
  protocols::StimulationProgram p = FiveSecondSteps();
  p.channels = {"ext", "tri"};
  try {
    MakeSchedule(p, 0.0);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("\"ext\" and \"flex\""), std::string::npos);
  }
  p = FiveSecondSteps();
  p.values_us[1][0] = 400.0;
  EXPECT_THROW(MakeSchedule(p, 0.0), std::invalid_argument);
  p = FiveSecondSteps();
  p.times_s[2] = 0.1;
  EXPECT_THROW(MakeSchedule(p, 0.0), std::invalid_argument);
  p = FiveSecondSteps();
  p.duration_s = 3.0;
  EXPECT_THROW(MakeSchedule(p, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::foreign
