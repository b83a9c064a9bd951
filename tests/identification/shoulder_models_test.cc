#include "identification/shoulder_models.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

namespace fesim::identification {
namespace {

constexpr double kExactTol = 1e-12;
constexpr double kRecoveryRelTol = 1e-2;  // planted parameters recovered within 1 %
constexpr double kDt = 0.01;              // s
constexpr unsigned kSeed = 20130707;

/// Pseudo-random activation steps, one muscle at a time ([Spagnol 2013] §III-A reference test).
ShoulderData StepInputs(double duration_s, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> level(0.2, 1.0), hold(0.8, 2.5);
  ShoulderData d;
  d.joint = "shoulder_horizontal";
  double t = 0.0, next_switch = 0.0, s_ant = 0.0, s_post = 0.0;
  int phase = 0;
  while (t < duration_s) {
    if (t >= next_switch) {
      phase = (phase + 1) % 4;  // ant, rest, post, rest
      s_ant = phase == 1 ? level(rng) : 0.0;
      s_post = phase == 3 ? level(rng) : 0.0;
      next_switch = t + hold(rng);
    }
    d.time.push_back(t);
    d.sigma_ant.push_back(s_ant);
    d.sigma_post.push_back(s_post);
    t += kDt;
  }
  d.theta.assign(d.time.size(), 0.0);
  d.omega.assign(d.time.size(), 0.0);
  return d;
}

ShoulderData Simulated(ShoulderModel model, const Eigen::VectorXd& p, double tm_ant, double tm_post,
                       unsigned seed) {
  ShoulderData d = StepInputs(60.0, seed);
  const auto sim = SimulateShoulder(model, p, tm_ant, tm_post, d, true);
  d.theta = sim.theta;
  d.omega = sim.omega;
  return d;
}

TEST(ShoulderModels, RegressorsReproduceTheModelEquations) {
  ShoulderModel1Params m1{-1.8, 1.7, 0.3, 0.6, 0.9, 0.3, 7.0, 0.95, 0.2};
  ShoulderModel2Params m2;
  m2.k_ant = 1.9;
  m2.k_post = 2.3;
  m2.r_ant = 0.2;
  m2.r_post = 0.1;
  m2.k_m = 6.56;
  m2.r_m = 1.3;
  m2.c = 0.2;
  for (double theta : {-0.4, 0.0, 0.3}) {
    for (double omega : {-0.5, 0.7}) {
      const double sa = 0.6, sp = 0.25;
      const auto phi1 = ModelRegressors(ShoulderModel::kModel1, 0, 0, sa, sp, theta, omega);
      const auto p1 = ToVector(m1);
      EXPECT_NEAR(phi1.dot(p1),
                  Model1DriveAcceleration(m1, sa, sp, theta, omega) - m1.c * (omega > 0 ? 1 : -1),
                  kExactTol);
      // [Spagnol 2013] eq. 2 written by hand.
      const double eq2 = m1.a_ant * sa + m1.a_post * sp - m1.k_m * theta -
                         (m1.k_ant * sa + m1.k_post * sp) * theta - m1.r_m * omega -
                         (m1.r_ant * sa + m1.r_post * sp) * omega;
      EXPECT_NEAR(Model1DriveAcceleration(m1, sa, sp, theta, omega), eq2, kExactTol);
      const auto phi2 = ModelRegressors(ShoulderModel::kModel2, m2.theta_max_ant, m2.theta_max_post,
                                        sa, sp, theta, omega);
      const double eq3 = m2.k_ant * sa * (m2.theta_max_ant - theta) +
                         m2.k_post * sp * (m2.theta_max_post - theta) -
                         (m2.r_ant * sa + m2.r_post * sp) * omega - m2.r_m * omega - m2.k_m * theta;
      EXPECT_NEAR(Model2DriveAcceleration(m2, sa, sp, theta, omega), eq3, kExactTol);
      EXPECT_NEAR(phi2.dot(ToVector(m2)), eq3 - m2.c * (omega > 0 ? 1 : -1), kExactTol);
    }
  }
  const auto back = Model2FromVector(ToVector(m2), m2);
  EXPECT_EQ(back.k_post, m2.k_post);
  EXPECT_EQ(Model1FromVector(ToVector(m1)).r_ant, m1.r_ant);
}

TEST(ShoulderModels, StickSlipFrictionNeverReversesVelocity) {
  double theta = 0.0, omega = 0.0;
  EulerFrictionStep(0.1, 0.2, kDt, true, &theta, &omega);  // |drive| ≤ c: stays stuck
  EXPECT_EQ(omega, 0.0);
  EulerFrictionStep(0.5, 0.2, kDt, true, &theta, &omega);  // breaks away with drive − c
  EXPECT_NEAR(omega, kDt * 0.3, kExactTol);
  omega = 0.001;
  EulerFrictionStep(-5.0, 0.2, kDt, true, &theta, &omega);  // would reverse: stops
  EXPECT_EQ(omega, 0.0);
  EXPECT_NEAR(theta, 0.001 * kDt, kExactTol);
}

TEST(ShoulderModels, PerformanceIndexIsNormalisedSquaredError) {
  const std::vector<double> y = {0.0, 1.0, 2.0, 3.0};
  EXPECT_NEAR(PerformanceIndexJL(y, y), 0.0, kExactTol);
  EXPECT_NEAR(PerformanceIndexJL(y, {1.5, 1.5, 1.5, 1.5}), 1.0, kExactTol);
  // Σe² = 1, Σ(y − ȳ)² = 5.
  EXPECT_NEAR(PerformanceIndexJL(y, {0.0, 1.0, 2.0, 4.0}), 0.2, kExactTol);
}

TEST(ShoulderModels, Model2FitRecoversPlantedParameters) {
  ShoulderModel2Params truth;
  truth.k_ant = 1.9;
  truth.k_post = 2.33;
  truth.r_ant = 0.0;
  truth.r_post = 0.0;
  truth.k_m = 6.56;
  truth.r_m = 1.3;
  truth.c = 0.1;
  const Eigen::VectorXd p = ToVector(truth);
  std::vector<ShoulderData> trials = {
      Simulated(ShoulderModel::kModel2, p, truth.theta_max_ant, truth.theta_max_post, kSeed)};
  const auto fit = FitShoulderModel(ShoulderModel::kModel2, trials, truth.theta_max_ant,
                                    truth.theta_max_post, -1.0);
  const auto names = ParameterNames(ShoulderModel::kModel2);
  for (int i = 0; i < p.size(); ++i) {
    const double scale = std::max(std::abs(p(i)), 0.1);  // zero parameters: absolute 1e-3
    EXPECT_NEAR(fit.p(i), p(i), kRecoveryRelTol * scale) << names[i];
  }
  EXPECT_LT(fit.cost, 1e-6);
}

TEST(ShoulderModels, Model1FitRecoversPlantedParametersWithKnownFriction) {
  const ShoulderModel1Params truth{-1.77, 1.76, 0.33, 0.6, 0.89, 0.3, 7.0, 0.95, 0.15};
  const Eigen::VectorXd p = ToVector(truth);
  std::vector<ShoulderData> trials = {Simulated(ShoulderModel::kModel1, p, 0, 0, kSeed + 1),
                                      Simulated(ShoulderModel::kModel1, p, 0, 0, kSeed + 2)};
  const auto fit = FitShoulderModel(ShoulderModel::kModel1, trials, 0, 0, truth.c);
  const auto names = ParameterNames(ShoulderModel::kModel1);
  for (int i = 0; i < p.size(); ++i) {
    EXPECT_NEAR(fit.p(i), p(i), kRecoveryRelTol * std::abs(p(i))) << names[i];
  }
  EXPECT_TRUE(fit.friction_known);
  EXPECT_EQ(fit.p(8), truth.c);
}

TEST(ShoulderModels, MethodPredictsHeldOutTrialBySimulation) {
  ShoulderModel2Params truth;
  truth.k_ant = 1.9;
  truth.k_post = 2.33;
  truth.k_m = 6.56;
  truth.r_m = 1.3;
  truth.c = 0.1;
  auto to_trial = [](const ShoulderData& d) {
    Trial t;
    t.time = d.time;
    t.AddColumn("a.deltoid_posterior", d.sigma_post);  // order must not matter
    t.AddColumn("a.deltoid_anterior", d.sigma_ant);
    t.AddColumn("q.shoulder", d.theta);
    t.AddColumn("qd.shoulder", d.omega);
    return t;
  };
  const Eigen::VectorXd p = ToVector(truth);
  const Trial train = to_trial(
      Simulated(ShoulderModel::kModel2, p, truth.theta_max_ant, truth.theta_max_post, kSeed + 5));
  const Trial test = to_trial(
      Simulated(ShoulderModel::kModel2, p, truth.theta_max_ant, truth.theta_max_post, kSeed + 6));
  const auto r = RunShoulderModelMethod(ShoulderModel::kModel2, {train}, {test}, nullptr);
  ASSERT_EQ(r.predictions.size(), 1u);
  const auto& w_hat = r.predictions[0].Column("qd.shoulder");
  const auto& th_hat = r.predictions[0].Column("q.shoulder");
  EXPECT_LT(PerformanceIndexJL(test.Column("qd.shoulder"), w_hat), 1e-4);
  EXPECT_LT(PerformanceIndexJL(test.Column("q.shoulder"), th_hat), 1e-4);
  EXPECT_NE(r.model_yaml.find("k_ant: {value: 1.9"), std::string::npos) << r.model_yaml;
}

TEST(ShoulderModels, BadInputNamesTheColumn) {
  Trial t;
  for (int i = 0; i < 20; ++i) t.time.push_back(0.01 * i);
  t.AddColumn("a.deltoid_anterior", std::vector<double>(20, 0.1));
  t.AddColumn("a.deltoid_posterior", std::vector<double>(20, 0.0));
  try {
    ExtractShoulderData(t);
    FAIL() << "missing q column accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("q.<joint>"), std::string::npos) << e.what();
  }
  std::vector<double> q(20, 0.0);
  q[5] = NAN;
  t.AddColumn("q.shoulder", q);
  try {
    ExtractShoulderData(t);
    FAIL() << "NaN accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("q.shoulder"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ExtractShoulderData(t, 100), std::runtime_error);
}

TEST(ShoulderModels, ExtractionPicksAnteriorAndPosteriorByName) {
  Trial t;
  for (int i = 0; i < 20; ++i) t.time.push_back(0.01 * i);
  t.AddColumn("u.ch_posterior", std::vector<double>(20, 150.0));
  t.AddColumn("u.ch_anterior", std::vector<double>(20, 300.0));
  std::vector<double> q(20);
  for (int i = 0; i < 20; ++i) q[i] = 0.5 * t.time[i];
  t.AddColumn("q.sh", q);
  const auto d = ExtractShoulderData(t);
  EXPECT_NEAR(d.sigma_ant[3], 1.0, kExactTol);
  EXPECT_NEAR(d.sigma_post[3], 0.5, kExactTol);
  EXPECT_NEAR(d.omega[7], 0.5, 1e-9);  // differentiated q
  EXPECT_EQ(d.joint, "sh");
}

}  // namespace
}  // namespace fesim::identification
