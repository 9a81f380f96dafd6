// The KUKA KR300 R2500 (Quantec Ultra) industrial robot as modelled by roblue (Retzler et al.,
// "Learning-based augmentation of physics-based models: an industrial robot use case", Data-Centric
// Engineering 5, e12, 2024), with the CAD-based parameters of Weigand et al. (IROS 2021). Source
// of every number: ../shared/data/roblue_elabee/SOURCE.md and the roblue code it summarises.
//
// ---- Joint coordinates ----------------------------------------------------------------------
// The joint variable q of this file (and of the roblue data sets, y = [q, qd]) is the roblue
// "relative" angle. The DH ("global") angle is
//     q_global = q + kKukaJointOffsets,   kKukaJointOffsets = (0, -pi/2, +pi/2, 0, 0, 0) rad,
// and the standard DH table (alpha, a [m], d [m], theta) is
//     1:  pi/2   0.35   -0.675  q1_global
//     2:  0      1.15   -0.189  q2_global
//     3: -pi/2   0.041   0.189  q3_global + pi/2
//     4:  pi/2   0      -1      q4_global
//     5: -pi/2   0       0      q5_global
//     6:  pi     0      -0.24   q6_global
// so the SerialChain built here has theta offsets (0, -pi/2, pi, 0, 0, 0) and takes q directly.
// The joint limits of the data sheet (q2_global in [-140, -5] deg, ...) are in global angles.
// Gravity is (0, 0, +9.81) m/s^2: the DH base frame has z pointing DOWN ("the DH parameters
// correspond to the robot fixed to the ceiling").
//
// ---- Inertial parameters --------------------------------------------------------------------
// Masses m1..m5 = 395.40, 339.12, 105.21, 35.80, 31.46 kg; link 6 lumps the axis-6 mass 17.78 kg at
// z = -50 mm with the payload at z = +100 mm (in frame {6}): m6 = payload + 17.78, c6 = (0, 0, (100
// payload - 50 * 17.78) / m6 mm), and a zero inertia tensor. Centres of mass and inertia tensors
// (Lxx, Lyy, Lzz, Lxy, Lyz, Lxz) of links 1..5 are those of SOURCE.md, in the standard-DH link
// frames. Rotor inertias I_a = J_m u^2 with J_m = (0.00923, 0.0118, 0.0118, 0.00173, 0.00173,
// 0.00173) kg m^2 and the gear ratios u below.
//
// INERTIA REFERENCE POINT (the convention that matters and is easy to get wrong). roblue feeds the
// tensors to SymPyBotics as its "L" parameters together with l = m c. SymPyBotics' L is the inertia
// about the LINK-FRAME ORIGIN (its Newton-Euler recursion uses the spatial inertia
// [[L, [l]x], [-[l]x, m 1]] about the frame origin). So the roblue model - and therefore the
// simulated data set elabee_robot_ftsd.mat - treats these numbers as InertiaReference::kLinkOrigin,
// which is the default here. Physically they are almost certainly inertias about the centre of
// mass (CAD output): read as origin inertias, the inertia about the COM of links 1, 2, 4 and 6 is
// indefinite and that of link 5 violates the triangle inequality (e.g. link 1: I_c,yy = 29.80 -
// 395.4 (0.353^2 + 0.004^2) = -19.5 kg m^2; eigenvalues (-36.8, -28.0, 21.7) kg m^2), see
// SerialChain::PhysicalConsistencyReport(); read about the COM all six links are consistent. Use
// kCenterOfMass for the physically consistent reading; it is the one to test against MEASURED
// data (still unverified).
//
// ---- Drive, friction, counterbalance --------------------------------------------------------
// Motor torque tau_m [N m, motor side] reaches the joint as u o tau_m (elementwise), with gear
// ratios u = (1798/7, 1872/7, 757/3, 221, 5032/21, 206793/1340). Joint friction (roblue, joint
// side, N m):
//     tau_f,i = f_asym,i + f_vis,i qd_i + f_coul,i tanh(s qd_i),   s = 1 s/rad,
//     f_vis  = (5000, 5000, 5000, 1000, 1000, 1000) N m s/rad,
//     f_coul = (45.3125, 119.5625, 107.1875, 193.8125, 8.1875, 156.6875) N m,
//     f_asym = (14.0625, -21.875, -3.125, -40.625, -3.125, -46.875) N m.
// (roblue also computes f_a tanh(f_b qd) but leaves it out of the sum; so do we.)
// Hydraulic weight counterbalance (nitrogen spring on axis 2), with delta = q2_global + 95 deg:
//     spring length  s = sqrt(D^2 + k^2 - 2 D k cos(delta)),  extension dl = s - (D - k),
//     lever arm      h = D k sin(delta) / s,
//     pressure       p = Z R T m_N2 / (V_max - dl A)  (isothermal real gas),
//     torque         tau_HWC = h p A,
// Z R T m_N2 = 1.01 * 296.8 * 328 * 2 * 0.0795 J, A = pi (0.055^2 - 0.030^2) / 4 m^2,
// V_max = 9.6e-4 m^3, D = 0.8 m, k = 0.2 m. tau_HWC(-90 deg) = +632 N m, (-60 deg) = +4197 N m.
// It enters like a gravity torque on joint 2 (it is SUBTRACTED from the drive torque below).
//
// ---- The roblue forward model ---------------------------------------------------------------
//     qdd = M(q)^-1 (u o tau_m - tau_f(qd) - g(q) - tau_HWC(q2_global) e_2 - C(q, qd) qd)
// with M, C, g of the SerialChain (rigid_body_dynamics.h); the inverse model returns
//     tau_m = (M qdd + C qd + g + tau_HWC e_2 + tau_f) / u.
//
// ---- What has been checked ------------------------------------------------------------------
// Against SOURCE.md: every constant and the HWC example torques (tests/models/kuka_kr300_test.cc).
// Against the data roblue simulated with this model, elabee_robot_ftsd.mat (float32, dt = 4 ms;
// tests/models/kuka_roblue_data_test.cc):
//   - Sample alignment and integrator: y[k+1] = Phi(y[k], u[k]), the motor torque u[k] held
//     constant over [t_k, t_{k+1}] and Phi ONE classical RK4 step of 0.004 s (roblue: deepSI's
//     integrator_RK4 with intermediate_steps = 1). RK4 with 2 or 10 substeps is indistinguishable
//     at the data's precision. Rejected: u[k-1] or u[k+1] instead of u[k] (one-step velocity
//     residual 8000x larger), explicit Euler (4200x), and in NRMS at step 150 (below) Heun/RK2
//     1.3e-6, explicit Euler 2.6e-4, semi-implicit Euler 9.3e-4.
//   - One-step RMS residual 1.3e-8 rad (q) and 7.1e-9 rad/s (qd): the float32 storage floor.
//   - Simulations of 150 steps from every start, positions compared, each joint normalised by
//     its standard deviation over the split (estimators/analysis/metrics.h):
//     150-step NRMS (seed 000 eq. 7, the root mean square over every start, step 1..150 and
//     joint): 2.6e-7 on the test split (all 14850 starts), 2.7e-7 on training and validation;
//     NRMS at step 150 (the same over step 150 alone): 3.8e-7 on the test split, 4.1e-7
//     (training) and 3.9e-7 (validation). roblue itself reports as "150-step NRMS" the NRMS at
//     step 150 squared, without the root: 1.4e-13 on the test split.
//   - Conventions pinned down by the residual (each alternative raises the one-step velocity
//     residual by the factor given): inertia tensors about the LINK-FRAME ORIGIN (about the COM:
//     3.6e3x); friction ON as written above, s = 1 and no f_a tanh(f_b qd) term (friction off:
//     2.6e6x); HWC ON (off: 2.9e5x); payload 150 kg (200 kg: 2.0e5x); gravity (0, 0, +9.81);
//     joint offsets (0, -pi/2, +pi/2, 0, 0, 0).
// NOT checked against measured data: the inertia reference point (the origin reading, though it
// generated the roblue data, is physically inconsistent, see above), the friction values (roblue's
// nominal starting values), and whether the real counterbalance follows the formula.
#pragma once

