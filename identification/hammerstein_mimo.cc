#include "identification/hammerstein_mimo.h"

#include <time.h>  // NOLINT(modernize-deprecated-headers): POSIX clock_gettime(), not in <ctime>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/MatrixFunctions>

#include "identification/levenberg_marquardt.h"
#include "identification/method_support.h"
#include "identification/metrics.h"
#include "identification/nnls.h"

namespace fesim::identification {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// CPU time of the calling thread, s.
double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

constexpr double kMuNegligible_s = 1e-12;  // below this the first-order lag is dropped
// Below this μ the sensitivity ∂y/∂μ is its μ → 0 limit −Ω(x1 − x2) (error ≈ 5Ωμ relative);
// above it −(y − u)/μ, whose cancellation costs ≈ 3e-18/μ² relative (measured at Ω = 2 rad/s,
// T = 25 ms): the two meet at ≲ 3e-5 here and are ≤ 1e-6 for μ ≥ 2e-6 s or μ = 0.
constexpr double kMuSensitivityFloor_s = 5e-7;
constexpr double kSatMargin = 1e-2;          // u_sat ≥ (1 + margin) u_db_1 keeps Ψ inside P
constexpr double kRidge = 1e-12;             // relative ridge of the bounded d sub-problem
constexpr double kRelativeTolerance = 1e-8;  // LM stops when the cost falls by less than this

/// min ‖E x − f‖ subject to |x_k| ≤ bound (a tiny ridge keeps E full rank).
Eigen::VectorXd BoundedLs(const Eigen::MatrixXd& E, const Eigen::VectorXd& f, double bound) {
  const Eigen::Index p = E.cols();
  Eigen::MatrixXd Er(E.rows() + p, p);
  const double ridge = std::sqrt(kRidge * std::max(E.squaredNorm(), 1e-300));
  Er.topRows(E.rows()) = E;
  Er.bottomRows(p) = ridge * Eigen::MatrixXd::Identity(p, p);
  Eigen::VectorXd fr = Eigen::VectorXd::Zero(E.rows() + p);
  fr.head(E.rows()) = f;
  Eigen::MatrixXd G(2 * p, p);
  G.topRows(p) = Eigen::MatrixXd::Identity(p, p);
  G.bottomRows(p) = -Eigen::MatrixXd::Identity(p, p);
  const Eigen::VectorXd h = Eigen::VectorXd::Constant(2 * p, -bound);
  return LeastSquaresInequality(Er, fr, G, h).x;
}

/// H (N×l) of activations h̃(u(k), φ_j) (eq. 22) for every row u(k) of `u`, vectorised.
Eigen::MatrixXd ActivationMatrix(const std::vector<SigmoidParams>& phi, const Eigen::MatrixXd& u) {
  const auto l = static_cast<Eigen::Index>(phi.size());
  Eigen::MatrixXd delta(u.cols(), l);
  for (Eigen::Index j = 0; j < l; ++j) {
    if (phi[j].delta.size() != u.cols()) {
      throw std::invalid_argument("activations: " + std::to_string(u.cols()) + " inputs for " +
                                  std::to_string(phi[j].delta.size()) + " gains");
    }
    delta.col(j) = phi[j].delta;
  }
  Eigen::MatrixXd H = u * delta;  // Σ_k δ_{j,k} u_k
  for (Eigen::Index j = 0; j < l; ++j) {
    auto x = H.col(j).array().min(700.0);  // e^x overflows beyond; the limit of eq. (22) is 1
    const Eigen::ArrayXd e = x.exp();
    H.col(j) = ((e - 1.0) / (e + phi[j].gamma)).matrix();
  }
  return H;
}

/// ẑ = D h(u, Φ) (eq. 43), N×q: ActivationMatrix · Dᵀ evaluated once per run of identical
/// consecutive input rows (a step-grid protocol holds each input for seconds) and copied to the
/// run's rows.
Eigen::MatrixXd StaticOutput(const std::vector<SigmoidParams>& phi, const Eigen::MatrixXd& d,
                             const Eigen::MatrixXd& u) {
  const Eigen::Index N = u.rows();
  std::vector<Eigen::Index> first;  // the first row of each run
  for (Eigen::Index k = 0; k < N; ++k) {
    if (k == 0 || u.row(k) != u.row(k - 1)) first.push_back(k);
  }
  Eigen::MatrixXd u_runs(static_cast<Eigen::Index>(first.size()), u.cols());
  for (std::size_t r = 0; r < first.size(); ++r) u_runs.row(r) = u.row(first[r]);
  const Eigen::MatrixXd z_runs = ActivationMatrix(phi, u_runs) * d.transpose();
  Eigen::MatrixXd z(N, d.rows());
  for (std::size_t r = 0; r < first.size(); ++r) {
    const Eigen::Index end = r + 1 < first.size() ? first[r + 1] : N;
    z.middleRows(first[r], end - first[r]).rowwise() = z_runs.row(r);
  }
  return z;
}

void ProjectCutoffs(int n, Eigen::VectorXd* x) {
  const Eigen::Index l = x->size() / (n + 1);
  for (Eigen::Index j = 0; j < l; ++j) {
    double& sat = (*x)(j * (n + 1) + n);
    const double db1 = (*x)(j * (n + 1));
    sat = std::max(sat, db1 * (1.0 + kSatMargin));
    sat = std::min(sat, db1 * SaturationRatioBound() * (1.0 - kSatMargin));
  }
}

struct StaticProblem {
  const Eigen::MatrixXd* u;
  Eigen::MatrixXd ytilde;  // S×q
  int n;
  double d_bound;

