// Robot blocks: the rigid-body dynamics of serial manipulators (rigid_body_dynamics.h) and the
// roblue KUKA KR300 R2500 model (kuka_kr300.h) as Blocks (block.h), with the inertial parameters
// (regressor.h) and the KUKA friction as block PARAMETERS, so a Model built from them can identify
// masses, first moments, inertias, rotor inertias and friction coefficients. Gravity, the DH
// geometry, the gear ratios and the counterbalance constants are fixed (known from the design).
//
// ---- Signals --------------------------------------------------------------------------------
// Joint i = 1..n: position "q<i>" [rad] (m for a prismatic joint), velocity "qd<i>" [rad/s]
// (m/s), acceleration "qdd<i>" [rad/s^2] (m/s^2), joint torque "tau<i>" [N m] (N). The KUKA blocks
// take MOTOR torques "tau_m<i>" [N m, motor side]; the joint receives u_i tau_m,i (u the gear
// ratio, kKukaGearRatios).
//
// ---- Parameters -----------------------------------------------------------------------------
// Inertial parameters, link after link, in the order and with the names of regressor.h:
//     "l<i>.m" [kg], "l<i>.mcx", "l<i>.mcy", "l<i>.mcz" [kg m], "l<i>.Ixx", "l<i>.Ixy", "l<i>.Ixz",
//     "l<i>.Iyy", "l<i>.Iyz", "l<i>.Izz" [kg m^2] (about the origin of the DH link frame {i}),
//     "l<i>.Ia" [kg m^2] (kg for a prismatic joint; only with InertialParameterSet::
//     kWithRotorInertia, the default; otherwise the chain's rotor inertia is a constant),
// so a block's inertial parameter vector IS the theta of regressor.h (InertialParameters(chain)
// are the nominal values). Bounds: masses, rotor inertias and the diagonal entries of I_O are >= 0
// (I_O,xx = sum m (y^2 + z^2)); the others are unbounded. They have no neutral value: they are the
// physics, not an added effect. Physical consistency (the inertia about the COM positive
// semi-definite, triangle inequality) is not imposed; see SerialChain::PhysicalConsistencyReport.
// KUKA friction (seed 000 eq. 5, joint side, roblue's values nominal, neutral 0):
//     tau_f,i = f_asym<i> + f_vis<i> qd_i + f_coul<i> tanh(qd_i / (1 rad/s)),
//     "f_asym<i>" [N m] (unbounded), "f_coul<i>" [N m] (>= 0), "f_vis<i>" [N m s/rad] (>= 0),
// in the order f_asym1..6, f_coul1..6, f_vis1..6 (seed 000's theta_f = [theta_asymm, theta_coul,
// theta_vis]), after the inertial parameters.
//
// ---- Block types ----------------------------------------------------------------------------
// "robot.serial_chain"  forward dynamics of a SerialChain as a state-space block,
//     d/dt q = qd,   d/dt qd = M(q, theta)^-1 (tau - C(q, qd, theta) qd - g(q, theta)),
//   states q1..qn, qd1..qn; inputs tau1..taun; outputs none (default), q1..qn, or q1..qn and
//   qd1..qdn (option). From C++: MakeSerialChainBlock(chain, options). From the registry: options
//   word "chain" = "test_arm" (default, RobotBlockTestArm()) or "kuka_kr300" (KukaKr300R2500(),
//   payload 150 kg, origin inertias), word "outputs" = "none" | "q" | "q_qd", number
//   "rotor_inertia" = 1 (default; "l<i>.Ia" are parameters) | 0.
//
// "robot.inverse_dynamics"  stateless inverse dynamics of a SerialChain,
//     tau = M(q, theta) qdd + C(q, qd, theta) qd + g(q, theta)   ( = Y(q, qd, qdd) theta ),
//   inputs q1..qn, qd1..qn, qdd1..qddn; outputs tau1..taun, and with the option feature_outputs a
//   copy "tau_p1".."tau_pn" of the same values (seed 001's physics torque tau_p fed to a residual
//   network as a feature while tau goes to the torque sum: a block output feeds one signal).
//   Registry options: "chain", "rotor_inertia" as above, number "feature_outputs" = 0 | 1.
//
// "robot.joint_integrator"  d/dt q = qd, d/dt qd = qdd (seed 000 eq. 1): states q1..qn, qd1..qn,
//   inputs qdd1..qddn, no parameters. Option "dof" (default 6). With an acceleration block it
//   forms a forward-dynamics model whose accelerations are signals other blocks can add to
//   (hybrid.h). Its signals carry the units and typical ranges of revolute KUKA joints (rad,
//   +-1.5 rad, +-2 rad/s); the equations hold for prismatic joints too (read m, m/s, m/s^2).
//
// "robot.kuka_kr300"  the roblue forward model (kuka_kr300.h) as a state-space block,
//     d/dt q = qd,
//     d/dt qd = M^-1 (u o tau_m + tau_j - tau_f(qd) - g(q) - tau_HWC(q2) e_2 - C(q, qd) qd),
//   states q1..q6, qd1..qd6; inputs tau_m1..tau_m6 and, with the option joint_torque_inputs,
//   "tau_j1".."tau_j6" [N m, joint side] (torques added at the joints by other blocks: friction
//   models, per-joint networks); outputs as "robot.serial_chain". Parameters: the 66 inertial
//   parameters (option inertial_parameters = 1, default; 0 keeps the table's values as constants)
//   and the 18 friction parameters. With nominal parameters it equals KukaForwardDynamics.
//   Registry options: numbers "payload" [kg] (150), "inertial_parameters" (1),
//   "joint_torque_inputs" (0); words "outputs", "inertia_reference" = "origin" (default, roblue)
//   | "center_of_mass". The shared registry suite checks it with its default options.
//
// "robot.kuka_kr300_acceleration"  the same model without states: inputs q1..q6, qd1..qd6,
//   tau_m1..tau_m6 (then tau_j1..6 with joint_torque_inputs); outputs qdd1..qdd6 (the right-hand
//   side above), then with the number option "feature_outputs" = 1 a copy "qdd_p1".."qdd_p6"
//   (seed 000 Model 2 feeds f_phy to a network while the residual form also adds it to the
//   acceleration; a block output feeds one signal), then with the word option "parts" the terms
//   of seed 000 eq. 4 that Models 3.a/3.b feed to a network (signals that are structurally zero
//   are omitted, as in the seed):
//     "torques"        u o tau_m ("tau_u<i>"), C qd ("tau_c<i>"), g ("tau_g<i>"), tau_HWC
//                      ("tau_hwc2", joint 2 only), all [N m];
//     "accelerations"  the same premultiplied by M^-1: "qdd_u<i>", "qdd_c<i>", "qdd_g<i>",
//                      "qdd_hwc<i>" (all six: M^-1 e_2 tau_HWC is not sparse), [rad/s^2].
//   (Seed 000 names the set with M^-1 "3.b M^-1 . PHY parts -> ANN" in its text but prints the
//   formulas of 3.a and 3.b the other way round in Table 2; see hybrid.h.) The shared registry
//   suite checks it with parts = accelerations, feature_outputs = 1 and inertial_parameters = 0
//   (the parts triple the derivative work); tests/models/robot_blocks_test.cc checks the
//   84-parameter form.
#pragma once