#include <array>
#include <cmath>

#include "graybox/models/rigid_body_dynamics.h"
#include "graybox/models/serial_chain.h"

namespace graybox::models {

inline constexpr int kKukaDof = 6;
inline constexpr double kKukaPi = 3.14159265358979323846;

/// q_global - q (rad), see the file comment.
inline constexpr std::array<double, kKukaDof> kKukaJointOffsets = {0.0, -kKukaPi / 2, kKukaPi / 2,
                                                                   0.0, 0.0,          0.0};
/// Gear ratios u (motor angle / joint angle).
inline constexpr std::array<double, kKukaDof> kKukaGearRatios = {
    1798.0 / 7.0, 1872.0 / 7.0, 757.0 / 3.0, 221.0, 5032.0 / 21.0, 206793.0 / 1340.0};
/// Motor rotor inertias J_m [kg m^2] (I_a = J_m u^2).
inline constexpr std::array<double, kKukaDof> kKukaMotorInertias = {0.00923, 0.0118,  0.0118,
                                                                    0.00173, 0.00173, 0.00173};

/// The rigid-body chain of the KR300 R2500 with `payload_kg` (>= 0, throws otherwise) lumped into
/// link 6, and the CAD inertia tensors read about `cad_inertia_reference` (kLinkOrigin reproduces
/// roblue, see the file comment). Joint variable: the roblue q (not q_global).
SerialChain KukaKr300R2500(double payload_kg = 150.0,
                           InertiaReference cad_inertia_reference = InertiaReference::kLinkOrigin);

/// Joint friction coefficients (joint side), tau_f = f_asym + f_vis qd + f_coul tanh(s qd).
struct KukaFrictionParameters {
  std::array<double, kKukaDof> f_asym{};  // [N m]
  std::array<double, kKukaDof> f_vis{};   // [N m s/rad]
  std::array<double, kKukaDof> f_coul{};  // [N m]
  double tanh_sharpness = 1.0;            // s [s/rad]
};

/// roblue's nominal friction (the values it generated elabee_robot_ftsd.mat with).
KukaFrictionParameters KukaRoblueFriction();

/// The complete roblue model: chain, friction and counterbalance switches.
struct KukaKr300Model {
  SerialChain chain;
  KukaFrictionParameters friction;
  bool friction_enabled = true;
  bool hwc_enabled = true;
};

/// roblue's model with the given payload (roblue: 150 kg).
KukaKr300Model KukaKr300RoblueModel(double payload_kg = 150.0);

/// The default roblue model (payload 150 kg), built once (thread-safe).
const KukaKr300Model& DefaultKukaKr300Model();

/// Hydraulic weight-counterbalance torque on joint 2 [N m] as a function of the GLOBAL (DH) angle
/// q2_global = q2 - pi/2 [rad]. See the file comment for the formula.
template <typename Scalar>
Scalar KukaHwcTorque(const Scalar& q2_global) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  constexpr double kGas = 1.01 * 296.8 * 328.0 * (2.0 * 0.0795);             // Z R T m_N2 [J]
  constexpr double kArea = kKukaPi * (0.055 * 0.055 - 0.030 * 0.030) / 4.0;  // [m^2]
  constexpr double kVolumeMax = 2.0 * 0.00048;                               // [m^3]
  constexpr double kOffset = 95.0 * kKukaPi / 180.0;                         // [rad]
  constexpr double kD = 0.8, kK = 0.2, kL = kD - kK;                         // [m]
  const Scalar delta = q2_global + kOffset;
  const Scalar spring = sqrt(kD * kD + kK * kK - (2.0 * kD * kK) * cos(delta));
  const Scalar extension = spring - kL;
  const Scalar lever = (kD * kK) * sin(delta) / spring;
  const Scalar pressure = kGas / (kVolumeMax - kArea * extension);
  return lever * pressure * kArea;
}