  /// D minimising ‖ỹ − H Dᵀ‖² with |d| ≤ d_bound, row by row. The problem is convex, so where
  /// the (ridge-regularised) unconstrained minimiser is inside the bounds it is the answer: it
  /// comes from the l×l normal equations shared by all joints, and only joints whose unconstrained
  /// d leaves the bounds go through the active-set solver (BoundedLs, same objective).
  Eigen::MatrixXd SolveD(const Eigen::MatrixXd& H) const {
    const Eigen::Index l = H.cols();
    Eigen::MatrixXd A = H.transpose() * H;
    A.diagonal().array() += kRidge * std::max(H.squaredNorm(), 1e-300);
    const Eigen::LLT<Eigen::MatrixXd> llt(A);
    Eigen::MatrixXd D(ytilde.cols(), l);
    if (llt.info() == Eigen::Success) D = llt.solve(H.transpose() * ytilde).transpose();
    for (Eigen::Index i = 0; i < ytilde.cols(); ++i) {
      if (llt.info() != Eigen::Success || !D.row(i).allFinite() ||
          D.row(i).cwiseAbs().maxCoeff() > d_bound) {
        D.row(i) = BoundedLs(H, ytilde.col(i), d_bound).transpose();
      }
    }
    return D;
  }
  Eigen::VectorXd Residual(const Eigen::VectorXd& x) const {
    const auto phi = SigmoidsFromCutoffs(UnpackCutoffs(x, n));
    const Eigen::MatrixXd H = ActivationMatrix(phi, *u);
    const Eigen::MatrixXd D = SolveD(H);
    const Eigen::MatrixXd R = ytilde - H * D.transpose();
    return Eigen::Map<const Eigen::VectorXd>(R.data(), R.size());
  }
};

/// Two lanes of one SIMD register (GCC/Clang vector extension; plain SSE2 at -O2).
using Lanes2 = double __attribute__((vector_size(16)));

/// The coefficients of two ZOH joint filters (eq. 18), one per lane. The cascade makes Ad lower
/// triangular, so each state update is one multiply-add deep on its own previous value.
struct FilterLanes {
  Lanes2 a11, a21, a22, a31, a32, a33, b1, b2, b3, c2, c3;
};

FilterLanes PairFilters(const JointFilter& f0, const JointFilter& f1) {
  const auto lanes = [](double x0, double x1) { return Lanes2{x0, x1}; };
  return {lanes(f0.Ad(0, 0), f1.Ad(0, 0)), lanes(f0.Ad(1, 0), f1.Ad(1, 0)),
          lanes(f0.Ad(1, 1), f1.Ad(1, 1)), lanes(f0.Ad(2, 0), f1.Ad(2, 0)),
          lanes(f0.Ad(2, 1), f1.Ad(2, 1)), lanes(f0.Ad(2, 2), f1.Ad(2, 2)),
          lanes(f0.Bd(0), f1.Bd(0)),       lanes(f0.Bd(1), f1.Bd(1)),
          lanes(f0.Bd(2), f1.Bd(2)),       lanes(f0.C(1), f1.C(1)),
          lanes(f0.C(2), f1.C(2))};
}

/// Two independent joint responses side by side: out_l[k] = ỹ_l(k) − C_l x_l(k), x⁺ = Ad_l x +
/// Bd_l z_l, from the steady state x_l(0) = z_l(0) (lane l = 0, 1). The lanes may share z and ỹ
/// (the two finite-difference perturbations of one joint) or not (two joints); out0 == out1 is
/// allowed when both lanes are the same filter. Each lane does the scalar recursion's operations
/// in the same order, so the results equal a one-joint-at-a-time loop's bit for bit; the pair
/// halves the instructions of this throughput-bound loop (≈ 43 % of the dynamic step before).
///
/// kWeighted: each residual is multiplied by the sample's weight w_l[k], 1 for a measured sample
/// and 0 for a missing one (its ỹ stored as 0), so a missing sample is not in the loss. Records
/// without missing samples run the unweighted loop (the same bits as before weights existed).
template <bool kWeighted>
void SimulatePair(const FilterLanes& c, const double* z0, const double* z1, const double* y0,
                  const double* y1, const double* w0, const double* w1, Eigen::Index N,
                  double* out0, double* out1) {
  if (N <= 0) return;
  Lanes2 x1 = {z0[0], z1[0]}, x2 = x1, x3 = x1;
  for (Eigen::Index k = 0; k < N; ++k) {
    const Lanes2 z = {z0[k], z1[k]};
    const Lanes2 y = {y0[k], y1[k]};
    Lanes2 o = y - (c.c2 * x2 + c.c3 * x3);
    if constexpr (kWeighted) o *= Lanes2{w0[k], w1[k]};
    out0[k] = o[0];
    out1[k] = o[1];
    const Lanes2 n1 = c.a11 * x1 + c.b1 * z;
    const Lanes2 n2 = c.a22 * x2 + (c.a21 * x1 + c.b2 * z);
    const Lanes2 n3 = c.a33 * x3 + (c.a31 * x1 + c.a32 * x2 + c.b3 * z);
    x1 = n1;
    x2 = n2;
    x3 = n3;
  }
}

/// Sums of the forward-difference normal equations of one joint over one trial.
struct DifferenceSums {
  double dd0 = 0, dd1 = 0;  ///< Σ d_l², lane l = 0, 1.
  double d01 = 0;           ///< Σ d_0 d_1.
  double db0 = 0, db1 = 0;  ///< Σ d_l r.
};

/// SimulatePair with both lanes on one joint's z and ỹ (two perturbed parameter sets), fused with
/// the normal-equation sums of the differences d_l(k) = out_l(k) − r(k) from the unperturbed
/// residual r: nothing is stored, and the sums fill the recursion's latency-bound loop.
template <bool kWeighted>
DifferenceSums SimulatePairDifferences(const FilterLanes& c, const double* z, const double* yt,
                                       const double* w, const double* r, Eigen::Index N) {
  DifferenceSums out;
  if (N <= 0) return out;
  Lanes2 x1 = {z[0], z[0]}, x2 = x1, x3 = x1;
  Lanes2 dd = {0.0, 0.0}, db = {0.0, 0.0};
  double d01 = 0.0;
  for (Eigen::Index k = 0; k < N; ++k) {
    const Lanes2 zk = {z[k], z[k]};
    const Lanes2 rk = {r[k], r[k]};
    Lanes2 d = (Lanes2{yt[k], yt[k]} - (c.c2 * x2 + c.c3 * x3)) - rk;
    if constexpr (kWeighted) d *= Lanes2{w[k], w[k]};  // (r is 0 at a missing sample)
    dd += d * d;
    db += d * rk;
    d01 += d[0] * d[1];
    const Lanes2 n1 = c.a11 * x1 + c.b1 * zk;
    const Lanes2 n2 = c.a22 * x2 + (c.a21 * x1 + c.b2 * zk);
    const Lanes2 n3 = c.a33 * x3 + (c.a31 * x1 + c.a32 * x2 + c.b3 * zk);
    x1 = n1;
    x2 = n2;
    x3 = n3;
  }
  out.dd0 = dd[0];
  out.dd1 = dd[1];
  out.d01 = d01;
  out.db0 = db[0];
  out.db1 = db[1];
  return out;
}

/// W lanes of one SIMD register: two in SSE2 (any x86-64), four in AVX.
template <int W>
struct LanesOf;
template <>
struct LanesOf<2> {
  typedef double type __attribute__((vector_size(16)));
};
template <>
struct LanesOf<4> {
  typedef double type __attribute__((vector_size(32)));
};

/// The 14 coefficients of JointSensitivityFilter::Phi that the deviation recursion uses, in the
/// order PropagateLanes reads them (Φ(0,0); Φ(1,0..1); Φ(2,0..2); Φ(3,0..3); Φ(4,0..2), Φ(4,4)).
constexpr int kPhiCoefficients = 14;
constexpr int kPhiRows[kPhiCoefficients] = {0, 1, 1, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4};
constexpr int kPhiCols[kPhiCoefficients] = {0, 0, 1, 0, 1, 2, 0, 1, 2, 3, 0, 1, 2, 4};
/// Sums of one chain's exact normal equations and cost, per lane in PropagateLanes: a², b², a b,
/// a o, b o, o² over the samples, with a and b the Ω and μ columns of J up to the factors
/// k_omega, k_mu and o = ỹ − y the residual.
constexpr int kSensitivitySums = 6;

/// W independent chains (joint responses), one per lane, in the deviation form of
/// JointSensitivityFilter: per sample k
///   o = (ỹ − z)(k) − e₃,  sums += (a², b², a b, a o, b o, o²),
///   e ← Φ e − (z(k+1) − z(k)) s₁,
/// from e = 0 (the steady state of z(0)). The input z enters only through ỹ − z and its
/// increments, both fixed during the dynamic step, so the recursion needs no Γ and the lanes
/// read one interleaved record per sample: `samples` holds, per sample, W values of ỹ − z, W of
/// z(k+1) − z(k) (0 at the last sample) and, with kWeighted, W weights (1 measured, 0 missing:
/// no residual and no Jacobian row; ỹ − z is stored as 0 there). `coef` holds the
/// kPhiCoefficients coefficients, W lanes each; with kStore o is written to out[l][k] (out is
/// not read otherwise); `sums` receives kSensitivitySums × W values (aa, bb, ab, ao, bo, oo;
/// lane-minor). 20 multiplications and 19 additions per sample and lane (a recursion on x itself
/// would add the Γ z terms: 26 and 23). A lane whose records are all 0 stays at 0 (padding).
template <int W, bool kWeighted, bool kStore>
[[gnu::always_inline]] inline void PropagateLanes(const double* coef, const double* samples,
                                                  Eigen::Index N, double* const* out,
                                                  double* sums) {
  using V = typename LanesOf<W>::type;
  V p11, p21, p22, p31, p32, p33, pa1, pa2, pa3, paa, pb1, pb2, pb3, pbb;
  V* const p[kPhiCoefficients] = {&p11, &p21, &p22, &p31, &p32, &p33, &pa1,
                                  &pa2, &pa3, &paa, &pb1, &pb2, &pb3, &pbb};
  for (int j = 0; j < kPhiCoefficients; ++j) std::memcpy(p[j], coef + j * W, sizeof(V));
  double* o_out[W] = {};
  if constexpr (kStore) {
    for (int l = 0; l < W; ++l) o_out[l] = out[l];
  }
  constexpr int kStride = (kWeighted ? 3 : 2) * W;
  const V zero = {};
  V e1 = zero, e2 = zero, e3 = zero, a = zero, b = zero;
  V aa = zero, bb = zero, ab = zero, ao = zero, bo = zero, oo = zero;
  for (Eigen::Index k = 0; k < N; ++k) {
    const double* rec = samples + k * kStride;
    V yz, dz;
    std::memcpy(&yz, rec, sizeof(V));
    std::memcpy(&dz, rec + W, sizeof(V));
    V o = yz - e3;
    V ak = a, bk = b;
    if constexpr (kWeighted) {
      V w;
      std::memcpy(&w, rec + 2 * W, sizeof(V));
      o *= w;
      ak *= w;
      bk *= w;
    }
    if constexpr (kStore) {
#pragma GCC unroll 4
      for (int l = 0; l < W; ++l) o_out[l][k] = o[l];
    }
    aa += ak * ak;
    bb += bk * bk;
    ab += ak * bk;
    ao += ak * o;
    bo += bk * o;
    oo += o * o;
    const V n1 = p11 * e1 - dz;
    const V n2 = p22 * e2 + (p21 * e1 - dz);
    const V n3 = p33 * e3 + (p31 * e1 + p32 * e2 - dz);
    const V na = paa * a + (pa1 * e1 + pa2 * e2 + pa3 * e3);
    const V nb = pbb * b + (pb1 * e1 + pb2 * e2 + pb3 * e3);
    e1 = n1;
    e2 = n2;
    e3 = n3;
    a = na;
    b = nb;
  }
  for (int l = 0; l < W; ++l) {
    sums[0 * W + l] = aa[l];
    sums[1 * W + l] = bb[l];
    sums[2 * W + l] = ab[l];
    sums[3 * W + l] = ao[l];
    sums[4 * W + l] = bo[l];
    sums[5 * W + l] = oo[l];
  }
}

/// PropagateLanes on four lanes, compiled for AVX (no FMA: every lane does the same IEEE
/// operations as on two SSE2 lanes, so the results do not depend on the lane count).
[[gnu::target("avx")]] void PropagateLanes4(bool weighted, bool store, const double* coef,
                                            const double* samples, Eigen::Index N,
                                            double* const* out, double* sums) {
  if (weighted) {
    store ? PropagateLanes<4, true, true>(coef, samples, N, out, sums)
          : PropagateLanes<4, true, false>(coef, samples, N, out, sums);
  } else {
    store ? PropagateLanes<4, false, true>(coef, samples, N, out, sums)
          : PropagateLanes<4, false, false>(coef, samples, N, out, sums);
  }
}

void PropagateLanes2(bool weighted, bool store, const double* coef, const double* samples,
                     Eigen::Index N, double* const* out, double* sums) {
  if (weighted) {
    store ? PropagateLanes<2, true, true>(coef, samples, N, out, sums)
          : PropagateLanes<2, true, false>(coef, samples, N, out, sums);
  } else {
    store ? PropagateLanes<2, false, true>(coef, samples, N, out, sums)
          : PropagateLanes<2, false, false>(coef, samples, N, out, sums);
  }
}

/// The dynamic step's residual r(Θ) = ỹ − C x = ŷ − y for fixed ẑ = D h(u) (eq. 43), rows grouped
/// by joint (joint i's block depends on Ω and μ_i only), with its normal equations either exact
/// (fused into the simulation) or by structured forward differences.
class DynamicProblem {
 public:
  DynamicProblem(const std::vector<MimoTrialData>& trials, const HammersteinMimoParams& p)
      : q_(p.d_rad.rows()) {
    const auto phi = SigmoidsFromCutoffs(p.psi);
    bool missing = false;
    for (const auto& t : trials) missing = missing || !t.y_rad.allFinite();
    for (const auto& t : trials) {
      Z_.emplace_back(StaticOutput(phi, p.d_rad, t.u_us));
      Yt_.emplace_back((-t.y_rad).rowwise() + p.rest_rad.transpose());
      n_res_ += t.u_us.rows() * q_;
      if (missing) {  // weights 1 (measured) / 0 (missing, its ỹ stored as 0)
        const Eigen::MatrixXd w = t.y_rad.array().isFinite().cast<double>();
        Yt_.back() = (w.array() > 0.0).select(Yt_.back(), 0.0);
        W_.push_back(w);
      }
      measured_ += static_cast<Eigen::Index>(t.y_rad.array().isFinite().count());
    }
    rows_per_joint_ = n_res_ / std::max<Eigen::Index>(q_, 1);
    // One chain per (trial, joint); consecutive chains of equal length run in pairs, one per
    // SIMD lane (a chain without a partner fills both lanes). Filters are computed once per
    // joint and distinct sample period.
    Eigen::Index offset = 0;
    for (std::size_t t = 0; t < trials.size(); ++t) {
      const double T = trials[t].sample_period_s;
      std::size_t slot = 0;
      while (slot < periods_.size() && periods_[slot] != T) ++slot;
      if (slot == periods_.size()) periods_.push_back(T);
      for (Eigen::Index i = 0; i < q_; ++i) {
        chains_.push_back({t, i, i * rows_per_joint_ + offset, slot * q_ + i, T});
      }
      offset += Z_[t].rows();
    }
    BuildRuns();
  }

