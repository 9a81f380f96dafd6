#include "graybox/models/inverse_dynamics_model.h"
#include "graybox/util/did_you_mean.h"

#include <stdexcept>
#include <utility>

#include "graybox/models/robot_blocks.h"

namespace graybox::models {

using expr::Expr;

Eigen::VectorXd InverseDynamicsModel::ParameterValues() const {
  Eigen::VectorXd p(NumParameters());
  for (int i = 0; i < NumParameters(); ++i) p[i] = parameters[i].value;
  return p;
}

int InverseDynamicsModel::ParameterIndex(const std::string& n) const {
  std::vector<std::string> names;
  for (int i = 0; i < NumParameters(); ++i) {
    if (parameters[i].name == n) return i;
    names.push_back(parameters[i].name);
  }
  const std::string hint = util::DidYouMean(n, names);
  throw std::invalid_argument("inverse-dynamics model '" + name + "': unknown parameter '" + n +
                              "'" + (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
}

Eigen::VectorXd InverseDynamicsModel::Torque(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                             const Eigen::VectorXd& qdd) const {
  return inverse_dynamics({q, qd, qdd, ParameterValues()})[0];
}

InverseDynamicsBuilder::InverseDynamicsBuilder(std::string name, const SerialChain& chain,
                                               const InverseDynamicsOptions& options)
    : model_(std::move(name)), dof_(chain.dof()) {
  const auto block = MakeInverseDynamicsBlock(
      chain, InverseDynamicsBlockOptions{options.parameters, options.physics_torque_signals});
  // The joint signals are the model's inputs, with the block's units and ranges.
  const std::vector<SignalInfo>& in = block->info().inputs;
  std::vector<std::string> inputs, outputs;
  for (const SignalInfo& s : in) {
    model_.AddInput(s.name, s.unit, s.description, s.typical_min, s.typical_max);
    inputs.push_back(s.name);
  }
  for (const SignalInfo& s : block->info().outputs) outputs.push_back(s.name);
  model_.AddBlock(options.rigid_body_instance, block, inputs, outputs);
  for (int j = 1; j <= dof_; ++j) model_.AddOutput("tau" + std::to_string(j));
}

void InverseDynamicsBuilder::CheckStatic(const std::string& instance, const Block& block) const {
  if (block.NumStates() > 0) {
    throw std::invalid_argument("inverse-dynamics model '" + name() + "': block '" + instance +
                                "' (" + block.info().type + ") has " +
                                std::to_string(block.NumStates()) +
                                " states; expected a static block (tau = g(q, qd, qdd, p)); use a "
                                "state-space Model for dynamic residuals");
  }
}

void InverseDynamicsBuilder::AddTorqueBlock(const std::string& instance,
                                            std::shared_ptr<const Block> block,
                                            const std::vector<std::string>& inputs,
                                            const std::vector<std::string>& outputs) {
  if (block) CheckStatic(instance, *block);
  model_.AddBlock(instance, std::move(block), inputs, outputs);
}

void InverseDynamicsBuilder::AddTorqueBlock(const std::string& instance, const std::string& type,
                                            const BlockOptions& options,
                                            const std::vector<std::string>& inputs,
                                            const std::vector<std::string>& outputs) {
  AddTorqueBlock(instance,
                 std::shared_ptr<const Block>(BlockRegistry::Global().Create(type, options)),
                 inputs, outputs);
}

void InverseDynamicsBuilder::Augment(const std::string& instance,
                                     std::shared_ptr<const Block> block,
                                     const std::vector<std::string>& inputs,
                                     const std::vector<std::string>& outputs) {
  if (block) CheckStatic(instance, *block);
  model_.Augment(instance, std::move(block), inputs, outputs);
}

void InverseDynamicsBuilder::Augment(const std::string& instance, const std::string& type,
                                     const BlockOptions& options,
                                     const std::vector<std::string>& inputs,
                                     const std::vector<std::string>& outputs) {
  Augment(instance, std::shared_ptr<const Block>(BlockRegistry::Global().Create(type, options)),
          inputs, outputs);
}

void InverseDynamicsBuilder::AddJointBlocks(const std::string& prefix, const std::string& type,
                                            const BlockOptions& options,
                                            const std::vector<int>& joints, bool augment) {
  std::vector<int> list = joints;
  if (list.empty()) {
    for (int j = 1; j <= dof_; ++j) list.push_back(j);
  }
  for (int j : list) {
    if (j < 1 || j > dof_) {
      throw std::invalid_argument("inverse-dynamics model '" + name() +
                                  "': expected joints in [1, " + std::to_string(dof_) + "], got " +
                                  std::to_string(j));
    }
    std::shared_ptr<const Block> block(BlockRegistry::Global().Create(type, options));
    if (block->NumInputs() != 1 || block->NumOutputs() != 1) {
      throw std::invalid_argument("inverse-dynamics model '" + name() + "': joint friction '" +
                                  type + "': expected a block with 1 input and 1 output, got " +
                                  std::to_string(block->NumInputs()) + " and " +
                                  std::to_string(block->NumOutputs()));
    }
    const std::string js = std::to_string(j);
    if (augment) {
      Augment(prefix + js, std::move(block), {"qd" + js}, {"tau" + js});
    } else {
      AddTorqueBlock(prefix + js, std::move(block), {"qd" + js}, {"tau" + js});
    }
  }
}

void InverseDynamicsBuilder::AddJointFriction(const std::string& prefix, const std::string& type,
                                              const BlockOptions& options,
                                              const std::vector<int>& joints) {
  AddJointBlocks(prefix, type, options, joints, false);
}

void InverseDynamicsBuilder::AugmentJointFriction(const std::string& prefix,
                                                  const std::string& type,
                                                  const BlockOptions& options,
                                                  const std::vector<int>& joints) {
  AddJointBlocks(prefix, type, options, joints, true);
}

InverseDynamicsModel InverseDynamicsBuilder::Build() const {
  const StateSpaceModel ss = model_.Build();
  InverseDynamicsModel m;
  m.name = ss.name;
  m.parameters = ss.parameters;
  const int n = dof_;
  for (int j = 0; j < n; ++j) {
    m.positions.push_back(ss.inputs[j]);
    m.velocities.push_back(ss.inputs[n + j]);
    m.accelerations.push_back(ss.inputs[2 * n + j]);
  }
  m.torques = ss.outputs;
  // Re-express y(x = {}, u = (q, qd, qdd), p) as tau(q, qd, qdd, p).
  const std::vector<Expr> q = expr::Expr::Symbols("q", n), qd = Expr::Symbols("qd", n),
                          qdd = Expr::Symbols("qdd", n);
  std::vector<Expr> p;
  for (const ModelParameter& par : ss.parameters) p.push_back(Expr::Symbol(par.name));
  std::vector<Expr> u = q;
  u.insert(u.end(), qd.begin(), qd.end());
  u.insert(u.end(), qdd.begin(), qdd.end());
  const std::vector<Expr> tau = ss.output.Call({{}, u, p})[0];
  m.inverse_dynamics = expr::Function(
      m.name + "_inverse_dynamics", {{"q", q}, {"qd", qd}, {"qdd", qdd}, {"p", p}}, {{"tau", tau}});
  return m;
}

}  // namespace graybox::models
