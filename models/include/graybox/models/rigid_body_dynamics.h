// Rigid-body kinematics and dynamics of a SerialChain, written once for any scalar type.
//
// Every function is a template over Scalar and is instantiated for
//   double                 numerical evaluation. All joint-space vectors and matrices have the
//                          compile-time maximum size kMaxDof (JointVector, JointMatrix), every
//                          per-link quantity is a fixed-size 3-vector or 3x3 matrix, so nothing is
//                          allocated on the heap: the code is as fast as a hand-written recursion.
//   graybox::expr::Expr    symbolic evaluation: the same code builds an expression graph that a
//                          graybox::expr::Function compiles and differentiates.
// Elementary functions are called unqualified after `using std::sin;` so argument-dependent lookup
// finds the Expr overloads.
//
// Calling. Scalar is deduced from JointVector<Scalar> arguments; pass other Eigen vectors with an
// explicit template argument, e.g. InverseDynamics<double>(chain, q, qd, qdd) with Eigen::VectorXd.
// Every joint-space argument must have chain.dof() entries (std::invalid_argument "expected q of
// size 6, got 5" otherwise). Each function exists in two forms: with the chain's own (double)
// inertial parameters, and with an explicit BodyParameterArray<Scalar> (the parameters in the joint
// frames, see serial_chain.h) so the inertial parameters can themselves be symbols to identify.
//
// ---- Equations of motion --------------------------------------------------------------------
//   tau = M(q) qdd + C(q, qd) qd + g(q)
//   tau      joint torques [N m] (revolute) / forces [N] (prismatic) on link i from link i-1
//   M(q)     joint-space mass matrix, symmetric positive definite, INCLUDING the reflected rotor
//            inertias on its diagonal (M = M_rigid + diag(I_a), SymPyBotics' "simplified" drive
//            model, see serial_chain.h)
//   C qd     Coriolis and centrifugal torques (quadratic in qd)
//   g(q)     gravity torques; g = dU/dq with U the potential energy
// Units: q in rad or m, qd in rad/s or m/s, qdd in rad/s^2 or m/s^2.
//
// ---- Algorithms -----------------------------------------------------------------------------
// InverseDynamics: recursive Newton-Euler (Luh, Walker, Paul 1980) in the joint frames {J_i}
// (z = joint axis). Outward pass, with a_0 = -gravity, w_0 = dw_0 = 0, R_i and p_i the rotation
// and origin of {J_i} in {J_{i-1}}, z = (0, 0, 1):
//     a'_i  = R_i^T (a_{i-1} + dw_{i-1} x p_i + w_{i-1} x (w_{i-1} x p_i))
//     revolute:   w_i = R_i^T w_{i-1} + z qd_i,  a_i = a'_i,
//                 dw_i = R_i^T dw_{i-1} + (R_i^T w_{i-1}) x z qd_i + z qdd_i
//     prismatic:  w_i = R_i^T w_{i-1},  dw_i = R_i^T dw_{i-1},
//                 a_i = a'_i + 2 w_i x z qd_i + z qdd_i
// Inward pass with the body parameters (m, h = m c, I_O) about the origin of {J_i}:
//     f_i = m a_i + dw_i x h + w_i x (w_i x h)              (net force on link i)
//     n_i = I_O dw_i + w_i x (I_O w_i) + h x a_i             (net moment about the origin)
//     F_i = f_i + R_{i+1} F_{i+1},   N_i = n_i + R_{i+1} N_{i+1} + p_{i+1} x (R_{i+1} F_{i+1})
//     tau_i = z . N_i (revolute) or z . F_i (prismatic), plus I_a,i qdd_i.
// BiasForces = C qd + g is the same recursion with qdd = 0; CoriolisForces = C qd with qdd = 0 and
// no gravity; GravityTorques = g with qd = qdd = 0 (the terms that are known to vanish are
// skipped). Cost O(n).
//
// MassMatrix: composite-rigid-body algorithm (Walker and Orin 1982). The parameters of links
// i..n are summed in {J_i} (body_parameters.h gives the change of frame), the spatial force the
// composite body needs for a unit rate of joint i, (n, f) = (I_O z, z x h) (revolute) or
// (h x z, m z) (prismatic), gives M_ii = z . n (or z . f) + I_a,i, and carrying (n, f) inward
// (f <- R f, n <- R n + p x f) gives M_ji for j < i. Cost O(n^2); M is exactly symmetric.
//
// ForwardDynamics: qdd = M^-1 (tau - C qd - g), from MassMatrix, BiasForces and a symmetric
// positive definite solve: for double an unpivoted LDL^T on the fixed-maximum-size matrix
// (SolveSpd below); for Expr graybox::expr::SolveSpd (the same square-root-free LDL^T,
// symbolically). The overload resolution picks the right one.
//
// Energies: KineticEnergy = qd^T M qd / 2 (rotor energy included), PotentialEnergy
// U = -gravity . sum_i (m_i p_i + R_i h_i) (base frame), so tau = 0 conserves T + U.
#pragma once

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Core>

