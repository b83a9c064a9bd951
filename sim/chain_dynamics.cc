#include "sim/chain_dynamics.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace fesim::sim {

using SimTK::Mat33;
using SimTK::SpatialVec;
using SimTK::Vec3;

namespace {

// Small dense products on the matrices' storage, written out so that they inline (SimTK's
// generic products and even its element access are out-of-line calls here). A Mat33 is nine
// packed doubles, element (i, j) at [i + 3 j].
static_assert(sizeof(Mat33) == 9 * sizeof(double), "Mat33 is nine packed doubles");
inline const double* Data(const Mat33& m) { return reinterpret_cast<const double*>(&m); }
inline double* Data(Mat33& m) { return reinterpret_cast<double*>(&m); }

inline Vec3 Mul(const Mat33& m, const Vec3& v) {
  const double* a = Data(m);
  return {a[0] * v[0] + a[3] * v[1] + a[6] * v[2], a[1] * v[0] + a[4] * v[1] + a[7] * v[2],
          a[2] * v[0] + a[5] * v[1] + a[8] * v[2]};
}
/// mᵀ v.
inline Vec3 MulT(const Mat33& m, const Vec3& v) {
  const double* a = Data(m);
  return {a[0] * v[0] + a[1] * v[1] + a[2] * v[2], a[3] * v[0] + a[4] * v[1] + a[5] * v[2],
          a[6] * v[0] + a[7] * v[1] + a[8] * v[2]};
}
inline Mat33 Mul(const Mat33& a, const Mat33& b) {
  Mat33 r;
  const double *x = Data(a), *y = Data(b);
  double* z = Data(r);
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) {
      z[i + 3 * j] = x[i] * y[3 * j] + x[i + 3] * y[1 + 3 * j] + x[i + 6] * y[2 + 3 * j];
    }
  }
  return r;
}
/// a bᵀ.
inline Mat33 MulTransposed(const Mat33& a, const Mat33& b) {
  Mat33 r;
  const double *x = Data(a), *y = Data(b);
  double* z = Data(r);
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i)
      z[i + 3 * j] = x[i] * y[j] + x[i + 3] * y[j + 3] + x[i + 6] * y[j + 6];
  }
  return r;
}
/// r = a − s · u wᵀ.
inline void MinusOuter(const Mat33& a, double s, const Vec3& u, const Vec3& w, Mat33* r) {
  const double* x = Data(a);
  double* z = Data(*r);
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) z[i + 3 * j] = x[i + 3 * j] - s * u[i] * w[j];
  }
}
/// dst = src (SimTK's Mat33 assignment is an out-of-line element loop here).
inline void Copy(Mat33* dst, const Mat33& src) {
  double* z = Data(*dst);
  const double* x = Data(src);
  for (int k = 0; k < 9; ++k) z[k] = x[k];
}
/// dst += src.
inline void AddTo(Mat33* dst, const Mat33& src) {
  double* z = Data(*dst);
  const double* x = Data(src);
  for (int k = 0; k < 9; ++k) z[k] += x[k];
}
/// The rigid-body blocks about G's origin of mass m with its centre at c (in G) and inertia
/// I_c (about the centre, in G): A = I_c + m (|c|² 1 − c cᵀ), B = m c×, C = m 1.
inline void RigidInertia(double m, const Vec3& c, const Mat33& inertia_c, Mat33* A, Mat33* B,
                         Mat33* C) {
  *A = inertia_c;
  double* a = Data(*A);
  const double cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) a[i + 3 * j] += m * ((i == j ? cc : 0.0) - c[i] * c[j]);
  }
  double* b = Data(*B);
  b[0] = b[4] = b[8] = 0.0;
  b[5] = m * c[0];   // (2, 1)
  b[7] = -m * c[0];  // (1, 2)
  b[6] = m * c[1];   // (0, 2)
  b[2] = -m * c[1];  // (2, 0)
  b[1] = m * c[2];   // (1, 0)
  b[3] = -m * c[2];  // (0, 1)
  double* cm = Data(*C);
  for (int k = 0; k < 9; ++k) cm[k] = 0.0;
  cm[0] = cm[4] = cm[8] = m;
}
inline double Dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double Dot(const SpatialVec& a, const SpatialVec& b) {
  return Dot(a[0], b[0]) + Dot(a[1], b[1]);
}

/// I m for the spatial matrix [[A, B], [Bᵀ, C]].
inline SpatialVec MulInertia(const Mat33& A, const Mat33& B, const Mat33& C, const SpatialVec& m) {
  return {Mul(A, m[0]) + Mul(B, m[1]), MulT(B, m[0]) + Mul(C, m[1])};
}

/// v ×ₘ m ([Featherstone 2008] eq. 2.31): the motion cross product.
inline SpatialVec CrossMotion(const SpatialVec& v, const SpatialVec& m) {
  return {v[0] % m[0], v[0] % m[1] + v[1] % m[0]};
}

