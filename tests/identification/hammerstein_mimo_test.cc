#include "identification/hammerstein_mimo.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "identification/metrics.h"

namespace fesim::identification {
namespace {

constexpr double kRecoveryTol = 1e-3;    // relative error, noiseless data
constexpr double kNoiseStd_rad = 0.005;  // ≈ 0.3°, tracker-like angle noise
constexpr double kNoisyTol = 0.05;       // relative error of D, Ψ, Θ under that noise
constexpr double kSamplePeriod = 0.025;  // s (40 Hz)
constexpr double kStep_s = 5.0;          // [Hand Hammerstein] §5.1
constexpr double kStepDC_tol = 1e-12;
// Transient left 5 s after a step (Ω = 4 rad/s, μ ≤ 0.3 s): ≈ (1 + Ωt) e^{−Ωt}·|Δz| ~ 1e-6 rad.
constexpr double kSettledTol_rad = 1e-5;
constexpr unsigned kSeed = 4242;

HammersteinMimoParams Planted() {
  HammersteinMimoParams p;
  CutoffParams a, b;
  a.u_db_us = Eigen::Vector2d(60.0, 200.0);
  a.u_sat_us = 180.0;
  b.u_db_us = Eigen::Vector2d(220.0, 80.0);
  b.u_sat_us = 400.0;
  p.psi = {a, b};
  p.d_rad.resize(3, 2);
  p.d_rad << 0.8, -0.5, 0.3, 0.6, -0.4, 0.9;
  p.omega_rad_s = 4.0;
  p.mu_s = Eigen::Vector3d(0.15, 0.3, 0.2);
  p.rest_rad = Eigen::Vector3d(0.1, 0.5, 0.3);
  return p;
}

// Step grid of [Hand Hammerstein] §5.1 / Fig. 6: 50 µs spacing over {u1 + u2 ≤ 300}, serpentine
// order starting at rest; `transpose` swaps the roles of the inputs (the paper's second traversal).
Eigen::MatrixXd StepGrid(bool transpose) {
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i <= 6; ++i) {
    for (int jj = 0; jj <= 6 - i; ++jj) {
      const int j = (i % 2 == 0) ? jj : 6 - i - jj;
      pts.emplace_back(transpose ? 50.0 * j : 50.0 * i, transpose ? 50.0 * i : 50.0 * j);
    }
  }
  const int per = static_cast<int>(std::lround(kStep_s / kSamplePeriod));
  Eigen::MatrixXd u(static_cast<Eigen::Index>(pts.size()) * per, 2);
  for (std::size_t s = 0; s < pts.size(); ++s) {
    u.middleRows(static_cast<Eigen::Index>(s) * per, per).rowwise() = pts[s].transpose();
  }
  return u;
}

std::vector<MimoTrialData> Trials(const HammersteinMimoParams& p, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> e(0.0, noise > 0 ? noise : 1.0);
  std::vector<MimoTrialData> out;
  for (bool tr : {false, true}) {
    MimoTrialData d;
    d.sample_period_s = kSamplePeriod;
    d.u_us = StepGrid(tr);
    d.y_rad = SimulateHammersteinMimo(p, d.u_us, kSamplePeriod);
    if (noise > 0) {
      for (Eigen::Index k = 0; k < d.y_rad.size(); ++k) d.y_rad.data()[k] += e(rng);
    }
    out.push_back(d);
  }
  return out;
}

double Rel(double a, double b) { return std::abs(a - b) / std::abs(b); }

void ExpectClose(const HammersteinMimoParams& got, const HammersteinMimoParams& want, double tol) {
  ASSERT_EQ(got.psi.size(), want.psi.size());
  for (std::size_t j = 0; j < want.psi.size(); ++j) {
    for (int k = 0; k < 2; ++k) {
      EXPECT_LT(Rel(got.psi[j].u_db_us(k), want.psi[j].u_db_us(k)), tol) << "u_db " << j << k;
    }
    EXPECT_LT(Rel(got.psi[j].u_sat_us, want.psi[j].u_sat_us), tol) << "u_sat " << j;
  }
  EXPECT_LT((got.d_rad - want.d_rad).norm() / want.d_rad.norm(), tol);
  EXPECT_LT(Rel(got.omega_rad_s, want.omega_rad_s), tol);
  for (int i = 0; i < 3; ++i) EXPECT_LT(Rel(got.mu_s(i), want.mu_s(i)), tol) << "mu " << i;
}

TEST(HammersteinMimo, JointDynamicsHaveUnitDcGainAndCriticallyDampedStep) {
  const double T = 0.01, omega = 3.0;
  const JointFilter f = DiscretiseJointDynamics(omega, 0.0, T);
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  for (int k = 1; k <= 200; ++k) {
    x = f.Ad * x + f.Bd * 1.0;
    const double t = k * T;
    EXPECT_NEAR(f.C * x, 1.0 - (1.0 + omega * t) * std::exp(-omega * t), 1e-12);
  }
  const JointFilter g = DiscretiseJointDynamics(omega, 0.4, T);
  const Eigen::Vector3d xs = (Eigen::Matrix3d::Identity() - g.Ad).lu().solve(g.Bd);
  EXPECT_NEAR(g.C * xs, 1.0, kStepDC_tol);  // H̃(0) = 1 (eq. 34)
}

// Exact sensitivities of the dynamic step against finite differences of the model itself.
constexpr double kJacobianTol = 1e-6;  // relative, vs second-order finite differences
constexpr double kFdRelStep = 1e-5;    // truncation ~1e-10, rounding ~1e-11 relative
// At μ = 0 the one-sided quotient needs a larger absolute step: the model's exp(M T) has entries
// T/h there, and its rounding (≈ ε T/h absolute) over h gives 3e-2 at h = 1e-8, 4e-7 at 1e-4.
constexpr double kFdStepAtMuZero_s = 3e-5;

/// y = C x of DiscretiseJointDynamics' filter driven by z from its steady state (the model).
Eigen::VectorXd JointResponse(double omega, double mu, const Eigen::VectorXd& z, double T) {
  const JointFilter f = DiscretiseJointDynamics(omega, mu, T);
  Eigen::Vector3d x = Eigen::Vector3d::Constant(z(0));
  Eigen::VectorXd y(z.size());
  for (Eigen::Index k = 0; k < z.size(); ++k) {
    y(k) = f.C * x;
    x = f.Ad * x + f.Bd * z(k);
  }
  return y;
}

/// Second-order difference quotient of f at x: central, or one-sided (−3f(x) + 4f(x + h) −
/// f(x + 2h))/(2h) where x − h would leave the domain (μ = 0).
template <typename F>
Eigen::VectorXd Derivative(const F& f, double x, double h, bool one_sided) {
  if (one_sided) return (-3.0 * f(x) + 4.0 * f(x + h) - f(x + 2.0 * h)) / (2.0 * h);
  return (f(x + h) - f(x - h)) / (2.0 * h);
}

double MaxRelError(const Eigen::VectorXd& got, const Eigen::VectorXd& want) {
  return (got - want).cwiseAbs().maxCoeff() / want.cwiseAbs().maxCoeff();
}

TEST(HammersteinMimo, JointSensitivitiesEqualDifferencesOfTheModel) {
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  // A random staircase z (steps of 1–60 samples), 2000 samples at T.
  const double T = kSamplePeriod;
  Eigen::VectorXd z(2000);
  for (Eigen::Index k = 0; k < z.size();) {
    const auto len = static_cast<Eigen::Index>(1 + 60 * unit(rng));
    const double level = 2.0 * unit(rng) - 1.0;
    for (Eigen::Index j = 0; j < len && k < z.size(); ++j) z(k++) = level;
  }
  // Random (Ω, μ) in the bounds' interior, the repeated pole Ω = 1/μ, and μ = 0.
  std::vector<std::pair<double, double>> cases = {{4.0, 0.25}, {2.0, 0.0}, {0.05, 3.0}, {9.0, 0.0}};
  for (int c = 0; c < 6; ++c) cases.emplace_back(0.3 + 9.7 * unit(rng), 0.01 + 2.0 * unit(rng));
  for (const auto& [omega, mu] : cases) {
    SCOPED_TRACE("Omega = " + std::to_string(omega) + ", mu = " + std::to_string(mu));
    const Eigen::MatrixXd s = SimulateJointSensitivities(omega, mu, z, T);
    EXPECT_LT((s.col(0) - JointResponse(omega, mu, z, T)).cwiseAbs().maxCoeff(), 1e-12);
    const Eigen::VectorXd d_omega = Derivative([&](double w) { return JointResponse(w, mu, z, T); },
                                               omega, kFdRelStep * omega, false);
    const double h_mu = mu == 0.0 ? kFdStepAtMuZero_s : kFdRelStep * mu;
    const Eigen::VectorXd d_mu =
        Derivative([&](double m) { return JointResponse(omega, m, z, T); }, mu, h_mu, mu == 0.0);
    EXPECT_LT(MaxRelError(s.col(1), d_omega), kJacobianTol);
    EXPECT_LT(MaxRelError(s.col(2), d_mu), kJacobianTol);
  }
}

TEST(HammersteinMimo, DynamicNormalEquationsEqualDifferencesOfTheSimulation) {
  auto trials = Trials(Planted(), kNoiseStd_rad, kSeed + 3);
  // A third, shorter trial at another sample period: an unpaired chain and a second filter set.
  MimoTrialData extra;
  extra.sample_period_s = 0.02;
  extra.u_us = trials[0].u_us.topRows(1001);
  extra.y_rad = trials[0].y_rad.topRows(1001);
  trials.push_back(extra);
  std::mt19937 rng(kSeed + 4);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int c = 0; c < 4; ++c) {
    HammersteinMimoParams p = Planted();
    p.omega_rad_s = 0.5 + 9.0 * unit(rng);
    for (int i = 0; i < 3; ++i) p.mu_s(i) = 0.01 + 1.5 * unit(rng);
    if (c == 3) p.mu_s(1) = 0.0;  // lower bound: right derivative
    SCOPED_TRACE("case " + std::to_string(c));
    // r = ŷ − y over all trials, joint-major, from SimulateHammersteinMimo (the model).
    const auto residual = [&](const HammersteinMimoParams& pp) {
      std::vector<Eigen::MatrixXd> e;
      Eigen::Index n = 0;
      for (const auto& t : trials) {
        e.push_back(SimulateHammersteinMimo(pp, t.u_us, t.sample_period_s) - t.y_rad);
        n += e.back().size();
      }
      Eigen::VectorXd r(n);
      Eigen::Index o = 0;
      for (int i = 0; i < 3; ++i) {
        for (const auto& m : e) {
          r.segment(o, m.rows()) = m.col(i);
          o += m.rows();
        }
      }
      return r;
    };
    const DynamicNormalEquations ne = HammersteinDynamicNormalEquations(trials, p);
    const Eigen::VectorXd r = residual(p);
    ASSERT_EQ(ne.residual.size(), r.size());
    EXPECT_LT((ne.residual - r).cwiseAbs().maxCoeff(), 1e-12);
    Eigen::MatrixXd J(r.size(), 4);
    J.col(0) = Derivative(
        [&](double w) {
          HammersteinMimoParams pp = p;
          pp.omega_rad_s = w;
          return residual(pp);
        },
        p.omega_rad_s, kFdRelStep * p.omega_rad_s, false);
    for (int i = 0; i < 3; ++i) {
      J.col(1 + i) = Derivative(
          [&](double m) {
            HammersteinMimoParams pp = p;
            pp.mu_s(i) = m;
            return residual(pp);
          },
          p.mu_s(i), p.mu_s(i) == 0.0 ? kFdStepAtMuZero_s : kFdRelStep * p.mu_s(i),
          p.mu_s(i) == 0.0);
    }
    const Eigen::MatrixXd jtj = J.transpose() * J;
    const Eigen::VectorXd jtr = J.transpose() * r;
    for (int a = 0; a < 4; ++a) {
      const double scale_r = std::sqrt(jtj(a, a)) * r.norm();
      EXPECT_LT(std::abs(ne.jtr(a) - jtr(a)), kJacobianTol * scale_r) << "J'r " << a;
      for (int b = 0; b < 4; ++b) {
        const double scale = std::sqrt(jtj(a, a) * jtj(b, b));
        EXPECT_LT(std::abs(ne.jtj(a, b) - jtj(a, b)), kJacobianTol * scale) << "J'J " << a << b;
      }
    }
    // μ columns vanish outside their joint's block: JᵀJ(μ_i, μ_k) = 0 for i ≠ k.
    EXPECT_EQ(ne.jtj(1, 2), 0.0);
    EXPECT_EQ(ne.jtj(2, 3), 0.0);
  }
}