#include "graybox/expr/matrix.h"
#include "graybox/models/body_parameters.h"
#include "graybox/models/serial_chain.h"

namespace graybox::models {

/// A joint-space vector: at most kMaxDof entries, stored inline (no heap).
template <typename Scalar>
using JointVector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1, 0, kMaxDof, 1>;
/// A joint-space matrix: at most kMaxDof x kMaxDof, stored inline (no heap).
template <typename Scalar>
using JointMatrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxDof, kMaxDof>;
/// A homogeneous transform [R p; 0 0 0 1].
template <typename Scalar>
using Transform3 = Eigen::Matrix<Scalar, 4, 4>;
/// Per-link inertial parameters in the joint frames {J_i} (entries beyond dof() are unused).
template <typename Scalar>
using BodyParameterArray = std::array<BodyParameters<Scalar>, kMaxDof>;

/// T^0_i for every link frame {i} of the chain's DH convention, i = 1..dof (stored 0-based).
template <typename Scalar>
struct LinkTransforms {
  int dof = 0;
  std::array<Transform3<Scalar>, kMaxDof> base_from_link;
};

namespace internal {

template <typename Scalar>
struct JointPose {
  Matrix3<Scalar> rotation;  // axes of {J_i} in {J_{i-1}}
  Vector3<Scalar> origin;    // origin of {J_i} in {J_{i-1}}
};

template <typename Scalar>
JointPose<Scalar> ComputeJointPose(const JointGeometry& g, const Scalar& q) {
  using std::cos;
  using std::sin;
  Scalar ct, st, d;
  if (g.joint_type == JointType::kRevolute) {
    const Scalar theta = q + g.theta;
    ct = cos(theta);
    st = sin(theta);
    d = Scalar(g.d);
  } else {
    ct = Scalar(g.cos_theta);
    st = Scalar(g.sin_theta);
    d = q + g.d;
  }
  const double ca = g.cos_alpha, sa = g.sin_alpha;
  JointPose<Scalar> p;
  // Rx(alpha) Tx(a) Rz(theta) Tz(d).
  p.rotation(0, 0) = ct;
  p.rotation(0, 1) = -st;
  p.rotation(0, 2) = Scalar(0.0);
  p.rotation(1, 0) = ca * st;
  p.rotation(1, 1) = ca * ct;
  p.rotation(1, 2) = Scalar(-sa);
  p.rotation(2, 0) = sa * st;
  p.rotation(2, 1) = sa * ct;
  p.rotation(2, 2) = Scalar(ca);
  p.origin[0] = Scalar(g.a);
  p.origin[1] = -sa * d;
  p.origin[2] = ca * d;
  return p;
}

template <typename Scalar>
Vector3<Scalar> Cross(const Vector3<Scalar>& a, const Vector3<Scalar>& b) {
  Vector3<Scalar> c;
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
  return c;
}

// r v
template <typename Scalar>
Vector3<Scalar> Rotate(const Matrix3<Scalar>& r, const Vector3<Scalar>& v) {
  Vector3<Scalar> out;
  for (int i = 0; i < 3; ++i) out[i] = r(i, 0) * v[0] + r(i, 1) * v[1] + r(i, 2) * v[2];
  return out;
}

// r^T v
template <typename Scalar>
Vector3<Scalar> RotateBack(const Matrix3<Scalar>& r, const Vector3<Scalar>& v) {
  Vector3<Scalar> out;
  for (int i = 0; i < 3; ++i) out[i] = r(0, i) * v[0] + r(1, i) * v[1] + r(2, i) * v[2];
  return out;
}

template <typename Scalar>
Vector3<Scalar> Zero3() {
  return Vector3<Scalar>::Constant(Scalar(0.0));
}

template <typename Derived>
void CheckSize(const SerialChain& chain, const Eigen::MatrixBase<Derived>& v, const char* what,
               const char* who) {
  if (v.size() != chain.dof()) {
    throw std::invalid_argument(std::string(who) + ": expected " + what + " of size " +
                                std::to_string(chain.dof()) + " (the dof of chain '" +
                                chain.name() + "'), got " + std::to_string(v.size()));
  }
}

// The chain's own parameters as a BodyParameterArray<Scalar>: a reference for double, a converted
// copy otherwise.
template <typename Scalar>
struct ChainBodies {
  static BodyParameterArray<Scalar> Get(const SerialChain& chain) {
    BodyParameterArray<Scalar> out;
    for (int i = 0; i < chain.dof(); ++i) {
      out[static_cast<std::size_t>(i)] = chain.body(i).template Cast<Scalar>();
    }
    return out;
  }
};
template <>
struct ChainBodies<double> {
  static const BodyParameterArray<double>& Get(const SerialChain& chain) { return chain.bodies(); }
};

// The outward pass of the recursive Newton-Euler algorithm: the pose of every joint frame {J_i} in
// its parent and the angular velocity w_i, angular acceleration dw_i and origin acceleration a_i of
// {J_i}, in {J_i} axes (gravity included as the base acceleration -gravity when `with_gravity`).
// A null qd or qdd switches the velocity or acceleration terms off (they are skipped, not
// evaluated on zeros). Shared by the inverse dynamics and the regressor (regressor.h).
template <typename Scalar>
struct RneaKinematics {
  std::array<JointPose<Scalar>, kMaxDof> pose;
  std::array<Vector3<Scalar>, kMaxDof> w, dw, acc;
};

template <typename Scalar>
void RneaForwardPass(const SerialChain& chain, const JointVector<Scalar>& q,
                     const JointVector<Scalar>* qd, const JointVector<Scalar>* qdd,
                     bool with_gravity, RneaKinematics<Scalar>* kin) {
  const int n = chain.dof();
  std::array<JointPose<Scalar>, kMaxDof>& pose = kin->pose;
  std::array<Vector3<Scalar>, kMaxDof>&w = kin->w, &dw = kin->dw, &acc = kin->acc;
  Vector3<Scalar> w_prev = Zero3<Scalar>(), dw_prev = Zero3<Scalar>(), a_prev = Zero3<Scalar>();
  if (with_gravity) {
    for (int k = 0; k < 3; ++k) a_prev[k] = Scalar(-chain.gravity()[k]);
  }
  for (int i = 0; i < n; ++i) {
    const JointGeometry& g = chain.geometry(i);
    pose[i] = ComputeJointPose(g, q[i]);
    const Matrix3<Scalar>& r = pose[i].rotation;
    const Vector3<Scalar>& p = pose[i].origin;
    Vector3<Scalar> a_origin = a_prev;
    if (qdd != nullptr || qd != nullptr) a_origin += Cross(dw_prev, p);
    if (qd != nullptr) a_origin += Cross(w_prev, Cross(w_prev, p));
    Vector3<Scalar> wi = RotateBack(r, w_prev);
    Vector3<Scalar> dwi = RotateBack(r, dw_prev);
    Vector3<Scalar> ai = RotateBack(r, a_origin);
    if (g.joint_type == JointType::kRevolute) {
      if (qd != nullptr) {
        const Scalar& v = (*qd)[i];
        dwi[0] += wi[1] * v;  // (R^T w_prev) x z qd
        dwi[1] -= wi[0] * v;
        wi[2] += v;
      }
      if (qdd != nullptr) dwi[2] += (*qdd)[i];
    } else {
      if (qd != nullptr) {
        const Scalar two_v = 2.0 * (*qd)[i];
        ai[0] += wi[1] * two_v;  // 2 w x z qd
        ai[1] -= wi[0] * two_v;
      }
      if (qdd != nullptr) ai[2] += (*qdd)[i];
    }
    w[i] = wi;
    dw[i] = dwi;
    acc[i] = ai;
    w_prev = wi;
    dw_prev = dwi;
    a_prev = ai;
  }
}

// Recursive Newton-Euler with switches for the velocity, acceleration and gravity terms (a term
// that is switched off is skipped, not evaluated on zeros).
template <typename Scalar>
JointVector<Scalar> Rnea(const SerialChain& chain, const BodyParameterArray<Scalar>& bodies,
                         const JointVector<Scalar>& q, const JointVector<Scalar>* qd,
                         const JointVector<Scalar>* qdd, bool with_gravity) {
  const int n = chain.dof();
  RneaKinematics<Scalar> kin;
  RneaForwardPass(chain, q, qd, qdd, with_gravity, &kin);
  const std::array<JointPose<Scalar>, kMaxDof>& pose = kin.pose;
  const std::array<Vector3<Scalar>, kMaxDof>&w = kin.w, &dw = kin.dw, &acc = kin.acc;
  JointVector<Scalar> tau(n);
  Vector3<Scalar> f_child = Zero3<Scalar>(), n_child = Zero3<Scalar>();  // in the current frame
  for (int i = n - 1; i >= 0; --i) {
    const BodyParameters<Scalar>& b = bodies[static_cast<std::size_t>(i)];
    Vector3<Scalar> f = b.mass * acc[i];
    Vector3<Scalar> m = Rotate(b.inertia, dw[i]) + Cross(b.first_moment, acc[i]);
    if (qdd != nullptr || qd != nullptr) f += Cross(dw[i], b.first_moment);
    if (qd != nullptr) {
      f += Cross(w[i], Cross(w[i], b.first_moment));
      m += Cross(w[i], Rotate(b.inertia, w[i]));
    }
    f += f_child;
    m += n_child;
    tau[i] = chain.geometry(i).joint_type == JointType::kRevolute ? m[2] : f[2];
    if (qdd != nullptr) tau[i] += b.rotor_inertia * (*qdd)[i];
    f_child = Rotate(pose[i].rotation, f);
    n_child = Rotate(pose[i].rotation, m) + Cross(pose[i].origin, f_child);
  }
  return tau;
}

template <typename Scalar>
void AddBody(const BodyParameters<Scalar>& b, BodyParameters<Scalar>* sum) {
  sum->mass += b.mass;
  sum->first_moment += b.first_moment;
  sum->inertia += b.inertia;
}

}  // namespace internal

// ---- Kinematics -----------------------------------------------------------------------------

/// T^0_i of every DH link frame {i} (see serial_chain.h for the conventions).
template <typename Scalar>
LinkTransforms<Scalar> ForwardKinematics(const SerialChain& chain, const JointVector<Scalar>& q) {
  internal::CheckSize(chain, q, "q", "ForwardKinematics");
  LinkTransforms<Scalar> out;
  out.dof = chain.dof();
  Matrix3<Scalar> rot = Matrix3<Scalar>::Identity();  // of {J_i} in the base
  Vector3<Scalar> pos = internal::Zero3<Scalar>();
  for (int i = 0; i < chain.dof(); ++i) {
    const JointGeometry& g = chain.geometry(i);
    const internal::JointPose<Scalar> p = internal::ComputeJointPose(g, q[i]);
    pos = pos + internal::Rotate(rot, p.origin);
    rot = (rot * p.rotation).eval();
    const Matrix3<Scalar> link_rot = (rot * g.link_rotation.template cast<Scalar>()).eval();
    const Vector3<Scalar> link_pos =
        pos + internal::Rotate(rot, Vector3<Scalar>(g.link_origin.template cast<Scalar>()));
    Transform3<Scalar>& t = out.base_from_link[static_cast<std::size_t>(i)];
    t.setConstant(Scalar(0.0));
    t.template topLeftCorner<3, 3>() = link_rot;
    t.template topRightCorner<3, 1>() = link_pos;
    t(3, 3) = Scalar(1.0);
  }
  return out;
}

// ---- Dynamics with explicit body parameters -------------------------------------------------

/// tau = M(q) qdd + C(q, qd) qd + g(q) (recursive Newton-Euler, rotor inertia included).
template <typename Scalar>
JointVector<Scalar> InverseDynamics(const SerialChain& chain,
                                    const BodyParameterArray<Scalar>& bodies,
                                    const JointVector<Scalar>& q, const JointVector<Scalar>& qd,
                                    const JointVector<Scalar>& qdd) {
  internal::CheckSize(chain, q, "q", "InverseDynamics");
  internal::CheckSize(chain, qd, "qd", "InverseDynamics");
  internal::CheckSize(chain, qdd, "qdd", "InverseDynamics");
  return internal::Rnea(chain, bodies, q, &qd, &qdd, true);
}

/// C(q, qd) qd + g(q).
template <typename Scalar>
JointVector<Scalar> BiasForces(const SerialChain& chain, const BodyParameterArray<Scalar>& bodies,
                               const JointVector<Scalar>& q, const JointVector<Scalar>& qd) {
  internal::CheckSize(chain, q, "q", "BiasForces");
  internal::CheckSize(chain, qd, "qd", "BiasForces");
  return internal::Rnea<Scalar>(chain, bodies, q, &qd, nullptr, true);
}

/// C(q, qd) qd (no gravity).
template <typename Scalar>
JointVector<Scalar> CoriolisForces(const SerialChain& chain,
                                   const BodyParameterArray<Scalar>& bodies,
                                   const JointVector<Scalar>& q, const JointVector<Scalar>& qd) {
  internal::CheckSize(chain, q, "q", "CoriolisForces");
  internal::CheckSize(chain, qd, "qd", "CoriolisForces");
  return internal::Rnea<Scalar>(chain, bodies, q, &qd, nullptr, false);
}

/// g(q).
template <typename Scalar>
JointVector<Scalar> GravityTorques(const SerialChain& chain,
                                   const BodyParameterArray<Scalar>& bodies,
                                   const JointVector<Scalar>& q) {
  internal::CheckSize(chain, q, "q", "GravityTorques");
  return internal::Rnea<Scalar>(chain, bodies, q, nullptr, nullptr, true);
}

/// M(q), rotor inertias on the diagonal (composite-rigid-body algorithm).
template <typename Scalar>
JointMatrix<Scalar> MassMatrix(const SerialChain& chain, const BodyParameterArray<Scalar>& bodies,
                               const JointVector<Scalar>& q) {
  internal::CheckSize(chain, q, "q", "MassMatrix");
  const int n = chain.dof();
  std::array<internal::JointPose<Scalar>, kMaxDof> pose;
  for (int i = 0; i < n; ++i) pose[i] = internal::ComputeJointPose(chain.geometry(i), q[i]);
  BodyParameterArray<Scalar> composite;
  for (int i = 0; i < n; ++i) composite[i] = bodies[i];
  for (int i = n - 1; i > 0; --i) {
    internal::AddBody(TransformBodyParameters(pose[i].rotation, pose[i].origin, composite[i]),
                      &composite[i - 1]);
  }
  JointMatrix<Scalar> m(n, n);
  for (int i = 0; i < n; ++i) {
    const BodyParameters<Scalar>& c = composite[i];
    Vector3<Scalar> nv, fv;
    if (chain.geometry(i).joint_type == JointType::kRevolute) {
      nv = c.inertia.col(2);
      fv[0] = -c.first_moment[1];  // z x h
      fv[1] = c.first_moment[0];
      fv[2] = Scalar(0.0);
      m(i, i) = nv[2] + bodies[i].rotor_inertia;
    } else {
      nv[0] = c.first_moment[1];  // h x z
      nv[1] = -c.first_moment[0];
      nv[2] = Scalar(0.0);
      fv[0] = Scalar(0.0);
      fv[1] = Scalar(0.0);
      fv[2] = c.mass;
      m(i, i) = fv[2] + bodies[i].rotor_inertia;
    }
    for (int j = i; j > 0; --j) {
      const Vector3<Scalar> f_parent = internal::Rotate(pose[j].rotation, fv);
      nv = internal::Rotate(pose[j].rotation, nv) + internal::Cross(pose[j].origin, f_parent);
      fv = f_parent;
      m(i, j - 1) = chain.geometry(j - 1).joint_type == JointType::kRevolute ? nv[2] : fv[2];
      m(j - 1, i) = m(i, j - 1);
    }
  }
  return m;
}

// ---- Symmetric positive definite solves -----------------------------------------------------

/// Solves A x = b for symmetric positive definite A by an unpivoted LDL^T factorisation (only the
/// lower triangle of A is read). Generic version, used for double; allocation-free.
template <typename Scalar>
JointVector<Scalar> SolveSpd(const JointMatrix<Scalar>& a, const JointVector<Scalar>& b) {
  const Eigen::Index n = a.rows();
  JointMatrix<Scalar> l(n, n);  // unit lower factor, strictly-lower part used
  JointVector<Scalar> d(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    Scalar djj = a(j, j);
    for (Eigen::Index k = 0; k < j; ++k) djj -= l(j, k) * l(j, k) * d[k];
    d[j] = djj;
    for (Eigen::Index i = j + 1; i < n; ++i) {
      Scalar lij = a(i, j);
      for (Eigen::Index k = 0; k < j; ++k) lij -= l(i, k) * l(j, k) * d[k];
      l(i, j) = lij / djj;
    }
  }
  JointVector<Scalar> x = b;
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index k = 0; k < i; ++k) x[i] -= l(i, k) * x[k];
  }
  for (Eigen::Index i = 0; i < n; ++i) x[i] /= d[i];
  for (Eigen::Index i = n; i-- > 0;) {
    for (Eigen::Index k = i + 1; k < n; ++k) x[i] -= l(k, i) * x[k];
  }
  return x;
}

