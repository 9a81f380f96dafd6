// BodyParameters: the inertial parameters of one rigid body in the form that is LINEAR in the
// dynamics, and the change of reference frame that keeps them linear.
//
// A rigid body is described, in a body-fixed frame {B} with origin O, by
//   m        mass                                         [kg]
//   h = m c  first moment of mass, c the centre of mass   [kg m]   (c in {B} coordinates, m)
//   I_O      rotational inertia tensor ABOUT THE ORIGIN O [kg m^2] (in {B} axes, symmetric)
//   I_a      reflected rotor inertia of the joint that drives the body [kg m^2, or kg for a
//            prismatic joint]; see serial_chain.h.
// Every rigid-body equation of motion is linear in (m, h, I_O) (this is the "standard" or
// "barycentric" parameter vector of identification; SymPyBotics calls (I_O, h, m, I_a)
// "L, l, m, Ia"). Inertia about the centre of mass is recovered by the parallel-axis theorem
//   I_O = I_c + m (|c|^2 1 - c c^T),      equivalently      I_c = I_O - (|h|^2 1 - h h^T) / m.
//
// Change of frame. If a frame {P} sees the origin of {B} at p (in {P} coordinates) and the axes
// of {B} as the columns of the rotation R, a point x of {B} is y = R x + p in {P}, and
//   m' = m,
//   h' = R h + m p,
//   I' = R I_O R^T + 2 (g.p) 1 - g p^T - p g^T + m (|p|^2 1 - p p^T),    g = R h,
// which follows from I = -sum m_k [y_k]x^2 with [y]x = R [x]x R^T + [p]x. The map is linear in the
// parameters, so it is written once for any scalar type (double, or graybox::expr::Expr when the
// parameters themselves are unknowns to identify). The rotor inertia is carried along unchanged.
#pragma once

#include <Eigen/Core>

namespace graybox::models {

template <typename Scalar>
using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
template <typename Scalar>
using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

template <typename Scalar>
struct BodyParameters {
  /// m [kg].
  Scalar mass = Scalar(0.0);
  /// h = m c [kg m], in the frame the parameters are expressed in.
  Vector3<Scalar> first_moment = Vector3<Scalar>::Constant(Scalar(0.0));
  /// I_O [kg m^2] about the frame origin, symmetric.
  Matrix3<Scalar> inertia = Matrix3<Scalar>::Constant(Scalar(0.0));
  /// I_a [kg m^2] (revolute) or [kg] (prismatic), added to the joint's mass-matrix diagonal.
  Scalar rotor_inertia = Scalar(0.0);

  /// Converts every entry to another scalar type (e.g. double to graybox::expr::Expr).
  template <typename Other>
  BodyParameters<Other> Cast() const {
    BodyParameters<Other> out;
    out.mass = Other(mass);
    for (int r = 0; r < 3; ++r) {
      out.first_moment[r] = Other(first_moment[r]);
      for (int c = 0; c < 3; ++c) out.inertia(r, c) = Other(inertia(r, c));
    }
    out.rotor_inertia = Other(rotor_inertia);
    return out;
  }
};

/// The parameters of a body given by its mass, centre of mass c (m) and inertia about the centre
/// of mass I_c, all in the frame of interest: h = m c, I_O = I_c + m (|c|^2 1 - c c^T).
inline BodyParameters<double> BodyFromCenterOfMassInertia(double mass,
                                                          const Eigen::Vector3d& center_of_mass,
                                                          const Eigen::Matrix3d& inertia_about_com,
                                                          double rotor_inertia = 0.0) {
  BodyParameters<double> b;
  b.mass = mass;
  b.first_moment = mass * center_of_mass;
  b.inertia =
      inertia_about_com + mass * (center_of_mass.squaredNorm() * Eigen::Matrix3d::Identity() -
                                  center_of_mass * center_of_mass.transpose());
  b.rotor_inertia = rotor_inertia;
  return b;
}

/// The inertia about the centre of mass, I_c = I_O - (|h|^2 1 - h h^T) / m; zero when m = 0.
inline Eigen::Matrix3d InertiaAboutCenterOfMass(const BodyParameters<double>& b) {
  if (b.mass == 0.0) return Eigen::Matrix3d::Zero();
  const Eigen::Vector3d& h = b.first_moment;
  return b.inertia - (h.squaredNorm() * Eigen::Matrix3d::Identity() - h * h.transpose()) / b.mass;
}

/// Expresses `body` (given in {B}) in the frame {P} that sees {B} with rotation `rotation`
/// (columns = axes of {B} in {P}) and origin `origin` (in {P}). See the formula above.
template <typename Scalar, typename RotScalar, typename PosScalar>
BodyParameters<Scalar> TransformBodyParameters(const Matrix3<RotScalar>& rotation,
                                               const Vector3<PosScalar>& origin,
                                               const BodyParameters<Scalar>& body) {
  BodyParameters<Scalar> out;
  out.mass = body.mass;
  out.rotor_inertia = body.rotor_inertia;
  Vector3<Scalar> g;
  for (int r = 0; r < 3; ++r) {
    g[r] = rotation(r, 0) * body.first_moment[0] + rotation(r, 1) * body.first_moment[1] +
           rotation(r, 2) * body.first_moment[2];
    out.first_moment[r] = g[r] + body.mass * origin[r];
  }
  // R I R^T.
  Matrix3<Scalar> ri;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      ri(r, c) = rotation(r, 0) * body.inertia(0, c) + rotation(r, 1) * body.inertia(1, c) +
                 rotation(r, 2) * body.inertia(2, c);
    }
  }
  const Scalar gp = g[0] * origin[0] + g[1] * origin[1] + g[2] * origin[2];
  const Scalar pp = origin[0] * origin[0] + origin[1] * origin[1] + origin[2] * origin[2];
  for (int r = 0; r < 3; ++r) {
    for (int c = r; c < 3; ++c) {
      Scalar v = ri(r, 0) * rotation(c, 0) + ri(r, 1) * rotation(c, 1) + ri(r, 2) * rotation(c, 2);
      v = v - g[r] * origin[c] - origin[r] * g[c] - body.mass * (origin[r] * origin[c]);
      if (r == c) v = v + 2.0 * gp + body.mass * pp;
      out.inertia(r, c) = v;
      out.inertia(c, r) = v;
    }
  }
  return out;
}

}  // namespace graybox::models