TEST(HammersteinMimo, ExactAndForwardDifferenceDynamicStepsReachTheSameOptimum) {
  const HammersteinMimoParams truth = Planted();
  const auto trials = Trials(truth, kNoiseStd_rad, kSeed + 5);
  HammersteinMimoOptions o;
  const SteadyStateSet set = ExtractSteadyState(trials, o.min_step_s, o.ss_window_s);
  const HammersteinMimoFit stat = FitHammersteinStatic(set, truth.rest_rad, o);
  HammersteinMimoFit exact = stat, fd = stat;
  FitHammersteinDynamic(trials, o, &exact);
  o.dynamic_jacobian = DynamicJacobian::kForwardDifference;
  FitHammersteinDynamic(trials, o, &fd);
  for (const auto* f : {&exact, &fd}) {
    for (const auto& c : f->dynamic_step_convergence) EXPECT_TRUE(c.converged) << c.stop_reason;
  }
  EXPECT_LT(Rel(exact.dynamic_cost, fd.dynamic_cost), 1e-7);
  EXPECT_LT(Rel(exact.params.omega_rad_s, fd.params.omega_rad_s), 1e-4);
  for (int i = 0; i < 3; ++i) EXPECT_LT(Rel(exact.params.mu_s(i), fd.params.mu_s(i)), 1e-4);
  EXPECT_LT(Rel(exact.params.omega_rad_s, truth.omega_rad_s), kNoisyTol);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(Rel(exact.theta_ci95(1 + i), fd.theta_ci95(1 + i)), 1e-3) << "ci95 mu " << i;
  }
  // The same with missing samples (issue 28: weighted residuals in both Jacobian paths).
  auto gappy = trials;
  for (Eigen::Index k = 300; k < 340; ++k) gappy[1].y_rad.row(k).setConstant(NAN);
  o = HammersteinMimoOptions{};
  HammersteinMimoFit exact_gaps = FitHammersteinStatic(
      ExtractSteadyState(gappy, o.min_step_s, o.ss_window_s), truth.rest_rad, o);
  HammersteinMimoFit fd_gaps = exact_gaps;
  FitHammersteinDynamic(gappy, o, &exact_gaps);
  o.dynamic_jacobian = DynamicJacobian::kForwardDifference;
  FitHammersteinDynamic(gappy, o, &fd_gaps);
  ASSERT_TRUE(std::isfinite(exact_gaps.dynamic_cost));
  EXPECT_LT(Rel(exact_gaps.dynamic_cost, fd_gaps.dynamic_cost), 1e-7);
  EXPECT_LT(Rel(exact_gaps.params.omega_rad_s, fd_gaps.params.omega_rad_s), 1e-4);
  EXPECT_LT(Rel(exact_gaps.params.omega_rad_s, exact.params.omega_rad_s), 1e-2);
}