/// The symbolic version: graybox::expr::SolveSpd (same LDL^T, built as an expression graph).
inline JointVector<expr::Expr> SolveSpd(const JointMatrix<expr::Expr>& a,
                                        const JointVector<expr::Expr>& b) {
  const expr::ExprMatrix x = expr::SolveSpd(expr::ExprMatrix(a), expr::ExprMatrix(b));
  return JointVector<expr::Expr>(x.col(0));
}

/// qdd = M(q)^-1 (tau - C(q, qd) qd - g(q)).
template <typename Scalar>
JointVector<Scalar> ForwardDynamics(const SerialChain& chain,
                                    const BodyParameterArray<Scalar>& bodies,
                                    const JointVector<Scalar>& q, const JointVector<Scalar>& qd,
                                    const JointVector<Scalar>& tau) {
  internal::CheckSize(chain, tau, "tau", "ForwardDynamics");
  const JointMatrix<Scalar> m = MassMatrix(chain, bodies, q);
  const JointVector<Scalar> rhs = tau - BiasForces(chain, bodies, q, qd);
  return SolveSpd(m, rhs);
}

/// qd^T M(q) qd / 2 [J].
template <typename Scalar>
Scalar KineticEnergy(const SerialChain& chain, const BodyParameterArray<Scalar>& bodies,
                     const JointVector<Scalar>& q, const JointVector<Scalar>& qd) {
  internal::CheckSize(chain, qd, "qd", "KineticEnergy");
  const JointMatrix<Scalar> m = MassMatrix(chain, bodies, q);
  Scalar e = Scalar(0.0);
  for (int i = 0; i < chain.dof(); ++i) {
    Scalar row = Scalar(0.0);
    for (int j = 0; j < chain.dof(); ++j) row += m(i, j) * qd[j];
    e += qd[i] * row;
  }
  return 0.5 * e;
}