#include <memory>

#include "graybox/models/block.h"
#include "graybox/models/kuka_kr300.h"
#include "graybox/models/regressor.h"
#include "graybox/models/serial_chain.h"

namespace graybox::models {

inline constexpr char kSerialChainBlock[] = "robot.serial_chain";
inline constexpr char kInverseDynamicsBlock[] = "robot.inverse_dynamics";
inline constexpr char kJointIntegratorBlock[] = "robot.joint_integrator";
inline constexpr char kKukaKr300Block[] = "robot.kuka_kr300";
inline constexpr char kKukaKr300AccelerationBlock[] = "robot.kuka_kr300_acceleration";

/// Which joint signals a state-space robot block also offers as outputs (its states are signals
/// "<instance>.q<i>" in a Model anyway).
enum class JointOutputs { kNone, kPositions, kPositionsAndVelocities };

/// Extra outputs of the KUKA acceleration block (see the file comment).
enum class DynamicsParts { kNone, kTorques, kAccelerations };

struct SerialChainBlockOptions {
  JointOutputs outputs = JointOutputs::kNone;
  InertialParameterSet parameters = InertialParameterSet::kWithRotorInertia;
};

struct InverseDynamicsBlockOptions {
  InertialParameterSet parameters = InertialParameterSet::kWithRotorInertia;
  /// Adds the outputs "tau_p<i>", copies of "tau<i>".
  bool feature_outputs = false;
};

struct KukaBlockOptions {
  double payload_kg = 150.0;
  InertiaReference inertia_reference = InertiaReference::kLinkOrigin;
  /// The 66 inertial parameters are block parameters (else constants of the table).
  bool inertial_parameters = true;
  /// Adds the inputs "tau_j<i>" (joint-side torques).
  bool joint_torque_inputs = false;
  /// State-space block only.
  JointOutputs outputs = JointOutputs::kNone;
  /// Acceleration block only.
  DynamicsParts parts = DynamicsParts::kNone;
  /// Acceleration block only: adds the outputs "qdd_p<i>", copies of "qdd<i>".
  bool feature_outputs = false;
};

/// "robot.serial_chain" for `chain` (copied into the block).
std::shared_ptr<const Block> MakeSerialChainBlock(const SerialChain& chain,
                                                  const SerialChainBlockOptions& options = {});
/// "robot.inverse_dynamics" for `chain`.
std::shared_ptr<const Block> MakeInverseDynamicsBlock(
    const SerialChain& chain, const InverseDynamicsBlockOptions& options = {});
/// "robot.joint_integrator" with `dof` >= 1 joints (std::invalid_argument otherwise).
std::shared_ptr<const Block> MakeJointIntegratorBlock(int dof);
/// "robot.kuka_kr300" (state space).
std::shared_ptr<const Block> MakeKukaKr300Block(const KukaBlockOptions& options = {});
/// "robot.kuka_kr300_acceleration" (stateless).
std::shared_ptr<const Block> MakeKukaKr300AccelerationBlock(const KukaBlockOptions& options = {});

/// The chain the registry instantiates "robot.serial_chain" and "robot.inverse_dynamics" with by
/// default: a 3-DoF arm, standard DH (alpha, a, d, theta) = (pi/2, 0.1, 0.4, 0), (0, 0.5, 0, 0.3),
/// (0, 0, 0.1, 0) with joints revolute, revolute, prismatic; masses 5, 3, 1 kg; physically
/// consistent inertias about the centres of mass with every entry nonzero; rotor inertias 0.2,
/// 0.1 kg m^2 and 0.5 kg; gravity (0, 0, -9.81) m/s^2.
SerialChain RobotBlockTestArm();

}  // namespace graybox::models