TEST(HammersteinMimo, SteadyStateSetIsTheEndOfEachStep) {
  const auto trials = Trials(Planted(), 0.0, kSeed);
  const SteadyStateSet set = ExtractSteadyState({trials[0]}, 1.0, 0.2);
  ASSERT_EQ(set.u_us.rows(), 28);  // grid points with u1 + u2 ≤ 300 at 50 µs
  for (Eigen::Index s = 0; s < set.u_us.rows(); ++s) {
    const Eigen::Vector3d want =
        Planted().rest_rad - StaticDeflection(Planted(), set.u_us.row(s).transpose());
    EXPECT_LT((set.y_rad.row(s).transpose() - want).norm(), kSettledTol_rad);
  }
}

TEST(HammersteinMimo, TwoStepFitRecoversPlantedParametersNoiseless) {
  const HammersteinMimoParams truth = Planted();
  const auto fit = FitHammersteinMimo(Trials(truth, 0.0, kSeed), HammersteinMimoOptions{});
  ExpectClose(fit.params, truth, kRecoveryTol);
  EXPECT_LT((fit.params.rest_rad - truth.rest_rad).norm(), 1e-9);
  EXPECT_EQ(fit.static_step_wall_s.size(), 20u);
}

TEST(HammersteinMimo, StaysCloseUnderAngleNoise) {
  const HammersteinMimoParams truth = Planted();
  const auto train = Trials(truth, kNoiseStd_rad, kSeed + 1);
  const auto fit = FitHammersteinMimo(train, HammersteinMimoOptions{});
  ExpectClose(fit.params, truth, kNoisyTol);
  // Simulation Best Fit on a fresh noisy trial stays near the noise floor.
  const auto test = Trials(truth, kNoiseStd_rad, kSeed + 2);
  const Eigen::MatrixXd yhat = SimulateHammersteinMimo(fit.params, test[0].u_us, kSamplePeriod);
  for (int i = 0; i < 3; ++i) {
    const std::vector<double> y(test[0].y_rad.col(i).data(),
                                test[0].y_rad.col(i).data() + test[0].y_rad.rows());
    const std::vector<double> yh(yhat.col(i).data(), yhat.col(i).data() + yhat.rows());
    EXPECT_GT(BestFitPercent(y, yh), 90.0) << "joint " << i;
  }
}

