#include "identification/recruitment_bijection.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace fesim::identification {
namespace {

constexpr double kRoundTripTol = 1e-9;  // relative
constexpr double kLevelTol = 1e-12;     // h̃ at the cut-off points
constexpr int kSamples = 2000;
constexpr unsigned kSeed = 7;

TEST(RecruitmentBijection, AlphaIsLn20OverLn20Over19) {
  EXPECT_NEAR(SaturationRatioBound(), 58.404, 5e-4);
  EXPECT_NEAR(SaturationRatio(1e-12), SaturationRatioBound(), 1e-6);
  EXPECT_LT(SaturationRatio(1e300), 1.01);  // f(∞) = 1, approached logarithmically
  EXPECT_GT(SaturationRatio(1e300), 1.0);
  EXPECT_GT(SaturationRatio(1.0), SaturationRatio(2.0));  // decreasing (eq. 41)
}

TEST(RecruitmentBijection, MOfMInverseIsIdentityOnRandomPointsOfP) {
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> db(1.0, 600.0), frac(1e-6, 1.0 - 1e-6);
  std::uniform_int_distribution<int> inputs(1, 4);
  const double alpha = SaturationRatioBound();
  for (int s = 0; s < kSamples; ++s) {
    CutoffParams psi;
    psi.u_db_us = Eigen::VectorXd(inputs(rng));
    for (int k = 0; k < psi.u_db_us.size(); ++k) psi.u_db_us(k) = db(rng);
    // ratio uniformly over the representable part of P (eq. 40), boundaries excluded
    const double lo = MinimumSaturationRatio();
    psi.u_sat_us = psi.u_db_us(0) * (lo + frac(rng) * (alpha - lo));
    ASSERT_TRUE(InRecruitmentSet(psi));
    const SigmoidParams phi = SigmoidFromCutoffs(psi);
    const CutoffParams back = CutoffsFromSigmoid(phi);
    for (int k = 0; k < psi.u_db_us.size(); ++k) {
      EXPECT_NEAR(back.u_db_us(k) / psi.u_db_us(k), 1.0, kRoundTripTol);
    }
    EXPECT_NEAR(back.u_sat_us / psi.u_sat_us, 1.0, kRoundTripTol);
  }
}

TEST(RecruitmentBijection, MInverseOfMIsIdentityAndCutoffsMeanFivePercentAndNinetyFive) {
  std::mt19937 rng(kSeed + 1);
  std::uniform_real_distribution<double> lg(-4.0, 4.0), ld(-4.0, -1.0);
  for (int s = 0; s < kSamples; ++s) {
    SigmoidParams phi;
    phi.gamma = std::pow(10.0, lg(rng));
    phi.delta = Eigen::Vector2d(std::pow(10.0, ld(rng)), std::pow(10.0, ld(rng)));
    const CutoffParams psi = CutoffsFromSigmoid(phi);
    ASSERT_TRUE(InRecruitmentSet(psi));
    const SigmoidParams back = SigmoidFromCutoffs(psi);
    EXPECT_NEAR(back.gamma / phi.gamma, 1.0, 1e-6);  // f is flat for large γ
    EXPECT_NEAR(back.delta(0) / phi.delta(0), 1.0, 1e-6);
    // Fig. 3 / Remark 11: dead band at 5 %, saturation at 95 % of the input-1 response.
    EXPECT_NEAR(SigmoidRecruitment(phi, Eigen::Vector2d(psi.u_db_us(0), 0.0)), 0.05, kLevelTol);
    EXPECT_NEAR(SigmoidRecruitment(phi, Eigen::Vector2d(0.0, psi.u_db_us(1))), 0.05, kLevelTol);
    EXPECT_NEAR(SigmoidRecruitment(phi, Eigen::Vector2d(psi.u_sat_us, 0.0)), 0.95, kLevelTol);
  }
}

TEST(RecruitmentBijection, PointsOutsidePAreRejected) {
  const double alpha = SaturationRatioBound();
  const auto make = [](double db1, double db2, double sat) {
    CutoffParams p;
    p.u_db_us = Eigen::Vector2d(db1, db2);
    p.u_sat_us = sat;
    return p;
  };
  const CutoffParams outside[] = {
      make(100, 50, 100),                // u_sat = u_db (needs u_db < u_sat)
      make(100, 50, 90),                 // u_sat < u_db
      make(16, 50, 16 * alpha),          // u_sat = α u_db (γ = 0 is not in Q)
      make(10, 50, 10 * alpha * 1.001),  // beyond α
      make(-5, 50, 100),                 // negative dead band
      make(100, 0, 200),                 // zero dead band on input 2
      make(100, 50, NAN),
  };
  for (const auto& p : outside) {
    EXPECT_FALSE(InRecruitmentSet(p));
    EXPECT_THROW(SigmoidFromCutoffs(p), std::invalid_argument);
  }
  SigmoidParams bad;
  bad.delta = Eigen::Vector2d(0.01, -0.01);
  EXPECT_THROW(CutoffsFromSigmoid(bad), std::invalid_argument);
}

}  // namespace
}  // namespace fesim::identification
