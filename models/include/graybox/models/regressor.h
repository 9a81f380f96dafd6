// The rigid-body dynamics of a SerialChain in linear-in-parameters form,
//     tau = Y(q, qd, qdd) theta,
// for equation-error identification of the inertial parameters (the inverse dynamic
// identification model, IDIM-LS: stack Y and the measured tau over many samples and solve the
// least-squares problem), and the map from a parameter vector theta to the BodyParameterArray the
// dynamics functions of rigid_body_dynamics.h take, so the same parameters can be symbols
// (graybox::expr::Expr) that an estimator identifies.
//
// ---- The standard inertial parameter vector -------------------------------------------------
// Per link i = 1..n, in its DH LINK FRAME {i} (serial_chain.h: distal frame for the standard
// convention, joint frame for the modified one) and about the ORIGIN of {i}:
//     k   name        meaning                                        unit
//     0   l<i>.m      mass m_i                                       kg
//     1   l<i>.mcx    first moment of mass h = m c, x component      kg m
//     2   l<i>.mcy    ... y component                                kg m
//     3   l<i>.mcz    ... z component                                kg m
//     4   l<i>.Ixx    inertia tensor about the origin of {i}, I_O    kg m^2
//     5   l<i>.Ixy    (tensor entries, I_xy = -sum m x y, not        kg m^2
//     6   l<i>.Ixz     the "positive" products of inertia)           kg m^2
//     7   l<i>.Iyy                                                   kg m^2
//     8   l<i>.Iyz                                                   kg m^2
//     9   l<i>.Izz                                                   kg m^2
//    10   l<i>.Ia     reflected rotor inertia I_a = J_m u^2          kg m^2 (kg for a prismatic
//                     (InertialParameterSet::kWithRotorInertia only)  joint)
// The links follow each other: theta = (theta_1, ..., theta_n), entry k of link i at index
// i * ParametersPerLink(set) + k (0-based i). This is SymPyBotics' "L, l, m, Ia" set in a different
// order; (m, h, I_O) enter the equations of motion linearly (body_parameters.h) and I_a adds
// I_a,i qdd_i to tau_i. With InertialParameterSet::kRigidBody the rotor inertias are not part of
// theta: BodiesFromInertialParameters takes them from the chain, and the regressor omits their
// columns, so then
//     tau = Y theta + diag(I_a) qdd.
// InertialParameters(chain, set) is the chain's own vector (so Y(chain...)
// InertialParameters(chain) equals InverseDynamics(chain, ...)).
//
// ---- The regressor --------------------------------------------------------------------------
// Y is n x (10 n) or n x (11 n), computed in O(n^2) without evaluating the dynamics once per
// parameter. The outward Newton-Euler pass gives the angular velocity w, angular acceleration dw
// and origin acceleration a of every joint frame (gravity as the base acceleration -gravity,
// rigid_body_dynamics.h). Re-expressed in the link frame {i} = {J_i} Rot(R_L) Trans(p_L)
// (identity for the modified convention; R_L = Rx(alpha_i), p_L = (a_i, 0, 0) for the standard
// one):
//     w' = R_L^T w,  dw' = R_L^T dw,  a' = R_L^T (a + dw x p_L + w x (w x p_L)).
// The net force and moment (about the origin of {i}) on link i are linear in its parameters,
//     f = m a' + dw' x h + w' x (w' x h),
//     n = I_O dw' + w' x (I_O w') + h x a',
// which gives a 6 x 10 matrix per link: the column of m is (a', 0), the column of h_k is
// (dw' x e_k + w' x (w' x e_k), e_k x a'), the column of the tensor entry I_rs is (0, L_rs(dw') +
// w' x L_rs(w')) with L_rs(v) = d (I_O v) / d I_rs. Each column is a spatial force; it is carried
// to {J_i} (f <- R_L f, n <- R_L n + p_L x f) and then inward through the joint frames (f <- R_j f,
// n <- R_j n + p_j x f), and its z component in {J_j} (n_z for a revolute joint, f_z for a
// prismatic one) is Y(j, column) for j = i, i-1, ..., 1. Y(i, 11 i + 10) = qdd_i. Generic over the
// scalar (double, or Expr for a symbolic regressor).
#pragma once

#include <array>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/models/body_parameters.h"
#include "graybox/models/rigid_body_dynamics.h"
#include "graybox/models/serial_chain.h"

