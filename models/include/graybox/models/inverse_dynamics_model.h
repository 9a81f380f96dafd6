// InverseDynamicsModel: the joint torques a robot needs for a motion,
//     tau = g(q, qd, qdd, p),
// as one symbolic Function, the model type of equation-error identification (IDIM: evaluate g on
// measured or filtered q and its derivatives and fit p to the measured torques;
// estimators/formulations/equation_error.h) and of feedforward control.
//
// Composition. g is the sum of a rigid-body part and additive torque blocks, composed exactly like
// a Model (model.h) through named signals:
//     signals "q<j>", "qd<j>", "qdd<j>"   the joint positions [rad or m], velocities and
//                                         accelerations, j = 1..n (the Function's inputs)
//     signal  "tau<j>"                    the joint torque [N m or N] (the Function's output): the
//                                         sum of everything written to it
//     signals "tau_p<j>"                  (option physics_torque_signals) a copy of the rigid-body
//                                         torque, for blocks that take it as a feature (seed 001's
//                                         residual network reads tau_p)
// The rigid-body part is the "robot.inverse_dynamics" block of the chain (robot_blocks.h),
// instance "arm" by default, whose parameters are the standard inertial parameters
// "arm.l<i>.m", ... (regressor.h); its torque is Y(q, qd, qdd) theta. Torque blocks read any of
// these signals and write "tau<j>": a friction block per joint reads "qd<j>" and writes "tau<j>"
// (in the INVERSE model friction ADDS to the torque the drive must deliver; the forward model
// subtracts the same block's output, which is why friction blocks output the torque with the sign
// of the velocity). Every block must be static (no states: std::invalid_argument otherwise); for
// recurrent residuals (seed 001's GRU) build a state-space Model instead (hybrid.h).
//
// Parameters are addressed by qualified names "<instance>.<parameter>" with values, bounds, scales
// and free/fixed flags as in StateSpaceModel; the Function's input "p" holds ALL of them in order
// (the estimator maps free ones). With rigid-body parameters and linear-in-parameter friction
// (viscous, Coulomb with fixed steepness, offset) g is linear in p, and IDIM-LS is one linear least
// squares problem.
//
// Augmentation: Augment() adds a torque block with every parameter that has a neutral value set to
// it, so the augmented model's torques are unchanged until the parameters move (the sim-to-real
// diagnosis adds candidate effects this way); AugmentJointFriction() does it for every joint.
//
//   InverseDynamicsBuilder b("kuka", KukaKr300R2500());
//   b.AddJointFriction("fv", "friction.viscous");   // instances fv1..fv6: tau_j += fv_j qd_j
//   InverseDynamicsModel m = b.Build();
//   // m.inverse_dynamics: inputs "q", "qd", "qdd", "p" -> output "tau"
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/expr/function.h"
#include "graybox/models/block.h"
#include "graybox/models/model.h"
#include "graybox/models/regressor.h"
#include "graybox/models/serial_chain.h"

namespace graybox::models {

/// The built inverse-dynamics model: one Function plus metadata. Immutable; cheap to copy.
struct InverseDynamicsModel {
  std::string name;
  /// "q1".."qn", "qd1"..., "qdd1"..., "tau1"... with units and typical ranges.
  std::vector<SignalInfo> positions, velocities, accelerations, torques;
  std::vector<ModelParameter> parameters;
  /// Inputs "q", "qd", "qdd" (NumJoints() each) and "p" (NumParameters()); output "tau".
  expr::Function inverse_dynamics;

  int NumJoints() const { return static_cast<int>(torques.size()); }
  int NumParameters() const { return static_cast<int>(parameters.size()); }
  /// Current parameter values in order.
  Eigen::VectorXd ParameterValues() const;
  /// Index of a parameter by qualified name; std::invalid_argument with a suggestion otherwise.
  int ParameterIndex(const std::string& name) const;
  /// tau at the current parameter values (convenience; allocates).
  Eigen::VectorXd Torque(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                         const Eigen::VectorXd& qdd) const;
};

struct InverseDynamicsOptions {
  /// Instance name of the rigid-body block (its parameters are "<instance>.l<i>.m", ...).
  std::string rigid_body_instance = "arm";
  /// Rotor inertias as parameters ("l<i>.Ia") or constants of the chain.
  InertialParameterSet parameters = InertialParameterSet::kWithRotorInertia;
  /// Offer the rigid-body torque as signals "tau_p<j>".
  bool physics_torque_signals = false;
};

class InverseDynamicsBuilder {
 public:
  /// Starts from the rigid-body inverse dynamics of `chain`.
  InverseDynamicsBuilder(std::string name, const SerialChain& chain,
                         const InverseDynamicsOptions& options = {});

  const std::string& name() const { return model_.name(); }
  int dof() const { return dof_; }

  /// Adds a static block. inputs[i] names the signal feeding block input i (see the file comment);
  /// outputs[i] the signal output i adds to ("-name" subtracts, "" leaves it unconnected).
  /// Throws std::invalid_argument for a block with states, a repeated instance, wrong counts.
  void AddTorqueBlock(const std::string& instance, std::shared_ptr<const Block> block,
                      const std::vector<std::string>& inputs,
                      const std::vector<std::string>& outputs);
  void AddTorqueBlock(const std::string& instance, const std::string& type,
                      const BlockOptions& options, const std::vector<std::string>& inputs,
                      const std::vector<std::string>& outputs);
  /// One single-input single-output block of `type` per joint in `joints` (1-based; empty = all),
  /// instance "<prefix><j>", reading "qd<j>" and adding to "tau<j>".
  void AddJointFriction(const std::string& prefix, const std::string& type,
                        const BlockOptions& options = {}, const std::vector<int>& joints = {});

  /// The same with every parameter of the new block that has a neutral value set to it.
  void Augment(const std::string& instance, std::shared_ptr<const Block> block,
               const std::vector<std::string>& inputs, const std::vector<std::string>& outputs);
  void Augment(const std::string& instance, const std::string& type, const BlockOptions& options,
               const std::vector<std::string>& inputs, const std::vector<std::string>& outputs);
  void AugmentJointFriction(const std::string& prefix, const std::string& type,
                            const BlockOptions& options = {}, const std::vector<int>& joints = {});

  /// Parameter access by qualified name (did-you-mean on unknown names).
  ModelParameter& Parameter(const std::string& name) { return model_.Parameter(name); }
  const std::vector<ModelParameter>& parameters() const { return model_.parameters(); }
  void SetParameter(const std::string& name, double value) { model_.SetParameter(name, value); }
  void Fix(const std::string& name) { model_.Fix(name); }
  void Free(const std::string& name) { model_.Free(name); }

  /// Builds the Function (std::invalid_argument for unknown signals, loops, stateful blocks).
  InverseDynamicsModel Build() const;

 private:
  void CheckStatic(const std::string& instance, const Block& block) const;
  void AddJointBlocks(const std::string& prefix, const std::string& type,
                      const BlockOptions& options, const std::vector<int>& joints, bool augment);

  Model model_;
  int dof_ = 0;
};

}  // namespace graybox::models