TEST(HammersteinMimo, MethodRejectsMissingColumnsNaNInputsAndUnmeasuredOutputs) {
  Trial t;
  for (int k = 0; k < 50; ++k) t.time.push_back(0.025 * k);
  t.AddColumn("u.ch1", std::vector<double>(50, 0.0));
  const auto method = HammersteinMimoMethod();
  EXPECT_THROW(method.run({t}, {}, nullptr), std::runtime_error);  // no q.*
  t.AddColumn("q.wrist", std::vector<double>(50, NAN));
  EXPECT_THROW(method.run({t}, {}, nullptr), std::runtime_error);  // no measured sample
  for (double& v : t.MutableColumn("q.wrist")) v = 0.1;
  t.MutableColumn("u.ch1")[7] = NAN;
  EXPECT_THROW(method.run({t}, {}, nullptr), std::runtime_error);  // NaN input
  t.MutableColumn("u.ch1")[7] = 0.0;
  EXPECT_THROW(method.run({t}, {}, nullptr), std::runtime_error);  // no steps: too few points
}

std::vector<Trial> ToTrials(const std::vector<MimoTrialData>& data) {
  std::vector<Trial> trials;
  for (const auto& d : data) {
    Trial t;
    for (Eigen::Index k = 0; k < d.u_us.rows(); ++k) t.time.push_back(kSamplePeriod * k);
    for (int c = 0; c < 2; ++c) {
      t.AddColumn("u.ch" + std::to_string(c + 1),
                  std::vector<double>(d.u_us.col(c).data(), d.u_us.col(c).data() + d.u_us.rows()));
    }
    const char* joints[] = {"q.wrist", "q.mcp", "q.pip"};
    for (int i = 0; i < 3; ++i) {
      t.AddColumn(joints[i], std::vector<double>(d.y_rad.col(i).data(),
                                                 d.y_rad.col(i).data() + d.y_rad.rows()));
    }
    trials.push_back(t);
  }
  return trials;
}