/// U(q) = -gravity . sum_i m_i c_i (c_i the centre of mass of link i in the base frame) [J].
template <typename Scalar>
Scalar PotentialEnergy(const SerialChain& chain, const BodyParameterArray<Scalar>& bodies,
                       const JointVector<Scalar>& q) {
  internal::CheckSize(chain, q, "q", "PotentialEnergy");
  Matrix3<Scalar> rot = Matrix3<Scalar>::Identity();
  Vector3<Scalar> pos = internal::Zero3<Scalar>();
  Vector3<Scalar> moment = internal::Zero3<Scalar>();  // sum m_i c_i
  for (int i = 0; i < chain.dof(); ++i) {
    const internal::JointPose<Scalar> p = internal::ComputeJointPose(chain.geometry(i), q[i]);
    pos = pos + internal::Rotate(rot, p.origin);
    rot = (rot * p.rotation).eval();
    const BodyParameters<Scalar>& b = bodies[static_cast<std::size_t>(i)];
    moment += b.mass * pos + internal::Rotate(rot, b.first_moment);
  }
  Scalar u = Scalar(0.0);
  for (int k = 0; k < 3; ++k) u -= chain.gravity()[k] * moment[k];
  return u;
}

// ---- Dynamics with the chain's own parameters -----------------------------------------------