/// tau_f(qd) = f_asym + f_vis o qd + f_coul o tanh(s qd) [N m], joint side.
template <typename Scalar>
JointVector<Scalar> KukaFriction(const JointVector<Scalar>& qd,
                                 const KukaFrictionParameters& params) {
  using std::tanh;
  if (qd.size() != kKukaDof) {
    throw std::invalid_argument("KukaFriction: expected qd of size 6, got " +
                                std::to_string(qd.size()));
  }
  JointVector<Scalar> tau(kKukaDof);
  for (int i = 0; i < kKukaDof; ++i) {
    const auto k = static_cast<std::size_t>(i);
    tau[i] = params.f_asym[k] + params.f_vis[k] * qd[i] +
             params.f_coul[k] * tanh(params.tanh_sharpness * qd[i]);
  }
  return tau;
}

/// The joint torque the model's non-rigid-body terms subtract: tau_f(qd) + tau_HWC e_2.
template <typename Scalar>
JointVector<Scalar> KukaNonRigidTorques(const KukaKr300Model& model, const JointVector<Scalar>& q,
                                        const JointVector<Scalar>& qd) {
  JointVector<Scalar> tau =
      model.friction_enabled
          ? KukaFriction(qd, model.friction)
          : JointVector<Scalar>(JointVector<Scalar>::Constant(kKukaDof, Scalar(0.0)));
  if (model.hwc_enabled) tau[1] += KukaHwcTorque(Scalar(q[1] + kKukaJointOffsets[1]));
  return tau;
}