  Eigen::Index residuals() const { return n_res_; }
  /// The residuals of measured samples (those of missing ones are 0).
  Eigen::Index measured() const { return measured_; }

  /// r(Θ), Θ = [Ω, μ_1 … μ_q].
  Eigen::VectorXd Residual(const Eigen::VectorXd& theta) const {
    std::vector<JointFilter> f;
    for (double T : periods_) {
      for (Eigen::Index i = 0; i < q_; ++i) {
        f.push_back(DiscretiseJointDynamics(theta(0), theta(1 + i), T));
      }
    }
    Eigen::VectorXd r(n_res_);
    ForEachPair([&](const Chain& a, const Chain& b, Eigen::Index N) {
      const auto run = [&](auto weighted) {
        SimulatePair<decltype(weighted)::value>(
            PairFilters(f[a.filter], f[b.filter]), Z_[a.trial].col(a.joint).data(),
            Z_[b.trial].col(b.joint).data(), Yt_[a.trial].col(a.joint).data(),
            Yt_[b.trial].col(b.joint).data(), Weights(a), Weights(b), N, r.data() + a.offset,
            r.data() + b.offset);
      };
      W_.empty() ? run(std::false_type{}) : run(std::true_type{});
    });
    return r;
  }

  /// The cost ‖r(Θ)‖² and the exact JᵀJ, Jᵀr from one pass (PropagateLanes, one run of chains at
  /// a time), and r(Θ) into *r unless r is null (r equals Residual's to rounding).
  double NormalEquations(const Eigen::VectorXd& theta, Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr,
                         Eigen::VectorXd* r) const {
    std::vector<JointSensitivityFilter> f;
    for (double T : periods_) {
      for (Eigen::Index i = 0; i < q_; ++i) {
        f.push_back(DiscretiseJointSensitivities(theta(0), theta(1 + i), T));
      }
    }
    if (r != nullptr) r->resize(n_res_);
    jtj->setZero(q_ + 1, q_ + 1);
    jtr->setZero(q_ + 1);
    double cost = 0.0;
    const int W = lanes_;
    std::vector<double> coef(kPhiCoefficients * W), sums(kSensitivitySums * W);
    std::vector<double*> out(W);
    std::vector<double> padding;  // the residuals of padding lanes, discarded
    for (const Run& run : runs_) {
      const auto lanes = static_cast<int>(run.chains.size());
      if (r != nullptr && lanes < W && padding.size() < static_cast<std::size_t>(run.N)) {
        padding.resize(run.N);
      }
      for (int l = 0; l < W; ++l) {
        const Chain& c = chains_[run.chains[std::min(l, lanes - 1)]];
        const JointSensitivityFilter& fc = f[c.filter];
        for (int j = 0; j < kPhiCoefficients; ++j) {
          coef[j * W + l] = fc.Phi(kPhiRows[j], kPhiCols[j]);
        }
        if (r != nullptr) out[l] = l < lanes ? r->data() + c.offset : padding.data();
      }
      (W == 4 ? PropagateLanes4 : PropagateLanes2)(!W_.empty(), r != nullptr, coef.data(),
                                                   run.samples.data(), run.N, out.data(),
                                                   sums.data());
      for (int l = 0; l < lanes; ++l) {
        const Chain& c = chains_[run.chains[l]];
        const double ko = f[c.filter].k_omega, km = f[c.filter].k_mu;
        const Eigen::Index i = 1 + c.joint;
        const auto s = [&](int m) { return sums[m * W + l]; };
        (*jtj)(0, 0) += ko * ko * s(0);
        (*jtj)(0, i) += ko * km * s(2);
        (*jtj)(i, i) += km * km * s(1);
        (*jtr)(0) += ko * s(3);
        (*jtr)(i) += km * s(4);
        cost += s(5);
      }
    }
    for (Eigen::Index i = 1; i <= q_; ++i) (*jtj)(i, 0) = (*jtj)(0, i);
    return cost;
  }