template <typename Scalar>
JointVector<Scalar> InverseDynamics(const SerialChain& chain, const JointVector<Scalar>& q,
                                    const JointVector<Scalar>& qd, const JointVector<Scalar>& qdd) {
  return InverseDynamics(chain, internal::ChainBodies<Scalar>::Get(chain), q, qd, qdd);
}

template <typename Scalar>
JointVector<Scalar> BiasForces(const SerialChain& chain, const JointVector<Scalar>& q,
                               const JointVector<Scalar>& qd) {
  return BiasForces(chain, internal::ChainBodies<Scalar>::Get(chain), q, qd);
}

template <typename Scalar>
JointVector<Scalar> CoriolisForces(const SerialChain& chain, const JointVector<Scalar>& q,
                                   const JointVector<Scalar>& qd) {
  return CoriolisForces(chain, internal::ChainBodies<Scalar>::Get(chain), q, qd);
}

template <typename Scalar>
JointVector<Scalar> GravityTorques(const SerialChain& chain, const JointVector<Scalar>& q) {
  return GravityTorques(chain, internal::ChainBodies<Scalar>::Get(chain), q);
}

template <typename Scalar>
JointMatrix<Scalar> MassMatrix(const SerialChain& chain, const JointVector<Scalar>& q) {
  return MassMatrix(chain, internal::ChainBodies<Scalar>::Get(chain), q);
}

template <typename Scalar>
JointVector<Scalar> ForwardDynamics(const SerialChain& chain, const JointVector<Scalar>& q,
                                    const JointVector<Scalar>& qd, const JointVector<Scalar>& tau) {
  return ForwardDynamics(chain, internal::ChainBodies<Scalar>::Get(chain), q, qd, tau);
}

template <typename Scalar>
Scalar KineticEnergy(const SerialChain& chain, const JointVector<Scalar>& q,
                     const JointVector<Scalar>& qd) {
  return KineticEnergy(chain, internal::ChainBodies<Scalar>::Get(chain), q, qd);
}

template <typename Scalar>
Scalar PotentialEnergy(const SerialChain& chain, const JointVector<Scalar>& q) {
  return PotentialEnergy(chain, internal::ChainBodies<Scalar>::Get(chain), q);
}

}  // namespace graybox::models