/// v ×* f (eq. 2.32): the force cross product.
inline SpatialVec CrossForce(const SpatialVec& v, const SpatialVec& f) {
  return {v[0] % f[0] + v[1] % f[1], v[0] % f[1]};
}

/// d · 1.
Mat33 Diagonal(double d) { return {d, 0, 0, 0, d, 0, 0, 0, d}; }

}  // namespace

ChainDynamics::ChainDynamics(std::vector<ChainBody> bodies, Vec3 gravity_m_s2)
    : bodies_(std::move(bodies)), gravity_(gravity_m_s2) {
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    const ChainBody& body = bodies_[b];
    if (body.parent >= static_cast<int>(b) || body.parent < -1) {
      throw std::invalid_argument("ChainDynamics: body " + std::to_string(b) + " has parent " +
                                  std::to_string(body.parent) + " (allowed -1.." +
                                  std::to_string(static_cast<int>(b) - 1) + ")");
    }
    // F in the parent's M: the parent's X_MB composed with this body's X_PF, once.
    X_MF_.push_back(body.parent < 0 ? body.X_PF : X_MB_[body.parent] * body.X_PF);
    X_MB_.push_back(~body.X_BM);
    // I_c = I_o − m (|c|² 1 − c cᵀ) (parallel axes).
    const Vec3& c = body.com_m;
    inertia_c_.push_back(body.inertia_o - body.mass_kg * (Diagonal(Dot(c, c)) - c * ~c));
  }
}

void ChainDynamics::Kinematics(const double* q, ChainWorkspace* ws) const {
  const std::size_t n = bodies_.size();
  ws->R_GM.resize(n);
  ws->p_GM.resize(n);
  ws->R_GB.resize(n);
  ws->p_GB.resize(n);
  ws->S.resize(n);
  ws->f.assign(n, SpatialVec(Vec3(0), Vec3(0)));
  for (std::size_t b = 0; b < n; ++b) {
    const ChainBody& body = bodies_[b];
    const SimTK::Transform& X_MF = X_MF_[b];  // in the parent's M (or G)
    Mat33 R_GF;
    Vec3 p_GF;
    if (body.parent < 0) {
      R_GF = X_MF.R().asMat33();
      p_GF = X_MF.p();
    } else {
      const Mat33& R = ws->R_GM[body.parent];
      R_GF = Mul(R, X_MF.R().asMat33());
      p_GF = ws->p_GM[body.parent] + Mul(R, X_MF.p());
    }
    // A pin turns M about F's Z by q: M's x and y columns rotate within F's x–y plane.
    Mat33& R_GM = ws->R_GM[b];
    R_GM = R_GF;
    const double* f = Data(R_GF);  // columns x, y, z at [0], [3], [6]
    if (body.q >= 0) {
      const double cq = std::cos(q[body.q]), sq = std::sin(q[body.q]);
      double* m = Data(R_GM);
      for (int i = 0; i < 3; ++i) {
        m[i] = cq * f[i] + sq * f[i + 3];
        m[i + 3] = -sq * f[i] + cq * f[i + 3];
      }
    }
    ws->p_GM[b] = p_GF;
    // The axis through M's origin as a motion about G's origin: (a, p × a).
    const Vec3 axis(f[6], f[7], f[8]);
    ws->S[b] =
        body.u >= 0 && !body.held ? SpatialVec(axis, p_GF % axis) : SpatialVec(Vec3(0), Vec3(0));
    if (body.mass_kg > 0.0) {
      ws->R_GB[b] = Mul(R_GM, X_MB_[b].R().asMat33());
      ws->p_GB[b] = p_GF + Mul(R_GM, X_MB_[b].p());
    }
  }
}

Vec3 ChainDynamics::StationInGround(const ChainWorkspace& ws, int b, const Vec3& p_B) const {
  return ws.p_GB[b] + Mul(ws.R_GB[b], p_B);
}

void ChainDynamics::ApplyForceAtStation(ChainWorkspace* ws, int b, const Vec3& p_B,
                                        const Vec3& f_G) const {
  ws->f[b] += SpatialVec(StationInGround(*ws, b, p_B) % f_G, f_G);
}

void ChainDynamics::Accelerations(const double* u, const double* tau, ChainWorkspace* ws,
                                  double* udot) const {
  ArticulatedInertias(ws);
  AccelerationsAtInertias(u, tau, ws, udot);
}