  /// Structured forward differences straight into the normal equations: per trial and joint i,
  /// one simulation with Ω perturbed and one with μ_i perturbed (side by side in
  /// SimulatePairDifferences; joint i's rows see only Ω and μ_i, so J's μ columns are zero
  /// outside their joint's block), accumulated block by block without forming J. r0 = r(Θ).
  void ForwardDifferenceNormalEquations(const Eigen::VectorXd& theta, const Eigen::VectorXd& r0,
                                        Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr) const {
    constexpr double kFdStep = 1e-7;
    const double h0 = -kFdStep * std::max(std::abs(theta(0)), 1e-3);  // inward of Ω ≤ Ω_max
    Eigen::VectorXd h(q_);
    for (Eigen::Index i = 0; i < q_; ++i) h(i) = kFdStep * std::max(std::abs(theta(1 + i)), 1e-3);
    jtj->setZero(q_ + 1, q_ + 1);
    jtr->setZero(q_ + 1);
    for (const Chain& c : chains_) {
      const Eigen::Index i = c.joint;
      const FilterLanes lanes =
          PairFilters(DiscretiseJointDynamics(theta(0) + h0, theta(1 + i), c.period_s),
                      DiscretiseJointDynamics(theta(0), theta(1 + i) + h(i), c.period_s));
      const DifferenceSums d =
          W_.empty() ? SimulatePairDifferences<false>(lanes, Z_[c.trial].col(i).data(),
                                                      Yt_[c.trial].col(i).data(), nullptr,
                                                      r0.data() + c.offset, Z_[c.trial].rows())
                     : SimulatePairDifferences<true>(lanes, Z_[c.trial].col(i).data(),
                                                     Yt_[c.trial].col(i).data(), Weights(c),
                                                     r0.data() + c.offset, Z_[c.trial].rows());
      (*jtj)(0, 0) += d.dd0 / (h0 * h0);
      (*jtj)(0, 1 + i) += d.d01 / (h0 * h(i));
      (*jtj)(1 + i, 1 + i) += d.dd1 / (h(i) * h(i));
      (*jtr)(0) += d.db0 / h0;
      (*jtr)(1 + i) += d.db1 / h(i);
    }
    for (Eigen::Index i = 0; i < q_; ++i) (*jtj)(1 + i, 0) = (*jtj)(0, 1 + i);
  }

 private:
  struct Chain {
    std::size_t trial;
    Eigen::Index joint, offset;
    std::size_t filter;  // index into the per-(period, joint) filters
    double period_s;     // T
  };

  /// The weights of a chain's samples (nullptr when no trial has a missing sample).
  const double* Weights(const Chain& c) const {
    return W_.empty() ? nullptr : W_[c.trial].col(c.joint).data();
  }

  /// Up to lanes_ consecutive chains of equal length, propagated side by side, with their
  /// PropagateLanes records (lanes past the last chain are padding: all records 0).
  struct Run {
    std::vector<std::size_t> chains;
    Eigen::Index N = 0;
    Eigen::VectorXd samples;
  };

  /// Groups the chains into runs and interleaves their records: ỹ − ẑ, ẑ(k+1) − ẑ(k) and the
  /// weights, fixed for the whole dynamic step.
  void BuildRuns() {
    lanes_ = __builtin_cpu_supports("avx") ? 4 : 2;
    const int W = lanes_;
    const int fields = W_.empty() ? 2 : 3;
    for (std::size_t c = 0; c < chains_.size();) {
      Run run;
      run.N = Z_[chains_[c].trial].rows();
      while (c < chains_.size() && static_cast<int>(run.chains.size()) < W &&
             Z_[chains_[c].trial].rows() == run.N) {
        run.chains.push_back(c++);
      }
      run.samples.resize(run.N * fields * W);
      const Eigen::Index stride = fields * W;
      for (int l = 0; l < W; ++l) {
        double* rec = run.samples.data() + l;
        if (l >= static_cast<int>(run.chains.size())) {  // padding
          for (Eigen::Index k = 0; k < run.N; ++k) {
            for (int f = 0; f < fields; ++f) rec[k * stride + f * W] = 0.0;
          }
          continue;
        }
        const Chain& ch = chains_[run.chains[l]];
        const double* z = Z_[ch.trial].col(ch.joint).data();
        const double* yt = Yt_[ch.trial].col(ch.joint).data();
        for (Eigen::Index k = 0; k + 1 < run.N; ++k) {
          rec[k * stride] = yt[k] - z[k];
          rec[k * stride + W] = z[k + 1] - z[k];
        }
        if (run.N > 0) {
          rec[(run.N - 1) * stride] = yt[run.N - 1] - z[run.N - 1];
          rec[(run.N - 1) * stride + W] = 0.0;
        }
        if (const double* w = Weights(ch)) {
          for (Eigen::Index k = 0; k < run.N; ++k) {
            if (!(w[k] > 0.0)) rec[k * stride] = 0.0;
            rec[k * stride + 2 * W] = w[k];
          }
        }
      }
      runs_.push_back(std::move(run));
    }
  }

  template <typename F>
  void ForEachPair(const F& f) const {
    for (std::size_t c = 0; c < chains_.size();) {
      const Chain& a = chains_[c];
      const Eigen::Index N = Z_[a.trial].rows();
      const bool pair = c + 1 < chains_.size() && Z_[chains_[c + 1].trial].rows() == N;
      f(a, pair ? chains_[c + 1] : a, N);
      c += pair ? 2 : 1;
    }
  }

  Eigen::Index q_;
  std::vector<Eigen::MatrixXd> Z_, Yt_;  // ẑ of eq. (43) and ỹ, fixed during the search
  std::vector<Eigen::MatrixXd> W_;       // sample weights when some output sample is missing
  Eigen::Index n_res_ = 0, rows_per_joint_ = 0, measured_ = 0;
  std::vector<double> periods_;
  std::vector<Chain> chains_;
  int lanes_ = 2;  // W of PropagateLanes: 4 where the CPU has AVX
  std::vector<Run> runs_;
};

}  // namespace

Eigen::VectorXd MuscleActivations(const std::vector<SigmoidParams>& phi,
                                  const Eigen::VectorXd& u_us) {
  Eigen::VectorXd h(static_cast<Eigen::Index>(phi.size()));
  for (std::size_t j = 0; j < phi.size(); ++j) h(j) = SigmoidRecruitment(phi[j], u_us);
  return h;
}

Eigen::VectorXd StaticDeflection(const HammersteinMimoParams& p, const Eigen::VectorXd& u_us) {
  return p.d_rad * MuscleActivations(SigmoidsFromCutoffs(p.psi), u_us);
}

