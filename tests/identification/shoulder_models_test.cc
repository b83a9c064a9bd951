#include "identification/shoulder_models.h"

#include <gtest/gtest.h>

#include <algorithm>
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

/// The shoulder_exo rig's frame: q = kRigRest − θ (adduction positive, rest 45°), its sensor
/// noise (0.2°, 1°/s) and pulse-width inputs u = 300 µs · σ named as the rig names them.
constexpr double kRigRest = 0.785398;                  // rad
constexpr double kRigAngleNoise = 0.2 * M_PI / 180.0;  // rad
constexpr double kRigVelocityNoise = M_PI / 180.0;     // rad/s
constexpr double kNoisyRecoveryRelTol = 0.05;  // planted parameters within 5 % from noisy data
constexpr double kNoisyZeroTol = 0.05;         // planted zeros within 0.05 (their unit)
constexpr double kNoiseFloorFactor = 1.1;      // held-out J_L within 10 % of the noise floor

Trial RigFrameTrial(const ShoulderData& paper_frame, unsigned noise_seed) {
  std::mt19937 rng(noise_seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  Trial t;
  t.time = paper_frame.time;
  std::vector<double> u_ant, u_post, q, qd;
  for (std::size_t k = 0; k < t.time.size(); ++k) {
    u_ant.push_back(kShoulderFullActivationPulseWidthUs * paper_frame.sigma_ant[k]);
    u_post.push_back(kShoulderFullActivationPulseWidthUs * paper_frame.sigma_post[k]);
    q.push_back(kRigRest - paper_frame.theta[k] + kRigAngleNoise * n01(rng));
    qd.push_back(-paper_frame.omega[k] + kRigVelocityNoise * n01(rng));
  }
  t.AddColumn("u.delt_ant", u_ant);
  t.AddColumn("u.delt_post", u_post);
  t.AddColumn("q.shoulder_elv_plane", q);
  t.AddColumn("qd.shoulder_elv_plane", qd);
  return t;
}

TEST(ShoulderModels, PerformanceIndexIsNormalisedSquaredError) {
  const std::vector<double> y = {0.0, 1.0, 2.0, 3.0};
  EXPECT_NEAR(PerformanceIndexJL(y, y), 0.0, kExactTol);
  EXPECT_NEAR(PerformanceIndexJL(y, {1.5, 1.5, 1.5, 1.5}), 1.0, kExactTol);
  // Σe² = 1, Σ(y − ȳ)² = 5.
  EXPECT_NEAR(PerformanceIndexJL(y, {0.0, 1.0, 2.0, 4.0}), 0.2, kExactTol);
}

/// The planted model-2 person of the recovery tests (r_ant = r_post = 0).
ShoulderModel2Params PlantedModel2() {
  ShoulderModel2Params truth;
  truth.k_ant = 1.9;
  truth.k_post = 2.33;
  truth.r_ant = 0.0;
  truth.r_post = 0.0;
  truth.k_m = 6.56;
  truth.r_m = 1.3;
  truth.c = 0.1;
  return truth;
}

TEST(ShoulderModels, Model2FitRecoversPlantedParameters) {
  const ShoulderModel2Params truth = PlantedModel2();
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

// [Spagnol 2013] §III-C: R̃1 = R̃2 = 0 in Table II(a), and §IV's EKF (eq. 4) drops them. The fit
// that holds them at zero keeps them there and recovers the rest; the free fit finds them.
TEST(ShoulderModels, Model2FitWithZeroActivationDampingHoldsThemAtZero) {
  ShoulderModel2Params truth = PlantedModel2();
  truth.r_ant = 0.4;
  truth.r_post = 0.3;
  const Eigen::VectorXd p = ToVector(truth);
  const std::vector<ShoulderData> trials = {
      Simulated(ShoulderModel::kModel2, p, truth.theta_max_ant, truth.theta_max_post, kSeed + 3)};
  const auto free = FitShoulderModel(ShoulderModel::kModel2, trials, truth.theta_max_ant,
                                     truth.theta_max_post, truth.c);
  EXPECT_FALSE(free.zero_activation_damping);
  EXPECT_NEAR(free.p(2), truth.r_ant, kRecoveryRelTol * truth.r_ant);
  EXPECT_NEAR(free.p(3), truth.r_post, kRecoveryRelTol * truth.r_post);
  const auto held = FitShoulderModel(ShoulderModel::kModel2, trials, truth.theta_max_ant,
                                     truth.theta_max_post, truth.c, Eigen::VectorXd(), true);
  EXPECT_TRUE(held.zero_activation_damping);
  EXPECT_EQ(held.p(2), 0.0);
  EXPECT_EQ(held.p(3), 0.0);
  EXPECT_EQ(held.ci95(2), 0.0);
  EXPECT_GT(held.cost, free.cost);  // the planted damping is missing
  // Planted without activation damping, the held fit recovers every parameter.
  const ShoulderModel2Params simple = PlantedModel2();
  const Eigen::VectorXd ps = ToVector(simple);
  const auto fit = FitShoulderModel(ShoulderModel::kModel2,
                                    {Simulated(ShoulderModel::kModel2, ps, simple.theta_max_ant,
                                               simple.theta_max_post, kSeed + 4)},
                                    simple.theta_max_ant, simple.theta_max_post, simple.c,
                                    Eigen::VectorXd(), true);
  for (int i : {0, 1, 4, 5}) EXPECT_NEAR(fit.p(i), ps(i), kRecoveryRelTol * ps(i)) << i;
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

// fesim's rig measures the angle from another zero and with the other sign than
// [Spagnol 2013] (adduction positive). Model 2's fixed θmax then pointed each muscle the wrong way,
// and the fit stayed at K_ant = K_post = 0 (a flat prediction, J_L ≈ 100 %).
TEST(ShoulderModels, Model2RecoversPlantedParametersFromNoisyRigFrameTrials) {
  const ShoulderModel2Params truth = PlantedModel2();
  const Eigen::VectorXd p = ToVector(truth);
  const ShoulderData train_paper =
      Simulated(ShoulderModel::kModel2, p, truth.theta_max_ant, truth.theta_max_post, kSeed + 7);
  const ShoulderData test_paper =
      Simulated(ShoulderModel::kModel2, p, truth.theta_max_ant, truth.theta_max_post, kSeed + 8);
  const Trial train = RigFrameTrial(train_paper, kSeed + 9);
  const Trial test = RigFrameTrial(test_paper, kSeed + 10);

  const ShoulderData d = ExtractShoulderData(train);
  EXPECT_EQ(d.direction, -1.0);  // inferred: the anterior deltoid drives q up
  EXPECT_NEAR(d.theta_rest, kRigRest, 4.0 * kRigAngleNoise);
  const auto fit = FitShoulderModel(ShoulderModel::kModel2, {d}, truth.theta_max_ant,
                                    truth.theta_max_post, -1.0);
  const auto names = ParameterNames(ShoulderModel::kModel2);
  for (int i = 0; i < p.size(); ++i) {
    const double tol = p(i) == 0.0 ? kNoisyZeroTol : kNoisyRecoveryRelTol * p(i);
    EXPECT_NEAR(fit.p(i), p(i), tol) << names[i];
  }
  // Held out: J_L of the simulated velocity near the noise floor J_L(measured, noiseless).
  const auto r = RunShoulderModelMethod(ShoulderModel::kModel2, {train}, {test}, nullptr);
  ASSERT_EQ(r.predictions.size(), 1u);
  const auto& qd = test.Column("qd.shoulder_elv_plane");
  std::vector<double> qd_true;
  for (double w : test_paper.omega) qd_true.push_back(-w);
  const double floor = PerformanceIndexJL(qd, qd_true);
  EXPECT_LT(PerformanceIndexJL(qd, r.predictions[0].Column("qd.shoulder_elv_plane")),
            kNoiseFloorFactor * floor);
  // Predictions are in the trial's frame: the angle starts at the measured rest.
  EXPECT_NEAR(r.predictions[0].Column("q.shoulder_elv_plane")[0],
              test.Column("q.shoulder_elv_plane")[0], kExactTol);
  EXPECT_NE(r.model_yaml.find("direction: -1"), std::string::npos) << r.model_yaml;
}

TEST(ShoulderModels, ThetaMaxFromJointRangeInTheModelsFrame) {
  constexpr double kDeg = M_PI / 180.0;
  ShoulderData d;
  d.theta_rest = 14.0 * kDeg;  // the shoulder_exo rig: rest 14°, range −90° … 130°
  d.direction = -1.0;          // its anterior deltoid drives q up
  double ant = 0.0, post = 0.0;
  ThetaMaxFromJointRange(-90.0 * kDeg, 130.0 * kDeg, d, &ant, &post);
  EXPECT_NEAR(ant, -116.0 * kDeg, kExactTol);  // 130° is −116° from rest in θ
  EXPECT_NEAR(post, 104.0 * kDeg, kExactTol);
  d.direction = 1.0;
  ThetaMaxFromJointRange(-90.0 * kDeg, 130.0 * kDeg, d, &ant, &post);
  EXPECT_NEAR(ant, -104.0 * kDeg, kExactTol);
  EXPECT_NEAR(post, 116.0 * kDeg, kExactTol);
  EXPECT_THROW(ThetaMaxFromJointRange(20.0 * kDeg, 130.0 * kDeg, d, &ant, &post),
               std::invalid_argument);
}

// [Spagnol 2013] eq. 3's θmax are its rig's reachable angles. An arm that travels beyond the
// paper's θmax_ant (≈ −56°) from rest, as fesim's shoulder_exo arm does (to ≈ −100°), turns the
// anterior deltoid's torque K σ (θmax − θ) around there: with the paper's θmax the fit cannot
// follow; with the rig's it recovers the planted person.
TEST(ShoulderModels, Model2NeedsTheRigsThetaMaxWhenTheArmTravelsBeyondThePapers) {
  constexpr double kRigThetaMaxAnt = -2.0246;  // rad: −116°, shoulder_exo's range end
  constexpr double kRigThetaMaxPost = 1.8151;  // rad: +104°
  constexpr double kPaperFitFloor = 0.01;      // J_L(ω) of the paper-θmax fit stays above 1 %
  ShoulderModel2Params truth = PlantedModel2();
  truth.k_ant = 3.0;
  truth.k_post = 2.0;
  truth.k_m = 0.5;  // weak passive spring: full anterior activation holds θ ≈ −1.7 rad
  truth.theta_max_ant = kRigThetaMaxAnt;
  truth.theta_max_post = kRigThetaMaxPost;
  const Eigen::VectorXd p = ToVector(truth);
  const ShoulderData d =
      Simulated(ShoulderModel::kModel2, p, kRigThetaMaxAnt, kRigThetaMaxPost, kSeed + 11);
  double theta_min = 0.0;
  for (double th : d.theta) theta_min = std::min(theta_min, th);
  ASSERT_LT(theta_min, ShoulderModel2Params().theta_max_ant);  // beyond the paper's θmax
  const ShoulderModel2Params paper;
  const auto wrong = FitShoulderModel(ShoulderModel::kModel2, {d}, paper.theta_max_ant,
                                      paper.theta_max_post, truth.c);
  EXPECT_GT(wrong.cost, kPaperFitFloor);
  const auto right =
      FitShoulderModel(ShoulderModel::kModel2, {d}, kRigThetaMaxAnt, kRigThetaMaxPost, truth.c);
  EXPECT_LT(right.cost, 1e-6);
  const auto names = ParameterNames(ShoulderModel::kModel2);
  for (int i = 0; i < p.size(); ++i) {
    EXPECT_NEAR(right.p(i), p(i), kRecoveryRelTol * std::max(std::abs(p(i)), 0.1)) << names[i];
  }
}

TEST(ShoulderModels, FrameFromMetadataAndTransformedBack) {
  Trial t;
  for (int i = 0; i < 20; ++i) t.time.push_back(0.01 * i);
  t.AddColumn("u.delt_ant", std::vector<double>(20, 150.0));
  t.AddColumn("u.delt_post", std::vector<double>(20, 0.0));
  std::vector<double> q(20);
  for (int i = 0; i < 20; ++i) q[i] = 1.0 + 0.5 * t.time[i];  // anterior drives q up
  t.AddColumn("q.sh", q);
  const auto inferred = ExtractShoulderData(t);
  EXPECT_EQ(inferred.direction, -1.0);
  EXPECT_NEAR(inferred.theta_rest, 1.0, kExactTol);
  EXPECT_NEAR(inferred.theta[10], -0.05, 1e-12);
  EXPECT_NEAR(inferred.omega[10], -0.5, 1e-9);
  const auto back = AngleToTrialFrame(inferred, inferred.theta);
  const auto back_w = VelocityToTrialFrame(inferred, inferred.omega);
  EXPECT_NEAR(back[10], q[10], kExactTol);
  EXPECT_NEAR(back_w[10], 0.5, 1e-9);
  EXPECT_EQ(ExtractShoulderData(t, 10, 1.0).direction, 1.0);  // the caller's s wins
  t.metadata["theta_rest"] = "0.25";
  t.metadata["theta_direction"] = "1";
  const auto given = ExtractShoulderData(t);
  EXPECT_EQ(given.direction, 1.0);
  EXPECT_NEAR(given.theta[0], 0.75, kExactTol);
  t.metadata["theta_direction"] = "2";
  try {
    ExtractShoulderData(t);
    FAIL() << "theta_direction 2 accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("theta_direction"), std::string::npos) << e.what();
  }
  t.metadata["theta_direction"] = "-1";
  t.metadata["theta_rest"] = "abc";
  EXPECT_THROW(ExtractShoulderData(t), std::runtime_error);
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
  t.metadata["theta_direction"] = "1";  // keep the trial's sign
  const auto d = ExtractShoulderData(t);
  EXPECT_NEAR(d.sigma_ant[3], 1.0, kExactTol);
  EXPECT_NEAR(d.sigma_post[3], 0.5, kExactTol);
  EXPECT_NEAR(d.omega[7], 0.5, 1e-9);  // differentiated q
  EXPECT_EQ(d.joint, "sh");
}

TEST(ShoulderModels, ExtractionPicksTheRigsDeltoidChannelsAmongOtherChannels) {
  // Raw `fesim simulate` output of the shoulder rig: every channel of the model, the deltoid's
  // named u.delt_ant / u.delt_post, the forearm's u.ext / u.flex undriven and first.
  Trial t;
  for (int i = 0; i < 20; ++i) t.time.push_back(0.01 * i);
  t.AddColumn("u.ext", std::vector<double>(20, 0.0));
  t.AddColumn("u.flex", std::vector<double>(20, 0.0));
  t.AddColumn("u.delt_ant", std::vector<double>(20, 300.0));
  t.AddColumn("u.delt_post", std::vector<double>(20, 150.0));
  t.AddColumn("q.sh", std::vector<double>(20, 0.1));
  t.metadata["theta_direction"] = "1";
  const auto d = ExtractShoulderData(t);
  EXPECT_NEAR(d.sigma_ant[3], 1.0, kExactTol);
  EXPECT_NEAR(d.sigma_post[3], 0.5, kExactTol);
}

}  // namespace
}  // namespace fesim::identification
