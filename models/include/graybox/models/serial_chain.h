// SerialChain: the immutable description of a serial manipulator (an open kinematic chain of n
// rigid links, each driven by one revolute or prismatic joint), from which rigid_body_dynamics.h
// evaluates kinematics and dynamics on any scalar type.
//
// ---- Geometry: Denavit-Hartenberg parameters ------------------------------------------------
// Each Link carries one row (alpha, a, d, theta) of a DH table and a joint type. The joint variable
// q_i is ADDED to theta (revolute joint, q in rad) or to d (prismatic joint, q in m), so the
// constant `theta` (or `d`) of a moving joint is its joint offset:
//   revolute:   theta_i = q_i + theta,  d_i = d
//   prismatic:  theta_i = theta,        d_i = q_i + d
// Two conventions are supported (both as in Corke's Robotics Toolbox and SymPyBotics):
//
//   kStandard (Denavit-Hartenberg 1955, Spong/Siciliano): frame {i} is attached to the DISTAL end
//     of link i and joint i moves about/along z_{i-1}:
//        T^{i-1}_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i).
//   kModified (Craig 1986, "proximal"): frame {i} sits ON joint i and joint i moves about/along
//     z_i; row i holds (alpha_{i-1}, a_{i-1}, d_i, theta_i), i.e. the twist and length of the
//     PREVIOUS link:
//        T^{i-1}_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i).
// Frame {0} is the base frame; all link frames are right-handed. Units: alpha, theta in rad;
// a, d in m. ForwardKinematics returns T^0_i for every link frame {i} of the chosen convention.
// The cosines and sines of the constant angles (alpha, and theta of prismatic joints) are
// rounded to exactly 0 or +-1 when they are within 1e-15 of it, so alpha = pi/2 gives the exact
// zeros a symbolic derivation would give (this keeps symbolic graphs small; the change is below
// one ulp of the result).
//
// ---- Inertia --------------------------------------------------------------------------------
// Link i's inertial parameters are given IN ITS LINK FRAME {i} (of the chosen convention):
//   mass            m_i [kg], >= 0
//   center_of_mass  c_i [m], the centre of mass in {i} coordinates
//   inertia         a symmetric 3x3 tensor [kg m^2] in {i} axes, about the point named by
//   inertia_reference
//     kCenterOfMass  I_c, the tensor about the centre of mass (what CAD tools, URDF and Pinocchio
//                    report). Physically consistent when I_c is positive semi-definite and its
//                    principal moments satisfy the triangle inequality.
//     kLinkOrigin    I_O, the tensor about the ORIGIN of {i} (SymPyBotics' "L" parameters, which
//                    enter the equations of motion linearly together with l = m c).
//                    I_O = I_c + m (|c|^2 1 - c c^T) (parallel-axis theorem).
// Products of inertia are the tensor entries (I_xy = -sum m x y), not the "positive" products
// some tables list; the tensor must be symmetric.
//
// ---- Drives ---------------------------------------------------------------------------------
//   rotor_inertia  I_a,i = J_m,i * u_i^2 >= 0: the motor rotor (and gear input) inertia J_m
//                  reflected through the gear ratio u_i to the joint side [kg m^2; kg for a
//                  prismatic joint]. It is modelled with the "simplified" drive model of
//                  SymPyBotics: tau_i gains I_a,i * qdd_i, i.e. I_a,i is added to the diagonal of
//                  the mass matrix. The gyroscopic coupling of the spinning rotor with the
//                  carrying links (Sciavicco-Siciliano's complete model) is neglected; the error
//                  is of relative order 1/u_i.
//   gear_ratio     u_i = motor angle / joint angle (dimensionless, nonzero). Not used by the
//                  rigid-body recursions; actuator models use it to map motor torque to joint
//                  torque, tau_joint = u_i * tau_motor (see kuka_kr300.h).
//
// ---- Gravity --------------------------------------------------------------------------------
// `gravity` is the gravitational acceleration vector in base-frame coordinates [m/s^2], e.g.
// (0, 0, -9.81) for a floor-mounted robot whose base z axis points up. The recursions implement it
// as a fictitious base acceleration a_0 = -gravity.
//
// ---- Validity -------------------------------------------------------------------------------
// The constructor calls Validate(), which throws std::invalid_argument with a message of the form
// "SerialChain 'name': link 3: expected a mass >= 0 kg, got -1; hint: ..." when: the number of
// links is not in [1, kMaxDof]; any number is not finite; a mass or rotor inertia is negative; an
// inertia tensor is not symmetric (to 1e-9 relative); a gear ratio is zero. Physical consistency of
// the inertia (positive semi-definite tensor about the COM, triangle inequality) is NOT required -
// published parameter sets (e.g. the KUKA table of kuka_kr300.h read as origin inertias) violate it
// - but PhysicalConsistencyReport() reports it.
//
// ---- Precomputed form -----------------------------------------------------------------------
// For the recursions every link is re-expressed in its JOINT FRAME {J_i}: the frame whose z axis is
// the axis of joint i and that moves with link i. For the modified convention {J_i} = {i}; for the
// standard convention {J_i} = {i-1} * Rz(theta_i) Tz(d_i), i.e. {i} = {J_i} * Tx(a_i) Rx(alpha_i).
// In both conventions the transform from {J_{i-1}} to {J_i} is
//     Rx(alpha') Tx(a') Rz(theta_i) Tz(d_i)
// with (alpha', a') = (alpha_i, a_i) (modified) or (alpha_{i-1}, a_{i-1}) and (0, 0) for i = 1
// (standard). body(i) holds the link parameters in {J_i} about its origin (body_parameters.h).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/models/body_parameters.h"