namespace graybox::models {

/// Which inertial parameters theta holds per link: the 10 rigid-body ones, or those and the
/// reflected rotor inertia (11).
enum class InertialParameterSet { kRigidBody, kWithRotorInertia };

/// Index of each parameter within a link's block of theta (see the file comment).
enum InertialParameter : int {
  kMass = 0,
  kFirstMomentX = 1,
  kFirstMomentY = 2,
  kFirstMomentZ = 3,
  kInertiaXX = 4,
  kInertiaXY = 5,
  kInertiaXZ = 6,
  kInertiaYY = 7,
  kInertiaYZ = 8,
  kInertiaZZ = 9,
  kRotorInertia = 10,
};

inline constexpr int kRigidBodyParametersPerLink = 10;

inline int ParametersPerLink(InertialParameterSet set) {
  return set == InertialParameterSet::kWithRotorInertia ? kRigidBodyParametersPerLink + 1
                                                        : kRigidBodyParametersPerLink;
}
inline int NumInertialParameters(const SerialChain& chain, InertialParameterSet set) {
  return chain.dof() * ParametersPerLink(set);
}

/// "l<i>.m", "l<i>.mcx", ... for every link (1-based link numbers), in theta order.
std::vector<std::string> InertialParameterNames(const SerialChain& chain, InertialParameterSet set);
/// Units of the same entries ("kg", "kg m", "kg m^2"; rotor inertia "kg" for prismatic joints).
std::vector<std::string> InertialParameterUnits(const SerialChain& chain, InertialParameterSet set);

/// The chain's own theta: every link's SerialChain::LinkFrameParameters in the order above.
Eigen::VectorXd InertialParameters(
    const SerialChain& chain, InertialParameterSet set = InertialParameterSet::kWithRotorInertia);

/// Link parameters (m, h, I_O[, I_a]) from one link's block of theta (10 or 11 entries at
/// `link_theta`); without the rotor entry, `rotor_inertia` is used.
template <typename Scalar>
BodyParameters<Scalar> LinkBodyFromParameters(const Scalar* link_theta, InertialParameterSet set,
                                              double rotor_inertia) {
  BodyParameters<Scalar> b;
  b.mass = link_theta[kMass];
  for (int k = 0; k < 3; ++k) b.first_moment[k] = link_theta[kFirstMomentX + k];
  b.inertia(0, 0) = link_theta[kInertiaXX];
  b.inertia(0, 1) = b.inertia(1, 0) = link_theta[kInertiaXY];
  b.inertia(0, 2) = b.inertia(2, 0) = link_theta[kInertiaXZ];
  b.inertia(1, 1) = link_theta[kInertiaYY];
  b.inertia(1, 2) = b.inertia(2, 1) = link_theta[kInertiaYZ];
  b.inertia(2, 2) = link_theta[kInertiaZZ];
  b.rotor_inertia = set == InertialParameterSet::kWithRotorInertia ? link_theta[kRotorInertia]
                                                                   : Scalar(rotor_inertia);
  return b;
}

/// The BodyParameterArray (parameters in the joint frames {J_i}, what InverseDynamics,
/// MassMatrix, ForwardDynamics, ... of rigid_body_dynamics.h take) of the parameter vector
/// `theta` (NumInertialParameters(chain, set) entries). Linear in theta. With Scalar = Expr and
/// symbols in theta, the dynamics become functions of the inertial parameters.
template <typename Scalar>
BodyParameterArray<Scalar> BodiesFromInertialParameters(const SerialChain& chain,
                                                        const Scalar* theta,
                                                        InertialParameterSet set) {
  BodyParameterArray<Scalar> bodies;
  const int per_link = ParametersPerLink(set);
  for (int i = 0; i < chain.dof(); ++i) {
    const BodyParameters<Scalar> link = LinkBodyFromParameters(
        theta + static_cast<std::ptrdiff_t>(i) * per_link, set, chain.link(i).rotor_inertia);
    const auto k = static_cast<std::size_t>(i);
    if (chain.convention() == DhConvention::kModified) {
      bodies[k] = link;  // {J_i} = {i}
    } else {
      const JointGeometry& g = chain.geometry(i);
      bodies[k] = TransformBodyParameters(g.link_rotation, Vector3<double>(g.link_origin), link);
    }
  }
  return bodies;
}

/// The same from an Eigen vector; throws std::invalid_argument "expected theta of size 66, got 60".
template <typename Scalar>
BodyParameterArray<Scalar> BodiesFromInertialParameters(
    const SerialChain& chain, const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>& theta,
    InertialParameterSet set = InertialParameterSet::kWithRotorInertia) {
  if (theta.size() != NumInertialParameters(chain, set)) {
    throw std::invalid_argument("BodiesFromInertialParameters: expected theta of size " +
                                std::to_string(NumInertialParameters(chain, set)) + " for chain '" +
                                chain.name() + "', got " + std::to_string(theta.size()));
  }
  return BodiesFromInertialParameters(chain, theta.data(), set);
}

/// Y: at most kMaxDof rows and 11 kMaxDof columns, stored inline (no heap).
template <typename Scalar>
using RegressorMatrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxDof,
                                      (kRigidBodyParametersPerLink + 1) * kMaxDof>;

/// Y(q, qd, qdd) with tau = Y theta (+ diag(I_a) qdd for kRigidBody), see the file comment.
template <typename Scalar>
RegressorMatrix<Scalar> Regressor(
    const SerialChain& chain, const JointVector<Scalar>& q, const JointVector<Scalar>& qd,
    const JointVector<Scalar>& qdd,
    InertialParameterSet set = InertialParameterSet::kWithRotorInertia) {
  using internal::Cross;
  using internal::Rotate;
  using internal::RotateBack;
  internal::CheckSize(chain, q, "q", "Regressor");
  internal::CheckSize(chain, qd, "qd", "Regressor");
  internal::CheckSize(chain, qdd, "qdd", "Regressor");
  const int n = chain.dof();
  const int per_link = ParametersPerLink(set);
  internal::RneaKinematics<Scalar> kin;
  internal::RneaForwardPass(chain, q, &qd, &qdd, true, &kin);

  RegressorMatrix<Scalar> y(n, per_link * n);
  y.setConstant(Scalar(0.0));
  constexpr int kCols = kRigidBodyParametersPerLink;
  for (int i = 0; i < n; ++i) {
    const JointGeometry& g = chain.geometry(i);
    const bool offset_link_frame = chain.convention() == DhConvention::kStandard;
    Matrix3<Scalar> r_link = Matrix3<Scalar>::Identity();
    Vector3<Scalar> p_link = internal::Zero3<Scalar>();
    Vector3<Scalar> w = kin.w[i], dw = kin.dw[i], a = kin.acc[i];
    if (offset_link_frame) {
      for (int r = 0; r < 3; ++r) {
        p_link[r] = Scalar(g.link_origin[r]);
        for (int c = 0; c < 3; ++c) r_link(r, c) = Scalar(g.link_rotation(r, c));
      }
      const Vector3<Scalar> a_origin = a + Cross(dw, p_link) + Cross(w, Cross(w, p_link));
      w = RotateBack(r_link, w);
      dw = RotateBack(r_link, dw);
      a = RotateBack(r_link, a_origin);
    }
    // The 6 x 10 wrench matrix of link i in {i}: force rows f[c], moment rows m[c].
    std::array<Vector3<Scalar>, kCols> f, m;
    std::array<bool, kCols> has_force{};
    f[kMass] = a;
    m[kMass] = internal::Zero3<Scalar>();
    has_force[kMass] = true;
    const Scalar ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    for (int k = 0; k < 3; ++k) {
      Vector3<Scalar> e = internal::Zero3<Scalar>();
      e[k] = Scalar(1.0);
      // dw x e_k + w x (w x e_k) = dw x e_k + w w_k - e_k |w|^2;  e_k x a.
      Vector3<Scalar> fk = Cross(dw, e);
      for (int r = 0; r < 3; ++r) fk[r] += w[r] * w[k];
      fk[k] -= ww;
      f[kFirstMomentX + k] = fk;
      m[kFirstMomentX + k] = Cross(e, a);
      has_force[kFirstMomentX + k] = true;
    }
    // L_rs(v) = d (I v) / d I_rs for the entries xx, xy, xz, yy, yz, zz.
    const auto l_of = [&](int entry, const Vector3<Scalar>& v) {
      Vector3<Scalar> out = internal::Zero3<Scalar>();
      switch (entry) {
        case kInertiaXX:
          out[0] = v[0];
          break;
        case kInertiaXY:
          out[0] = v[1];
          out[1] = v[0];
          break;
        case kInertiaXZ:
          out[0] = v[2];
          out[2] = v[0];
          break;
        case kInertiaYY:
          out[1] = v[1];
          break;
        case kInertiaYZ:
          out[1] = v[2];
          out[2] = v[1];
          break;
        default:  // kInertiaZZ
          out[2] = v[2];
          break;
      }
      return out;
    };
    for (int c = kInertiaXX; c <= kInertiaZZ; ++c) {
      f[c] = internal::Zero3<Scalar>();
      m[c] = l_of(c, dw) + Cross(w, l_of(c, w));
    }
    // To {J_i}: f <- R_L f, n <- R_L n + p_L x f.
    if (offset_link_frame) {
      for (int c = 0; c < kCols; ++c) {
        m[c] = Rotate(r_link, m[c]);
        if (has_force[c]) {
          f[c] = Rotate(r_link, f[c]);
          m[c] += Cross(p_link, f[c]);
        }
      }
    }
    // Inward through the joint frames.
    for (int j = i; j >= 0; --j) {
      const bool revolute = chain.geometry(j).joint_type == JointType::kRevolute;
      for (int c = 0; c < kCols; ++c) y(j, per_link * i + c) = revolute ? m[c][2] : f[c][2];
      if (j == 0) break;
      const internal::JointPose<Scalar>& pose = kin.pose[static_cast<std::size_t>(j)];
      for (int c = 0; c < kCols; ++c) {
        m[c] = Rotate(pose.rotation, m[c]);
        if (has_force[c]) {
          f[c] = Rotate(pose.rotation, f[c]);
          m[c] += Cross(pose.origin, f[c]);
        }
      }
    }
  }
  if (set == InertialParameterSet::kWithRotorInertia) {
    for (int i = 0; i < n; ++i) y(i, per_link * i + kRotorInertia) = qdd[i];
  }
  return y;
}

}  // namespace graybox::models