JointFilter DiscretiseJointDynamics(double omega_rad_s, double mu_s, double sample_period_s) {
  if (!(omega_rad_s > 0.0) || !(mu_s >= 0.0) || !(sample_period_s > 0.0)) {
    throw std::invalid_argument("joint dynamics: need Omega > 0, mu >= 0, T > 0");
  }
  // x1' = Ω(z − x1), x2' = Ω(x1 − x2), x3' = (x2 − x3)/μ: 1/((1 + s/Ω)²(1 + μ s)), eq. (18).
  Eigen::Matrix4d M = Eigen::Matrix4d::Zero();
  M(0, 0) = -omega_rad_s;
  M(0, 3) = omega_rad_s;
  M(1, 0) = omega_rad_s;
  M(1, 1) = -omega_rad_s;
  JointFilter f;
  if (mu_s > kMuNegligible_s) {
    M(2, 1) = 1.0 / mu_s;
    M(2, 2) = -1.0 / mu_s;
    f.C << 0.0, 0.0, 1.0;
  } else {
    f.C << 0.0, 1.0, 0.0;
  }
  const Eigen::Matrix4d E = (M * sample_period_s).exp();
  f.Ad = E.topLeftCorner<3, 3>();
  f.Bd = E.topRightCorner<3, 1>();
  return f;
}

JointSensitivityFilter DiscretiseJointSensitivities(double omega_rad_s, double mu_s,
                                                    double sample_period_s) {
  if (!(omega_rad_s > 0.0) || !(mu_s >= 0.0) || !(sample_period_s > 0.0)) {
    throw std::invalid_argument("joint sensitivities: need Omega > 0, mu >= 0, T > 0");
  }
  // States x1, x2, x3, a, b and the held input z (column 5): d/dt [x; z] = M [x; z], so that
  // exp(M T) holds Φ and Γ (the ZOH of the augmented system; see the header for a and b).
  const double w = omega_rad_s;
  Eigen::Matrix<double, 6, 6> M = Eigen::Matrix<double, 6, 6>::Zero();
  M(0, 0) = -w;  // x1' = Ω(z − x1)
  M(0, 5) = w;
  M(1, 0) = w;  // x2' = Ω(x1 − x2)
  M(1, 1) = -w;
  if (mu_s > kMuNegligible_s) {
    M(2, 1) = 1.0 / mu_s;  // x3' = (x2 − x3)/μ
    M(2, 2) = -1.0 / mu_s;
  } else {
    M.row(2) = M.row(1);  // P² alone: x3 ≡ x2
  }
  M.row(3) = M.row(2);  // a' = y' − Ω a (y = x3)
  M(3, 3) = -w;
  JointSensitivityFilter f;
  f.k_omega = -2.0 / w;
  if (mu_s > kMuSensitivityFloor_s) {
    M.row(4) = M.row(2);  // b' = y' − b/μ
    M(4, 4) = -1.0 / mu_s;
    f.k_mu = 1.0 / mu_s;
  } else {
    M.row(4) = M.row(0) - M.row(1);  // b = x1 − x2
    f.k_mu = w;
  }
  const Eigen::Matrix<double, 6, 6> E = (M * sample_period_s).exp();
  f.Phi = E.topLeftCorner<5, 5>().triangularView<Eigen::Lower>();
  f.Phi(4, 3) = 0.0;
  f.Gamma = E.topRightCorner<5, 1>();
  return f;
}

Eigen::MatrixXd SimulateJointSensitivities(double omega_rad_s, double mu_s,
                                           const Eigen::VectorXd& z, double sample_period_s) {
  const JointSensitivityFilter f = DiscretiseJointSensitivities(omega_rad_s, mu_s, sample_period_s);
  const Eigen::Index N = z.size();
  const Eigen::Matrix<double, 5, 1> s1 =
      (Eigen::Matrix<double, 5, 1>() << 1, 1, 1, 0, 0).finished();
  Eigen::MatrixXd out(N, 3);
  Eigen::Matrix<double, 5, 1> e = Eigen::Matrix<double, 5, 1>::Zero();
  for (Eigen::Index k = 0; k < N; ++k) {
    out(k, 0) = z(k) + e(2);
    out(k, 1) = -f.k_omega * e(3);
    out(k, 2) = -f.k_mu * e(4);
    e = f.Phi * e;
    if (k + 1 < N) e -= (z(k + 1) - z(k)) * s1;
  }
  return out;
}

DynamicNormalEquations HammersteinDynamicNormalEquations(const std::vector<MimoTrialData>& trials,
                                                         const HammersteinMimoParams& p) {
  const DynamicProblem problem(trials, p);
  Eigen::VectorXd theta(p.mu_s.size() + 1);
  theta << p.omega_rad_s, p.mu_s;
  DynamicNormalEquations out;
  problem.NormalEquations(theta, &out.jtj, &out.jtr, &out.residual);
  return out;
}

Eigen::MatrixXd SimulateHammersteinMimo(const HammersteinMimoParams& p, const Eigen::MatrixXd& u_us,
                                        double sample_period_s) {
  const Eigen::Index N = u_us.rows();
  const Eigen::Index q = p.d_rad.rows();
  const Eigen::MatrixXd Z =
      ActivationMatrix(SigmoidsFromCutoffs(p.psi), u_us) * p.d_rad.transpose();
  Eigen::MatrixXd Y(N, q);
  for (Eigen::Index i = 0; i < q; ++i) {
    const JointFilter f = DiscretiseJointDynamics(p.omega_rad_s, p.mu_s(i), sample_period_s);
    Eigen::Vector3d x = Eigen::Vector3d::Constant(N > 0 ? Z(0, i) : 0.0);
    for (Eigen::Index k = 0; k < N; ++k) {
      Y(k, i) = p.rest_rad(i) - f.C * x;
      x = f.Ad * x + f.Bd * Z(k, i);
    }
  }
  return Y;
}

SteadyStateSet ExtractSteadyState(const std::vector<MimoTrialData>& trials, double min_step_s,
                                  double ss_window_s) {
  std::vector<Eigen::VectorXd> us, ys;
  for (const auto& t : trials) {
    const Eigen::Index N = t.u_us.rows();
    const long min_len = std::max<long>(1, std::lround(min_step_s / t.sample_period_s));
    const long win = std::max<long>(1, std::lround(ss_window_s / t.sample_period_s));
    Eigen::Index start = 0;
    for (Eigen::Index k = 1; k <= N; ++k) {
      if (k < N && t.u_us.row(k) == t.u_us.row(start)) continue;
      const Eigen::Index len = k - start;
      if (len >= min_len) {
        const Eigen::Index w = std::min<Eigen::Index>(win, len);
        const auto window = t.y_rad.middleRows(k - w, w);
        if (window.allFinite()) {
          us.emplace_back(t.u_us.row(start).transpose());
          ys.emplace_back(window.colwise().mean().transpose());
        } else {
          // Missing samples (NaN): the mean of the measured ones, per output; a step whose
          // window misses an output entirely gives no steady-state point.
          const Eigen::ArrayXXd measured = window.array().isFinite().cast<double>();
          const Eigen::ArrayXd count = measured.colwise().sum().transpose();
          if ((count > 0.0).all()) {
            us.emplace_back(t.u_us.row(start).transpose());
            ys.emplace_back(
                (window.array().isFinite().select(window, 0.0).colwise().sum().transpose().array() /
                 count)
                    .matrix());
          }
        }
      }
      start = k;
    }
  }
  SteadyStateSet set;
  if (us.empty()) return set;
  set.u_us.resize(static_cast<Eigen::Index>(us.size()), us[0].size());
  set.y_rad.resize(static_cast<Eigen::Index>(ys.size()), ys[0].size());
  for (std::size_t s = 0; s < us.size(); ++s) {
    set.u_us.row(s) = us[s].transpose();
    set.y_rad.row(s) = ys[s].transpose();
  }
  return set;
}

Eigen::VectorXd PackCutoffs(const std::vector<CutoffParams>& psi) {
  if (psi.empty()) return {};
  const Eigen::Index n = psi[0].u_db_us.size();
  Eigen::VectorXd x(static_cast<Eigen::Index>(psi.size()) * (n + 1));
  for (std::size_t j = 0; j < psi.size(); ++j) {
    x.segment(j * (n + 1), n) = psi[j].u_db_us;
    x(j * (n + 1) + n) = psi[j].u_sat_us;
  }
  return x;
}

