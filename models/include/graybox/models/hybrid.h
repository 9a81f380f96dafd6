// Hybrid physics/network models built as COMPOSITIONS of blocks: a physics block and network blocks
// (networks.h) connected through Model signals (model.h). No physics or network code lives here;
// each function only instantiates and wires registered blocks, so every structure inherits the
// blocks' tested derivatives and metadata, and its parameters are ordinary qualified Model
// parameters.
//
// Networks start at their NEUTRAL values (added with Model::Augment: zero output-layer and
// residual weights, random Glorot hidden weights; networks.h), so every hybrid initially equals
// its physics-only model exactly and training moves it away from there: the sim-to-real
// diagnosis compares structures from that common start.
//
// ==== Seed 000: forward dynamics of the KUKA KR300 R2500, Table 2 ==============================
// Every structure is a state-space Model named after the structure ("0.a PHY-only", ...) with
//     inputs    "tau_m1".."tau_m6"                 motor torques [N m, motor side]
//     states    "robot.q1".."robot.q6" [rad], "robot.qd1".."robot.qd6" [rad/s]
//               (block "robot", robot.joint_integrator: d/dt q = qd, d/dt qd = qdd; seed eq. 1)
//     outputs   "robot.q1".."robot.q6" (and "robot.qd1".."robot.qd6" with velocity_outputs)
//     signals   "qdd1".."qdd6" [rad/s^2], the accelerations every block adds to
// The physics block "phy" is robot.kuka_kr300_acceleration (robot_blocks.h): the roblue model
//     f_phy(x, v, tau_m) = M^-1 (u o tau_m - tau_f(v) - g(x) - tau_hwc(x) - C(x, v) v)    (eq. 4)
// with parameters "phy.l<i>.m", ... (66 inertial) and "phy.f_asym<i>", "phy.f_coul<i>",
// "phy.f_vis<i>" (18 friction). The network block is "ann". Writing x, v for q, qd:
//
//   0.a  PHY-only            qdd = f_phy(x, v, tau_m)
//   0.b  ANN-only            qdd = f_ann(x, v, tau_m)                        network.mlp 18 -> 6
//   1    ANN + PHY           qdd = f_ann(x, v, tau_m) + f_phy(x, v, tau_m)    network.mlp 18 -> 6
//   2    PHY -> ANN          qdd = f_phy + f_ann(x, v, tau_m, f_phy)          network.mlp 24 -> 6
//   3.a  PHY parts -> ANN    qdd = f_phy + f_ann(x, v, u tau_m, C v, g, tau_hwc,2)
//                                                                              network.mlp 31 -> 6
//   3.b  M^-1 PHY parts->ANN qdd = f_phy + f_ann(x, v, M^-1 u tau_m, M^-1 C v, M^-1 g,
//                                                M^-1 tau_hwc)                 network.mlp 36 -> 6
//   4    vel. -> ANN per joint
//                            qdd = M^-1 [f_ann,1(v_1); ...; f_ann,6(v_6)] + f_phy
//                                = M^-1 (u o tau_m + tau_ann - tau_f - g - tau_hwc - C v)
//                                                          network.per_joint, 6 x (1 -> 1)
//   5    (vel., all pos.) -> ANN per joint
//                            qdd = M^-1 [f_ann,1(v_1, x); ...; f_ann,6(v_6, x)] + f_phy
//                                                          network.velocity_positions, 6 x (7 -> 1)
// Wiring: f_phy is the output qdd<i> of "phy" (to signal "qdd<i>"); f_ann of "ann" adds to the same
// signals (1, 2, 3.a, 3.b) or, for 4 and 5, writes joint torques "tau_ann<i>" [N m] that "phy"
// reads through its joint-torque inputs (so the M^-1 of the seed's formula is the physics block's
// own solve). Model 2 reads f_phy from the copies "qdd_p<i>" (signals "qdd_phy<i>"); 3.a/3.b read
// the part outputs of "phy" (signals "tau_u<i>", "tau_c<i>", "tau_g<i>", "tau_hwc2" or
// "qdd_u<i>", "qdd_c<i>", "qdd_g<i>", "qdd_hwc<i>"). The network's inputs are in the order of the
// formulas above.
//
// Residual form (a decision). The seed writes Models 2, 3.a and 3.b as f_ann(...) alone; here the
// physics acceleration is also added, so that a network at neutral reproduces 0.a. For 2 this is
// the same model family: the MLPs have the seed's linear residual path, and shifting its weights
// on the f_phy inputs by the identity (in normalised units) turns one form into the other. For 3.b
// with the friction off (as in the seed, see below) f_phy = qdd_u - qdd_c - qdd_g - qdd_hwc is
// linear in the network's inputs, and the family is again the same. For 3.a f_phy =
// M^-1 (u tau_m - C v - g - tau_hwc) is a nonlinear function of the inputs, so the residual form
// is a richer family (the physics plus a learned correction).
// 3.a versus 3.b (a decision). Seed 000's text and model names say that 3.b "M^-1 . PHY parts ->
// ANN" feeds the terms premultiplied by M^-1 and 3.a "PHY parts -> ANN" omits the multiplication;
// its Table 2 prints the two formulas the other way round. We follow the names and the text.
// Structurally zero inputs are omitted as in the seed (only tau_hwc,2 of tau_hwc; M^-1 tau_hwc is
// not sparse, so 3.b keeps all six).
// Friction. "Aside from the 0.a PHY-only model, the friction term tau_f inside f_phy was not active
// in any other models" (seed 000 Sec. 2.1). With physics_friction = false the 18 friction
// parameters are set to 0 and fixed (the parameter count does not change); the default (true)
// keeps roblue's friction in every structure so that each equals 0.a at neutral.
// Network sizes. The seed uses two hidden layers of 1000 units (about 1.0e6 weights) for the
// single MLP and two of 100 per joint; the defaults here are smaller (64, 64 and 16, 16) because
// every weight is a symbol of the expression graph; set `hidden` / `joint_hidden` to the seed's.
//
// ==== Seed 001: residual inverse dynamics (Stäubli, GRU) ========================================
//     tau = tau_p(q, qd, qdd) + M_theta(q, qd, qdd, tau_p)                     (seed 001 eq. 1,
//     Fig. 3)
// A state-space Model with inputs "q<j>", "qd<j>", "qdd<j>" (the desired trajectory; the model is
// used as a feedforward), outputs "tau1".."taun" [N m], blocks
//     "phy"      robot.inverse_dynamics of the chain (rigid body with the motor-shaft inertias
//                I_a; parameters "phy.l<i>.m", ...) writing "tau<j>" and its copy "tau_p<j>";
//     "f<j>"     optional joint friction of a registered type (e.g. "friction.viscous"), reading
//                "qd<j>" and adding to "tau<j>" (seed 001's F term);
//     "gru1".."gru<L>"  network.gru layers (continuous-time GRU, networks.h). Layer 1 reads
//                (q, qd, qdd, tau_p) (seed 001's best feature set; without physics_torque_feature
//                (q, qd, qdd)); layer k > 1 reads the read-out of layer k-1 (signals "h<k-1>_<i>");
//                the last layer's read-out adds to "tau<j>". States "gru<k>.h<i>".
// Inner layers start at their nominal (Glorot) read-out, the last one at neutral, so at neutral
// tau is the physics torque whatever the GRU states. Differences from the seed: the seed stacks 4
// discrete GRU layers of 64 units on sequences of 128 samples; here the GRU is the continuous-time
// block (one explicit Euler step of length tau = T_s is the seed's cell) integrated along the
// trajectory, and tau_p excludes the friction blocks (a block output feeds one signal; the GRU can
// learn friction from qd, and seed 001 Table 5 shows it does).
#pragma once