TEST(HammersteinMimo, MethodEntryFitsTrialsAndReportsPerJointMetrics) {
  const std::vector<Trial> trials = ToTrials(Trials(Planted(), 0.0, kSeed));
  const MethodResult r = HammersteinMimoMethod().run(trials, {trials[1]}, nullptr);
  ASSERT_EQ(r.predictions.size(), 1u);
  const auto& yhat = r.predictions[0].Column("q.mcp");
  const auto& y = trials[1].Column("q.mcp");
  EXPECT_GT(BestFitPercent(y, yhat), 99.9);
  EXPECT_NE(r.model_yaml.find("Omega: {value: 4"), std::string::npos) << r.model_yaml;
  EXPECT_NE(r.metrics.Dump().find("static_local_step_wall_s"), std::string::npos);
  // Noiseless planted data: the kept static and dynamic runs converged, and say so.
  const std::string m = r.metrics.Dump(0);
  for (const char* step : {"static_step_convergence", "dynamic_step_convergence"}) {
    const auto at = m.find(std::string("\"") + step + "\":{\"best_run\":");
    ASSERT_NE(at, std::string::npos) << step;
    EXPECT_NE(m.find("\"converged\":true", at), std::string::npos) << step;
  }
  EXPECT_NE(r.model_yaml.find("convergence:\n  static_step:\n"), std::string::npos);
  EXPECT_TRUE(r.warnings.empty());
}