std::vector<CutoffParams> UnpackCutoffs(const Eigen::VectorXd& x, int inputs_n) {
  if (inputs_n < 1 || x.size() % (inputs_n + 1) != 0) {
    throw std::invalid_argument("UnpackCutoffs: length is not a multiple of n + 1");
  }
  std::vector<CutoffParams> psi(static_cast<std::size_t>(x.size() / (inputs_n + 1)));
  for (std::size_t j = 0; j < psi.size(); ++j) {
    psi[j].u_db_us = x.segment(j * (inputs_n + 1), inputs_n);
    psi[j].u_sat_us = x(j * (inputs_n + 1) + inputs_n);
  }
  return psi;
}

HammersteinMimoFit FitHammersteinStatic(const SteadyStateSet& set, const Eigen::VectorXd& rest_rad,
                                        const HammersteinMimoOptions& options) {
  const auto t0 = Clock::now();
  const int n = static_cast<int>(set.u_us.cols());
  const int q = static_cast<int>(set.y_rad.cols());
  const int l = options.muscles_l > 0 ? options.muscles_l : n;
  const HammersteinMimoBounds& b = options.bounds;
  if (rest_rad.size() != q) throw std::invalid_argument("FitHammersteinStatic: r has wrong size");
  StaticProblem prob;
  prob.u = &set.u_us;
  prob.ytilde = (-set.y_rad).rowwise() + rest_rad.transpose();  // ỹ = r − y
  prob.n = n;
  prob.d_bound = b.d_abs_max_rad;
  const int p = l * (n + 1);
  Eigen::VectorXd lower(p), upper(p);
  for (Eigen::Index j = 0; j < l; ++j) {
    lower.segment(j * (n + 1), n).setConstant(b.u_db_min_us);
    upper.segment(j * (n + 1), n).setConstant(b.u_db_max_us);
    lower(j * (n + 1) + n) = b.u_sat_min_us;
    upper(j * (n + 1) + n) = b.u_sat_max_us;
  }
  const auto residual = [&prob](const Eigen::VectorXd& x) { return prob.Residual(x); };
  const auto project = [n](Eigen::VectorXd* x) { ProjectCutoffs(n, x); };
  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  HammersteinMimoFit fit;
  LmResult best;
  best.cost = std::numeric_limits<double>::infinity();
  LmOptions lo;
  lo.max_iterations = 200;
  lo.relative_tolerance = kRelativeTolerance;
  lo.hold_active_bounds = true;
  for (int s = 0; s < std::max(1, options.starts); ++s) {
    Eigen::VectorXd x0(p);
    for (int k = 0; k < p; ++k) x0(k) = lower(k) + unit(rng) * (upper(k) - lower(k));
    const auto ts = Clock::now();
    const double cpu = ThreadCpuSeconds();
    LmResult r = LevenbergMarquardt(residual, x0, lower, upper, lo, project);
    fit.static_step_wall_s.push_back(Seconds(ts));
    fit.static_step_cpu_s.push_back(ThreadCpuSeconds() - cpu);
    fit.static_step_iterations.push_back(r.iterations);
    fit.static_step_convergence.push_back(ToConvergence(r));
    if (r.cost < best.cost) {
      fit.static_best_run = fit.static_step_convergence.size() - 1;
      best = std::move(r);
    }
  }
  // Sort muscle units by u^db_{j,1} (the model is invariant to their order).
  std::vector<CutoffParams> psi = UnpackCutoffs(best.x, n);
  std::vector<int> order(static_cast<std::size_t>(l));
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&psi](int a, int c) { return psi[a].u_db_us(0) < psi[c].u_db_us(0); });
  std::vector<CutoffParams> sorted;
  Eigen::VectorXd ci = ConfidenceHalfWidths95(best.jtj, best.cost, best.residual.size());
  Eigen::VectorXd ci_sorted(p);
  for (int j = 0; j < l; ++j) {
    sorted.push_back(psi[order[j]]);
    ci_sorted.segment(static_cast<Eigen::Index>(j) * (n + 1), n + 1) =
        ci.segment(static_cast<Eigen::Index>(order[j]) * (n + 1), n + 1);
  }
  const Eigen::MatrixXd H = ActivationMatrix(SigmoidsFromCutoffs(sorted), set.u_us);
  fit.params.psi = sorted;
  fit.params.d_rad = prob.SolveD(H);
  fit.params.rest_rad = rest_rad;
  fit.params.mu_s = Eigen::VectorXd::Zero(q);
  fit.static_cost = best.cost;
  fit.psi_ci95 = ci_sorted;
  fit.d_ci95.resize(q, l);
  for (int i = 0; i < q; ++i) {
    const Eigen::VectorXd r = prob.ytilde.col(i) - H * fit.params.d_rad.row(i).transpose();
    fit.d_ci95.row(i) =
        ConfidenceHalfWidths95(H.transpose() * H, r.squaredNorm(), H.rows()).transpose();
  }
  fit.total_wall_s = Seconds(t0);
  return fit;
}

void FitHammersteinDynamic(const std::vector<MimoTrialData>& trials,
                           const HammersteinMimoOptions& options, HammersteinMimoFit* fit) {
  const auto t0 = Clock::now();
  const Eigen::Index q = fit->params.d_rad.rows();
  const DynamicProblem problem(trials, fit->params);
  const bool exact = options.dynamic_jacobian == DynamicJacobian::kExactSensitivities;
  // Exact path: every cost evaluation also propagates the sensitivities and keeps JᵀJ, Jᵀr for
  // its Θ, and the residual vector is never stored (LevenbergMarquardtOnCost).
  // LevenbergMarquardt asks for the normal equations only at the point it evaluated last (the
  // start, then each accepted step), so they come without another simulation; at any other Θ
  // they are recomputed.
  Eigen::VectorXd cached_theta;
  Eigen::MatrixXd cached_jtj;
  Eigen::VectorXd cached_jtr;
  const auto cost = [&](const Eigen::VectorXd& theta) {
    cached_theta = theta;
    return problem.NormalEquations(theta, &cached_jtj, &cached_jtr, nullptr);
  };
  const auto residual = [&](const Eigen::VectorXd& theta) { return problem.Residual(theta); };
  const auto normal_equations = [&](const Eigen::VectorXd& theta, const Eigen::VectorXd& r0,
                                    Eigen::MatrixXd* jtj, Eigen::VectorXd* jtr, int* evals) {
    if (!exact) {
      problem.ForwardDifferenceNormalEquations(theta, r0, jtj, jtr);
      *evals += 2;
      return;
    }
    if (cached_theta.size() != theta.size() || cached_theta != theta) {
      cost(theta);
      ++*evals;
    }
    *jtj = cached_jtj;
    *jtr = cached_jtr;
  };
  const HammersteinMimoBounds& b = options.bounds;
  Eigen::VectorXd lower(q + 1), upper(q + 1);
  lower(0) = b.omega_min_rad_s;
  upper(0) = b.omega_max_rad_s;
  lower.tail(q).setConstant(b.mu_min_s);
  upper.tail(q).setConstant(b.mu_max_s);
  LmResult best;
  best.cost = std::numeric_limits<double>::infinity();
  const int starts = std::max(1, options.dynamic_starts);
  for (int s = 0; s < starts; ++s) {
    Eigen::VectorXd x0(q + 1);
    // Ω spread geometrically over [1, 8] rad/s; μ starts at 0.1 s.
    x0(0) = starts == 1 ? 4.0 : std::exp(std::log(1.0) + s * std::log(8.0) / (starts - 1));
    x0.tail(q).setConstant(0.1);
    const auto ts = Clock::now();
    const double cpu = ThreadCpuSeconds();
    LmOptions lo;
    lo.relative_tolerance = kRelativeTolerance;
    lo.hold_active_bounds = true;
    LmResult r = exact
                     ? LevenbergMarquardtOnCost(cost, x0, lower, upper, normal_equations, lo)
                     : LevenbergMarquardt(residual, x0, lower, upper, lo, {}, {}, normal_equations);
    fit->dynamic_step_wall_s.push_back(Seconds(ts));
    fit->dynamic_step_cpu_s.push_back(ThreadCpuSeconds() - cpu);
    fit->dynamic_step_iterations.push_back(r.iterations);
    fit->dynamic_step_evaluations.push_back(r.evaluations);
    fit->dynamic_step_convergence.push_back(ToConvergence(r));
    if (r.cost < best.cost) {
      fit->dynamic_best_run = fit->dynamic_step_convergence.size() - 1;
      best = std::move(r);
    }
  }
  fit->params.omega_rad_s = best.x(0);
  fit->params.mu_s = best.x.tail(q);
  fit->dynamic_cost = best.cost;
  fit->theta_ci95 = ConfidenceHalfWidths95(best.jtj, best.cost, problem.measured());
  fit->total_wall_s += Seconds(t0);
}