void ChainDynamics::ArticulatedInertias(ChainWorkspace* ws) const {
  const int n = num_bodies();
  for (auto* m :
       {&ws->RA, &ws->RB, &ws->RC, &ws->IA, &ws->IB, &ws->IC, &ws->PA, &ws->PB, &ws->PC}) {
    m->resize(n);
  }
  ws->U.resize(n);
  ws->D.resize(n);
  ws->inv_d.resize(n);
  // Rigid-body inertias about G's origin (pass 1 of Table 7.1, its position part).
  for (int b = 0; b < n; ++b) {
    const ChainBody& body = bodies_[b];
    if (body.mass_kg > 0.0) {
      const Mat33& R = ws->R_GB[b];
      RigidInertia(body.mass_kg, ws->p_GB[b] + Mul(R, body.com_m),
                   MulTransposed(Mul(R, inertia_c_[b]), R), &ws->RA[b], &ws->RB[b], &ws->RC[b]);
      Copy(&ws->IA[b], ws->RA[b]);
      Copy(&ws->IB[b], ws->RB[b]);
      Copy(&ws->IC[b], ws->RC[b]);
    } else {
      for (Mat33* m : {&ws->IA[b], &ws->IB[b], &ws->IC[b]}) {
        double* z = Data(*m);
        for (int k = 0; k < 9; ++k) z[k] = 0.0;
      }
    }
  }
  // Articulated inertias, tip to root (pass 2's inertia part; all in G: a child's adds to its
  // parent's as it is).
  for (int b = n - 1; b >= 0; --b) {
    const ChainBody& body = bodies_[b];
    const bool moves = body.u >= 0 && !body.held;
    if (moves) {
      const SpatialVec& S = ws->S[b];
      SpatialVec& U = ws->U[b];
      U = MulInertia(ws->IA[b], ws->IB[b], ws->IC[b], S);
      ws->D[b] = Dot(S, U);
      ws->inv_d[b] = 1.0 / ws->D[b];
      const double inv_d = ws->inv_d[b];
      MinusOuter(ws->IA[b], inv_d, U[0], U[0], &ws->PA[b]);
      MinusOuter(ws->IB[b], inv_d, U[0], U[1], &ws->PB[b]);
      MinusOuter(ws->IC[b], inv_d, U[1], U[1], &ws->PC[b]);
    }
    if (body.parent < 0) continue;
    // A weld or held pin projects nothing out: its articulated inertia passes as it is.
    AddTo(&ws->IA[body.parent], moves ? ws->PA[b] : ws->IA[b]);
    AddTo(&ws->IB[body.parent], moves ? ws->PB[b] : ws->IB[b]);
    AddTo(&ws->IC[body.parent], moves ? ws->PC[b] : ws->IC[b]);
  }
}

void ChainDynamics::AccelerationsAtInertias(const double* u, const double* tau, ChainWorkspace* ws,
                                            double* udot) const {
  const int n = num_bodies();
  ws->v.resize(n);
  ws->c.resize(n);
  ws->p.resize(n);
  ws->a.resize(n);
  ws->uu.resize(n);
  // Pass 1: velocities, velocity-product accelerations c = v ×ₘ S u̇ (Ṡ = v ×ₘ S for an axis
  // fixed in the moving body) and bias forces.
  for (int b = 0; b < n; ++b) {
    const ChainBody& body = bodies_[b];
    const SpatialVec vj = body.u >= 0 ? ws->S[b] * u[body.u] : SpatialVec(Vec3(0), Vec3(0));
    ws->v[b] = (body.parent < 0 ? SpatialVec(Vec3(0), Vec3(0)) : ws->v[body.parent]) + vj;
    ws->c[b] = CrossMotion(ws->v[b], vj);
    if (body.mass_kg > 0.0) {
      const SpatialVec& v = ws->v[b];
      ws->p[b] = CrossForce(v, MulInertia(ws->RA[b], ws->RB[b], ws->RC[b], v)) - ws->f[b];
    } else {
      ws->p[b] = -ws->f[b];
    }
  }
  // Pass 2: articulated bias forces, tip to root.
  for (int b = n - 1; b >= 0; --b) {
    const ChainBody& body = bodies_[b];
    const bool moves = body.u >= 0 && !body.held;
    if (moves) ws->uu[b] = tau[body.u] - Dot(ws->S[b], ws->p[b]);
    if (body.parent < 0) continue;
    const int parent = body.parent;
    if (moves) {
      ws->p[parent] += ws->p[b] + MulInertia(ws->PA[b], ws->PB[b], ws->PC[b], ws->c[b]) +
                       ws->U[b] * (ws->uu[b] * ws->inv_d[b]);
    } else {  // a weld or held pin: c = 0
      ws->p[parent] += ws->p[b];
    }
  }
  // Pass 3: accelerations, root to tip; gravity as the ground's acceleration −g.
  const SpatialVec a_ground(Vec3(0), -gravity_);
  for (int b = 0; b < n; ++b) {
    const ChainBody& body = bodies_[b];
    ws->a[b] = (body.parent < 0 ? a_ground : ws->a[body.parent]) + ws->c[b];
    if (body.u < 0) continue;
    if (body.held) {
      udot[body.u] = 0.0;
      continue;
    }
    const double qdd = (ws->uu[b] - Dot(ws->U[b], ws->a[b])) / ws->D[b];
    udot[body.u] = qdd;
    ws->a[b] += ws->S[b] * qdd;
  }
}

}  // namespace fesim::sim