/// The roblue forward model: qdd [rad/s^2] from q [rad], qd [rad/s] (roblue coordinates) and the
/// MOTOR torques tau_motor [N m]:
///   qdd = M^-1 (u o tau_m - tau_f(qd) - g(q) - tau_HWC e_2 - C qd).
template <typename Scalar>
JointVector<Scalar> KukaForwardDynamics(const KukaKr300Model& model, const JointVector<Scalar>& q,
                                        const JointVector<Scalar>& qd,
                                        const JointVector<Scalar>& tau_motor) {
  internal::CheckSize(model.chain, tau_motor, "tau_motor", "KukaForwardDynamics");
  internal::CheckSize(model.chain, q, "q", "KukaForwardDynamics");
  JointVector<Scalar> tau = -KukaNonRigidTorques(model, q, qd);
  for (int i = 0; i < kKukaDof; ++i) {
    tau[i] += kKukaGearRatios[static_cast<std::size_t>(i)] * tau_motor[i];
  }
  return ForwardDynamics(model.chain, q, qd, tau);
}

/// KukaForwardDynamics with DefaultKukaKr300Model().
template <typename Scalar>
JointVector<Scalar> KukaForwardDynamics(const JointVector<Scalar>& q, const JointVector<Scalar>& qd,
                                        const JointVector<Scalar>& tau_motor) {
  return KukaForwardDynamics(DefaultKukaKr300Model(), q, qd, tau_motor);
}

/// The roblue inverse model: the motor torques [N m] that produce qdd,
///   tau_m = (M qdd + C qd + g + tau_HWC e_2 + tau_f) / u.
template <typename Scalar>
JointVector<Scalar> KukaInverseDynamics(const KukaKr300Model& model, const JointVector<Scalar>& q,
                                        const JointVector<Scalar>& qd,
                                        const JointVector<Scalar>& qdd) {
  JointVector<Scalar> tau =
      InverseDynamics(model.chain, q, qd, qdd) + KukaNonRigidTorques(model, q, qd);
  for (int i = 0; i < kKukaDof; ++i) tau[i] /= kKukaGearRatios[static_cast<std::size_t>(i)];
  return tau;
}

/// KukaInverseDynamics with DefaultKukaKr300Model().
template <typename Scalar>
JointVector<Scalar> KukaInverseDynamics(const JointVector<Scalar>& q, const JointVector<Scalar>& qd,
                                        const JointVector<Scalar>& qdd) {
  return KukaInverseDynamics(DefaultKukaKr300Model(), q, qd, qdd);
}

}  // namespace graybox::models