HammersteinMimoFit FitHammersteinMimo(const std::vector<MimoTrialData>& trials,
                                      const HammersteinMimoOptions& options) {
  const SteadyStateSet set = ExtractSteadyState(trials, options.min_step_s, options.ss_window_s);
  if (trials.empty() || set.u_us.rows() == 0) {
    throw std::runtime_error("hammerstein-mimo: no constant-input segment of at least " +
                             Num(options.min_step_s) + " s (step-grid protocol expected)");
  }
  const Eigen::Index q = set.y_rad.cols();
  Eigen::VectorXd rest = Eigen::VectorXd::Zero(q);
  int zeros = 0;
  for (Eigen::Index s = 0; s < set.u_us.rows(); ++s) {
    if (set.u_us.row(s).isZero(0.0)) {
      rest += set.y_rad.row(s).transpose();
      ++zeros;
    }
  }
  if (zeros > 0) {
    rest /= zeros;
  } else {  // the first measured sample of each output
    const Eigen::MatrixXd& y0 = trials[0].y_rad;
    for (Eigen::Index i = 0; i < q; ++i) {
      Eigen::Index k = 0;
      while (k + 1 < y0.rows() && !std::isfinite(y0(k, i))) ++k;
      rest(i) = y0(k, i);
    }
  }
  HammersteinMimoFit fit = FitHammersteinStatic(set, rest, options);
  FitHammersteinDynamic(trials, options, &fit);
  return fit;
}