namespace graybox::models {

/// Largest number of joints of a SerialChain. Every joint-space vector and matrix of the dynamics
/// has this compile-time maximum size, so evaluation on double never touches the heap.
inline constexpr int kMaxDof = 8;

enum class DhConvention { kStandard, kModified };
enum class JointType { kRevolute, kPrismatic };
enum class InertiaReference { kCenterOfMass, kLinkOrigin };

const char* ToString(DhConvention convention);
const char* ToString(JointType type);
const char* ToString(InertiaReference reference);

/// One link and the joint that drives it. See the file comment for meanings and units.
struct Link {
  JointType joint_type = JointType::kRevolute;
  double alpha = 0.0;  // [rad]
  double a = 0.0;      // [m]
  double d = 0.0;      // [m]; the joint offset of a prismatic joint
  double theta = 0.0;  // [rad]; the joint offset of a revolute joint

  double mass = 0.0;                                         // [kg]
  Eigen::Vector3d center_of_mass = Eigen::Vector3d::Zero();  // [m], in {i}
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();         // [kg m^2], in {i} axes
  InertiaReference inertia_reference = InertiaReference::kCenterOfMass;

  double rotor_inertia = 0.0;  // I_a = J_m u^2 [kg m^2 or kg]
  double gear_ratio = 1.0;     // u [-]
};

/// I_a = J_m * u^2: a motor-side inertia J_m [kg m^2] seen on the joint side of a gear u.
inline double ReflectedRotorInertia(double motor_inertia, double gear_ratio) {
  return motor_inertia * gear_ratio * gear_ratio;
}

/// The constant part of the transform {J_{i-1}} -> {J_i} (see "Precomputed form") and of the
/// transform {J_i} -> {i}, with snapped cosines and sines.
struct JointGeometry {
  JointType joint_type = JointType::kRevolute;
  // Rx(alpha') Tx(a') before the joint motion.
  double cos_alpha = 1.0, sin_alpha = 0.0, a = 0.0;
  // The joint motion Rz(theta) Tz(d): constant parts.
  double theta = 0.0, d = 0.0;
  double cos_theta = 1.0, sin_theta = 0.0;  // of the constant theta (used by prismatic joints)
  // {i} = {J_i} * Rot(link_rotation) Trans(link_origin) (identity for the modified convention).
  Eigen::Matrix3d link_rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d link_origin = Eigen::Vector3d::Zero();
};

class SerialChain {
 public:
  /// Builds and validates the chain (throws std::invalid_argument, see the file comment).
  SerialChain(std::string name, DhConvention convention, std::vector<Link> links,
              const Eigen::Vector3d& gravity);

  /// Throws std::invalid_argument "SerialChain '<name>': ... expected X, got Y" on bad input.
  /// Called by the constructor; calling it again on a constructed chain never throws.
  void Validate() const;

  const std::string& name() const { return name_; }
  int dof() const { return static_cast<int>(links_.size()); }
  DhConvention convention() const { return convention_; }
  const Link& link(int i) const { return links_.at(static_cast<std::size_t>(i)); }
  const std::vector<Link>& links() const { return links_; }
  const Eigen::Vector3d& gravity() const { return gravity_; }

  /// Link i's parameters in its joint frame {J_i}, about the origin of {J_i} (0-based i).
  const BodyParameters<double>& body(int i) const { return bodies_[static_cast<std::size_t>(i)]; }
  const std::array<BodyParameters<double>, kMaxDof>& bodies() const { return bodies_; }
  const JointGeometry& geometry(int i) const { return geometry_[static_cast<std::size_t>(i)]; }

  /// Link i's parameters in its link frame {i}, about the origin of {i}: (m, h = m c, I_O, I_a),
  /// SymPyBotics' (m, l, L, Ia).
  BodyParameters<double> LinkFrameParameters(int i) const;

  /// Empty when every link's inertia about its centre of mass is positive semi-definite and its
  /// principal moments satisfy the triangle inequality (to 1e-9 relative); otherwise one line per
  /// offending link, e.g. "link 1: inertia about the COM has eigenvalues (-19.5, 4.2, 31.0)".
  std::string PhysicalConsistencyReport() const;

 private:
  std::string name_;
  DhConvention convention_;
  std::vector<Link> links_;
  Eigen::Vector3d gravity_;
  std::array<BodyParameters<double>, kMaxDof> bodies_{};
  std::array<JointGeometry, kMaxDof> geometry_{};
};

}  // namespace graybox::models