#include <string>
#include <vector>

#include "graybox/models/block.h"
#include "graybox/models/model.h"
#include "graybox/models/regressor.h"
#include "graybox/models/serial_chain.h"

namespace graybox::models {

/// The structures of seed 000 Table 2.
enum class KukaHybridStructure {
  kPhysicsOnly,                // 0.a
  kNetworkOnly,                // 0.b
  kNetworkPlusPhysics,         // 1
  kPhysicsIntoNetwork,         // 2
  kPartsIntoNetwork,           // 3.a
  kScaledPartsIntoNetwork,     // 3.b
  kVelocityNetworkPerJoint,    // 4
  kVelocityPositionsPerJoint,  // 5
};

/// All eight, in the seed's order.
std::vector<KukaHybridStructure> AllKukaHybridStructures();
/// The seed's number ("0.a", ..., "5") and name ("PHY-only", ..., "(vel., all pos.)->ANN per
/// joint").
const char* Label(KukaHybridStructure structure);
const char* Name(KukaHybridStructure structure);

struct KukaHybridOptions {
  /// Physics: roblue's payload [kg] and whether the 66 inertial parameters are model parameters.
  double payload_kg = 150.0;
  bool inertial_parameters = true;
  /// roblue's joint friction inside f_phy (see "Friction" above).
  bool physics_friction = true;
  /// Hidden layer sizes of the single MLP (0.b, 1, 2, 3.a, 3.b); seed 000: {1000, 1000}.
  std::vector<int> hidden = {64, 64};
  /// Hidden layer sizes of every per-joint MLP (4, 5); seed 000: {100, 100}.
  std::vector<int> joint_hidden = {16, 16};
  /// Further network options ("seed", "activation", "linear_residual", "input_mean",
  /// "input_std", "output_mean", "output_std"; networks.h). "sizes", "joints" and "hidden" are
  /// set from the fields above (std::invalid_argument if given here).
  BlockOptions network;
  /// Also output the joint velocities (roblue's simulated data have y = [q, qd]).
  bool velocity_outputs = false;
};

/// One builder per structure (see the table above).
Model KukaPhysicsOnlyModel(const KukaHybridOptions& options = {});
Model KukaNetworkOnlyModel(const KukaHybridOptions& options = {});
Model KukaNetworkPlusPhysicsModel(const KukaHybridOptions& options = {});
Model KukaPhysicsIntoNetworkModel(const KukaHybridOptions& options = {});
Model KukaPartsIntoNetworkModel(const KukaHybridOptions& options = {});
Model KukaScaledPartsIntoNetworkModel(const KukaHybridOptions& options = {});
Model KukaVelocityNetworkPerJointModel(const KukaHybridOptions& options = {});
Model KukaVelocityPositionsPerJointModel(const KukaHybridOptions& options = {});
/// Dispatches to the builder of `structure`.
Model KukaHybridModel(KukaHybridStructure structure, const KukaHybridOptions& options = {});

struct ResidualInverseDynamicsOptions {
  /// Rotor (motor-shaft) inertias as parameters or constants.
  InertialParameterSet parameters = InertialParameterSet::kWithRotorInertia;
  /// GRU hidden-state size and number of stacked layers; seed 001: 64 and 4.
  int hidden_state = 64;
  int layers = 1;
  /// Layer 1 reads tau_p besides (q, qd, qdd).
  bool physics_torque_feature = true;
  /// Further options of the GRU blocks: "seed" (layer k uses seed + k - 1), "tau" (all layers),
  /// "input_mean"/"input_std" (layer 1), "output_mean"/"output_std" (last layer). "sizes" is set
  /// from the fields above.
  BlockOptions network;
  /// Registered type of a joint friction block added per joint at its nominal values (empty: no
  /// friction block), and its options (a prismatic joint's block gets motion = "prismatic" unless
  /// they set a motion).
  std::string joint_friction;
  BlockOptions joint_friction_options;
};

/// Seed 001's hybrid inverse dynamics for `chain` (see above).
Model ResidualInverseDynamicsModel(const SerialChain& chain,
                                   const ResidualInverseDynamicsOptions& options = {});

}  // namespace graybox::models