// ---------------------------------------------------------------------------------------------
// CLI adapter.
namespace {

struct MimoColumns {
  std::vector<std::string> inputs, outputs;
};

MimoTrialData ReadMimo(const Trial& trial, const MimoColumns& cols, const std::string& label) {
  MimoTrialData d;
  d.sample_period_s = UniformSamplePeriod(trial, label);
  d.u_us = RequireColumns(trial, cols.inputs, label);
  // Output samples may be missing (tracker dropouts, NaN): the dynamic step leaves them out of
  // its loss, the static step averages the measured ones.
  d.y_rad.resize(d.u_us.rows(), static_cast<Eigen::Index>(cols.outputs.size()));
  for (std::size_t i = 0; i < cols.outputs.size(); ++i) {
    std::size_t missing = 0;
    d.y_rad.col(static_cast<Eigen::Index>(i)) =
        OutputColumn(trial, cols.outputs[i], label, &missing);
    if (missing == static_cast<std::size_t>(d.y_rad.rows())) {
      throw std::runtime_error(label + ": column " + cols.outputs[i] + " has no measured sample");
    }
  }
  if ((d.u_us.array() < 0.0).any() || (d.u_us.array() > 300.0).any()) {
    throw std::runtime_error(label + ": u.* pulse widths must lie in [0, 300] us");
  }
  return d;
}

/// The two-step fit on `train` and the identified model's YAML (shared by `fesim identify` and
/// the diagnosis simulator).
struct MimoFitted {
  MimoColumns cols;
  SteadyStateSet set;
  HammersteinMimoFit fit;
  std::string yaml;
  std::vector<std::string> warnings;
};

MimoFitted FitMimoOnTrials(const std::vector<Trial>& train_rows, const ProgressFn& progress) {
  if (train_rows.empty()) throw std::runtime_error("--train: no trials");
  // The rows of the angle sensor (a hand-rig record interleaves other sensors' rows).
  const std::vector<Trial> train = SensorRows(train_rows, train_rows[0].NamesWithPrefix("q."));
  MimoColumns cols{train[0].NamesWithPrefix("u."), train[0].NamesWithPrefix("q.")};
  if (cols.inputs.empty()) throw std::runtime_error("train trial 0: no u.* input column");
  if (cols.outputs.empty()) throw std::runtime_error("train trial 0: no q.* output column");
  const int n = static_cast<int>(cols.inputs.size());
  const int q = static_cast<int>(cols.outputs.size());
  MetadataOptions md(train[0].metadata, "hammerstein");
  HammersteinMimoOptions o;
  o.muscles_l = md.Int("muscles_l", n, 1, 64);
  o.starts = md.Int("starts", o.starts, 1, 100000);
  o.dynamic_starts = md.Int("dynamic_starts", o.dynamic_starts, 1, 1000);
  o.seed = static_cast<unsigned>(md.Int("seed", 1, 0, 2147483647));
  o.min_step_s = md.Real("min_step_s", o.min_step_s, 0.0, 1e6);
  o.ss_window_s = md.Real("ss_window_s", o.ss_window_s, 0.0, 1e6);
  md.RejectUnknown();
  std::vector<MimoTrialData> tr;
  for (std::size_t t = 0; t < train.size(); ++t) {
    const std::string label = "train trial " + std::to_string(t);
    RequireSamples(train[t], 10, label, "dynamic fit");
    tr.push_back(ReadMimo(train[t], cols, label));
  }
  const SteadyStateSet set = ExtractSteadyState(tr, o.min_step_s, o.ss_window_s);
  const int l = o.muscles_l;
  const long unknowns = static_cast<long>(l) * (n + 1) + static_cast<long>(l) * q;
  if (set.u_us.rows() * q <= unknowns) {
    throw std::runtime_error("train: " + std::to_string(set.u_us.rows()) +
                             " steady-state points (constant input for >= " + Num(o.min_step_s) +
                             " s), need more than " + std::to_string(unknowns / q) +
                             " for l = " + std::to_string(l));
  }
  if (progress) progress(0.0, "static step (multi-start, " + std::to_string(o.starts) + ")");
  const HammersteinMimoFit fit = FitHammersteinMimo(tr, o);
  if (progress) progress(0.9, "evaluation");

  const HammersteinMimoParams& p = fit.params;
  std::string y =
      "# fesim identify: hammerstein-mimo (paper 000_0a6c0de9fc69df7c eq. 16-24, "
      "two-step identification of section 4)\nmethod: hammerstein-mimo\n";
  y += "inputs: [";
  for (int k = 0; k < n; ++k) y += (k ? ", " : "") + cols.inputs[k];
  y += "]\noutputs: [";
  for (int i = 0; i < q; ++i) y += (i ? ", " : "") + cols.outputs[i];
  y += "]\nmuscles_l: " + std::to_string(l) + "\n";
  y += YamlParam("Omega", p.omega_rad_s, "rad/s", fit.theta_ci95(0), 0);
  y += "joints:\n";
  for (int i = 0; i < q; ++i) {
    y += "  " + cols.outputs[i] + ":\n";
    y += YamlParam("rest_r", p.rest_rad(i), "rad", NAN, 4);
    y += YamlParam("mu", p.mu_s(i), "s", fit.theta_ci95(1 + i), 4);
    for (int j = 0; j < l; ++j) {
      y += YamlParam("D_" + std::to_string(j + 1), p.d_rad(i, j), "rad", fit.d_ci95(i, j), 4);
    }
  }
  y += "# Psi = M(Phi) (eq. 39); ci95 of D are conditional on Psi\nmuscles:\n";
  const auto phi = SigmoidsFromCutoffs(p.psi);
  for (int j = 0; j < l; ++j) {
    y += "  - unit: " + std::to_string(j + 1) + "\n";
    for (int k = 0; k < n; ++k) {
      y += YamlParam("u_db_" + cols.inputs[k], p.psi[j].u_db_us(k), "us",
                     fit.psi_ci95(j * (n + 1) + k), 4);
      y += YamlParam("delta_" + cols.inputs[k], phi[j].delta(k), "1/us", NAN, 4);
    }
    y += YamlParam("u_sat_" + cols.inputs[0], p.psi[j].u_sat_us, "us",
                   fit.psi_ci95(j * (n + 1) + n), 4);
    y += YamlParam("gamma", phi[j].gamma, "1", NAN, 4);
  }
  y += "# how each local Levenberg-Marquardt run stopped (best_run: the one kept)\nconvergence:\n";
  y += ConvergenceYaml("static_step", fit.static_step_convergence, fit.static_best_run, 2);
  y += ConvergenceYaml("dynamic_step", fit.dynamic_step_convergence, fit.dynamic_best_run, 2);
  std::vector<std::string> warnings;
  for (const std::string& w :
       {NotConvergedWarning("hammerstein-mimo static step", fit.static_step_convergence,
                            fit.static_best_run),
        NotConvergedWarning("hammerstein-mimo dynamic step", fit.dynamic_step_convergence,
                            fit.dynamic_best_run)}) {
    if (!w.empty()) warnings.push_back(w);
  }
  return {cols, set, fit, y, warnings};
}

MethodResult RunHammersteinMimo(const std::vector<Trial>& train_rows,
                                const std::vector<Trial>& test_rows, const ProgressFn& progress) {
  if (train_rows.empty()) throw std::runtime_error("--train: no trials");
  const std::vector<std::string> outputs = train_rows[0].NamesWithPrefix("q.");
  const std::vector<Trial> train = SensorRows(train_rows, outputs);
  const std::vector<Trial> test = SensorRows(test_rows, outputs);
  const MimoFitted fitted = FitMimoOnTrials(train, progress);
  const MimoColumns& cols = fitted.cols;
  const SteadyStateSet& set = fitted.set;
  const HammersteinMimoFit& fit = fitted.fit;
  const HammersteinMimoParams& p = fit.params;
  const int n = static_cast<int>(cols.inputs.size());
  const int q = static_cast<int>(cols.outputs.size());
  MethodResult result;
  result.model_yaml = fitted.yaml;
  result.warnings = fitted.warnings;

  const bool has_test = !test.empty();
  const std::vector<Trial>& eval = has_test ? test : train;
  Json fits = Json::Array();
  std::vector<double> ne_sum(static_cast<std::size_t>(q), 0.0);
  for (std::size_t t = 0; t < eval.size(); ++t) {
    const std::string label =
        std::string(has_test ? "test" : "train") + " trial " + std::to_string(t);
    const MimoTrialData d = ReadMimo(eval[t], cols, label);
    const Eigen::MatrixXd yhat = SimulateHammersteinMimo(p, d.u_us, d.sample_period_s);
    Json f = Json::Object();
    f.Set("trial", static_cast<int>(t));
    Json joints = Json::Object();
    Trial pred;
    pred.metadata["source"] = "fesim identify --method hammerstein-mimo";
    pred.time = eval[t].time;
    for (int k = 0; k < n; ++k) pred.AddColumn(cols.inputs[k], eval[t].Column(cols.inputs[k]));
    for (int i = 0; i < q; ++i) {
      std::vector<double> yv(d.y_rad.col(i).data(), d.y_rad.col(i).data() + d.y_rad.rows());
      std::vector<double> yh(yhat.col(i).data(), yhat.col(i).data() + yhat.rows());
      // The metrics are over the measured samples; the prediction covers every row.
      std::vector<double> yhm = yh;
      const std::size_t all = yv.size();
      KeepMeasuredPairs(&yv, &yhm);
      Json jf = Json::Object();
      jf.Set("best_fit_percent", BestFitPercent(yv, yhm));
      const double ne = NormalisedError(yv, yhm);
      jf.Set("normalised_error", ne);
      ne_sum[static_cast<std::size_t>(i)] += ne;
      jf.Set("rms_rad", Rms(yv, yhm));
      jf.Set("missing_samples", static_cast<double>(all - yv.size()));
      joints.Set(cols.outputs[i], jf);
      pred.AddColumn(cols.outputs[i], std::move(yh));
    }
    f.Set("joints", joints);
    fits.Push(f);
    result.predictions.push_back(std::move(pred));
  }
  Json mean_ne = Json::Object();
  for (int i = 0; i < q; ++i)
    mean_ne.Set(cols.outputs[i], ne_sum[i] / static_cast<double>(eval.size()));
  const auto mean_sd = [](const std::vector<double>& v) {
    Json j = Json::Object();
    double m = 0, s = 0;
    for (double x : v) m += x;
    m /= std::max<std::size_t>(1, v.size());
    for (double x : v) s += (x - m) * (x - m);
    j.Set("mean", m);
    j.Set("std", v.size() > 1 ? std::sqrt(s / (v.size() - 1)) : 0.0);
    j.Set("count", static_cast<int>(v.size()));
    j.Set("all", v);
    return j;
  };
  Json m = Json::Object();
  m.Set("method", "hammerstein-mimo");
  m.Set("prediction", "simulation from the steady state of the first input (not one-step-ahead)");
  m.Set("steady_state_points", static_cast<int>(set.u_us.rows()));
  m.Set(has_test ? "test" : "train", fits);
  std::size_t train_missing = 0;
  for (const Trial& t : train) {
    for (const auto& y : cols.outputs) {
      for (double v : t.Column(y)) train_missing += std::isfinite(v) ? 0 : 1;
    }
  }
  m.Set("train_missing_samples", static_cast<double>(train_missing));
  m.Set("mean_normalised_error", mean_ne);
  m.Set("static_cost_rad2", fit.static_cost);
  m.Set("dynamic_cost_rad2", fit.dynamic_cost);
  m.Set("static_local_step_wall_s", mean_sd(fit.static_step_wall_s));
  m.Set("dynamic_local_step_wall_s", mean_sd(fit.dynamic_step_wall_s));
  std::vector<double> iters(fit.static_step_iterations.begin(), fit.static_step_iterations.end());
  m.Set("static_local_step_iterations", iters);
  m.Set("static_step_convergence",
        ConvergenceJson(fit.static_step_convergence, fit.static_best_run));
  m.Set("dynamic_step_convergence",
        ConvergenceJson(fit.dynamic_step_convergence, fit.dynamic_best_run));
  m.Set("total_wall_s", fit.total_wall_s);
  result.metrics = m;
  if (progress) progress(1.0, "done");
  return result;
}

FittedSimulator FitHammersteinMimoSimulator(const std::vector<Trial>& train,
                                            const ProgressFn& progress) {
  MimoFitted fitted = FitMimoOnTrials(train, progress);
  FittedSimulator out;
  out.model_yaml = fitted.yaml;
  out.inputs = fitted.cols.inputs;
  out.outputs = fitted.cols.outputs;
  out.warnings = fitted.warnings;
  out.simulate = [cols = fitted.cols, p = fitted.fit.params](const Trial& trial) {
    const std::string label = "simulated trial";
    const Eigen::MatrixXd u = RequireColumns(trial, cols.inputs, label);
    const Eigen::MatrixXd yhat = SimulateHammersteinMimo(p, u, UniformSamplePeriod(trial, label));
    Trial pred;
    pred.time = trial.time;
    for (std::size_t i = 0; i < cols.outputs.size(); ++i) {
      const auto col = yhat.col(static_cast<Eigen::Index>(i));
      pred.AddColumn(cols.outputs[i], std::vector<double>(col.data(), col.data() + col.size()));
    }
    return pred;
  };
  if (progress) progress(1.0, "done");
  return out;
}

}  // namespace

MethodEntry HammersteinMimoMethod() {
  return {"hammerstein-mimo",
          "MIMO Hammerstein hand model, two-step fit (static Psi/d, then Theta), paper 000",
          RunHammersteinMimo, FitHammersteinMimoSimulator};
}

}  // namespace fesim::identification