// Issue 28: tracker dropouts (the hand lost: every joint NaN on 5 % of the rows, in bursts of 8)
// are left out of the dynamic step's loss and of the steady-state means; the metrics count them
// and the fit is as good as on the complete record.
TEST(HammersteinMimo, MissingOutputSamplesAreLeftOutOfTheFit) {
  const std::vector<Trial> complete = ToTrials(Trials(Planted(), kNoiseStd_rad, kSeed + 3));
  std::vector<Trial> gaps = complete;
  std::mt19937 rng(kSeed + 4);
  std::uniform_int_distribution<std::size_t> start(5, gaps[0].size() - 10);
  std::set<std::size_t> rows;
  while (rows.size() < gaps[0].size() / 20) {
    const std::size_t k0 = start(rng);
    for (std::size_t k = k0; k < k0 + 8; ++k) rows.insert(k);
  }
  for (const char* q : {"q.wrist", "q.mcp", "q.pip"}) {
    for (std::size_t k : rows) gaps[0].MutableColumn(q)[k] = NAN;
  }
  const MethodResult with_gaps = HammersteinMimoMethod().run(gaps, {complete[1]}, nullptr);
  const MethodResult reference = HammersteinMimoMethod().run(complete, {complete[1]}, nullptr);
  const std::string m = with_gaps.metrics.Dump(0);
  EXPECT_NE(m.find("\"train_missing_samples\":" + std::to_string(3 * rows.size())),
            std::string::npos)
      << m;
  for (const char* q : {"q.wrist", "q.mcp", "q.pip"}) {
    const auto& y = complete[1].Column(q);
    const double fit_gaps = BestFitPercent(y, with_gaps.predictions[0].Column(q));
    const double fit_complete = BestFitPercent(y, reference.predictions[0].Column(q));
    EXPECT_GT(fit_gaps, fit_complete - 0.5) << q;
    EXPECT_GT(fit_gaps, 90.0) << q;
  }
}

}  // namespace
}  // namespace fesim::identification
