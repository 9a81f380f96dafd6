// Hybrid structures as block compositions; the equations and decisions are documented in
// include/graybox/models/hybrid.h.
#include "graybox/models/hybrid.h"

#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "graybox/models/robot_blocks.h"

namespace graybox::models {

namespace {

constexpr int kJoints = 6;

std::string Numbered(const std::string& prefix, int i) { return prefix + std::to_string(i); }

// prefix1..prefix<n> (1-based).
std::vector<std::string> Signals(const std::string& prefix, int n) {
  std::vector<std::string> s;
  for (int i = 1; i <= n; ++i) s.push_back(Numbered(prefix, i));
  return s;
}

std::vector<std::string> Concat(std::vector<std::vector<std::string>> parts) {
  std::vector<std::string> all;
  for (auto& p : parts) all.insert(all.end(), p.begin(), p.end());
  return all;
}

// The network options: the caller's extras plus the structural keys set here.
BlockOptions NetworkOptions(const BlockOptions& extra, const char* who,
                            const std::vector<std::string>& reserved) {
  for (const std::string& key : reserved) {
    if (extra.numbers.count(key) || extra.words.count(key)) {
      throw std::invalid_argument(std::string(who) + ": network option '" + key +
                                  "' is set by the structure; expected it unset, got a value "
                                  "(use the options' hidden sizes instead)");
    }
  }
  return extra;
}

// The common skeleton: motor-torque inputs, the joint integrator "robot" reading "qdd<i>", the
// outputs.
Model Skeleton(KukaHybridStructure structure, const KukaHybridOptions& options) {
  Model m(std::string(Label(structure)) + " " + Name(structure));
  for (int i = 1; i <= kJoints; ++i) {
    m.AddInput(Numbered("tau_m", i), "N m",
               "motor torque of joint " + std::to_string(i) + " (motor side)", -20.0, 20.0);
  }
  m.AddBlock("robot", MakeJointIntegratorBlock(kJoints), Signals("qdd", kJoints), {});
  for (int i = 1; i <= kJoints; ++i) m.AddOutput(Numbered("robot.q", i));
  if (options.velocity_outputs) {
    for (int i = 1; i <= kJoints; ++i) m.AddOutput(Numbered("robot.qd", i));
  }
  return m;
}

std::vector<std::string> StateSignals() {
  return Concat({Signals("robot.q", kJoints), Signals("robot.qd", kJoints)});
}

// Adds the physics block "phy" with its qdd outputs on "qdd<i>" and the given extra outputs, and
// switches its friction off if asked.
void AddPhysics(Model* m, const KukaHybridOptions& options, KukaBlockOptions block_options,
                const std::vector<std::string>& extra_outputs,
                const std::vector<std::string>& joint_torque_inputs = {}) {
  block_options.payload_kg = options.payload_kg;
  block_options.inertial_parameters = options.inertial_parameters;
  block_options.joint_torque_inputs = !joint_torque_inputs.empty();
  std::vector<std::string> inputs =
      Concat({StateSignals(), Signals("tau_m", kJoints), joint_torque_inputs});
  std::vector<std::string> outputs = Concat({Signals("qdd", kJoints), extra_outputs});
  m->AddBlock("phy", MakeKukaKr300AccelerationBlock(block_options), inputs, outputs);
  if (!options.physics_friction) {
    for (const char* f : {"f_asym", "f_coul", "f_vis"}) {
      for (int i = 1; i <= kJoints; ++i) {
        const std::string name = "phy." + Numbered(f, i);
        m->SetParameter(name, 0.0);
        m->Fix(name);
      }
    }
  }
}

// Adds the single MLP "ann" at neutral, reading `inputs` and adding to "qdd<i>".
void AddMlp(Model* m, const KukaHybridOptions& options, const std::vector<std::string>& inputs,
            const char* who) {
  BlockOptions o = NetworkOptions(options.network, who, {"sizes", "joints", "hidden"});
  std::vector<double> sizes = {static_cast<double>(inputs.size())};
  for (int h : options.hidden) sizes.push_back(h);
  sizes.push_back(kJoints);
  o.numbers["sizes"] = sizes;
  if (!o.words.count("output_unit")) o.words["output_unit"] = "rad/s^2";
  m->Augment("ann", "network.mlp", o, inputs, Signals("qdd", kJoints));
}

// Adds the per-joint networks "ann" at neutral, writing "tau_ann<i>".
void AddPerJoint(Model* m, const KukaHybridOptions& options, bool with_positions, const char* who) {
  BlockOptions o = NetworkOptions(options.network, who, {"sizes", "joints", "hidden"});
  o.numbers["joints"] = {static_cast<double>(kJoints)};
  o.numbers["hidden"] =
      std::vector<double>(options.joint_hidden.begin(), options.joint_hidden.end());
  std::vector<std::string> inputs = Signals("robot.qd", kJoints);
  if (with_positions) inputs = Concat({inputs, Signals("robot.q", kJoints)});
  m->Augment("ann", with_positions ? "network.velocity_positions" : "network.per_joint", o, inputs,
             Signals("tau_ann", kJoints));
}

}  // namespace

std::vector<KukaHybridStructure> AllKukaHybridStructures() {
  return {KukaHybridStructure::kPhysicsOnly,
          KukaHybridStructure::kNetworkOnly,
          KukaHybridStructure::kNetworkPlusPhysics,
          KukaHybridStructure::kPhysicsIntoNetwork,
          KukaHybridStructure::kPartsIntoNetwork,
          KukaHybridStructure::kScaledPartsIntoNetwork,
          KukaHybridStructure::kVelocityNetworkPerJoint,
          KukaHybridStructure::kVelocityPositionsPerJoint};
}

const char* Label(KukaHybridStructure structure) {
  switch (structure) {
    case KukaHybridStructure::kPhysicsOnly:
      return "0.a";
    case KukaHybridStructure::kNetworkOnly:
      return "0.b";
    case KukaHybridStructure::kNetworkPlusPhysics:
      return "1";
    case KukaHybridStructure::kPhysicsIntoNetwork:
      return "2";
    case KukaHybridStructure::kPartsIntoNetwork:
      return "3.a";
    case KukaHybridStructure::kScaledPartsIntoNetwork:
      return "3.b";
    case KukaHybridStructure::kVelocityNetworkPerJoint:
      return "4";
    case KukaHybridStructure::kVelocityPositionsPerJoint:
      return "5";
  }
  return "?";
}

const char* Name(KukaHybridStructure structure) {
  switch (structure) {
    case KukaHybridStructure::kPhysicsOnly:
      return "PHY-only";
    case KukaHybridStructure::kNetworkOnly:
      return "ANN-only";
    case KukaHybridStructure::kNetworkPlusPhysics:
      return "ANN + PHY";
    case KukaHybridStructure::kPhysicsIntoNetwork:
      return "PHY->ANN";
    case KukaHybridStructure::kPartsIntoNetwork:
      return "PHY parts->ANN";
    case KukaHybridStructure::kScaledPartsIntoNetwork:
      return "M^-1 PHY parts->ANN";
    case KukaHybridStructure::kVelocityNetworkPerJoint:
      return "vel.->ANN per joint";
    case KukaHybridStructure::kVelocityPositionsPerJoint:
      return "(vel., all pos.)->ANN per joint";
  }
  return "?";
}

Model KukaPhysicsOnlyModel(const KukaHybridOptions& options) {
  Model m = Skeleton(KukaHybridStructure::kPhysicsOnly, options);
  AddPhysics(&m, options, {}, {});
  return m;
}

Model KukaNetworkOnlyModel(const KukaHybridOptions& options) {
  Model m = Skeleton(KukaHybridStructure::kNetworkOnly, options);
  AddMlp(&m, options, Concat({StateSignals(), Signals("tau_m", kJoints)}), "KukaNetworkOnlyModel");
  return m;
}

Model KukaNetworkPlusPhysicsModel(const KukaHybridOptions& options) {
  Model m = Skeleton(KukaHybridStructure::kNetworkPlusPhysics, options);
  AddPhysics(&m, options, {}, {});
  AddMlp(&m, options, Concat({StateSignals(), Signals("tau_m", kJoints)}),
         "KukaNetworkPlusPhysicsModel");
  return m;
}

Model KukaPhysicsIntoNetworkModel(const KukaHybridOptions& options) {
  Model m = Skeleton(KukaHybridStructure::kPhysicsIntoNetwork, options);
  KukaBlockOptions b;
  b.feature_outputs = true;
  AddPhysics(&m, options, b, Signals("qdd_phy", kJoints));
  AddMlp(&m, options,
         Concat({StateSignals(), Signals("tau_m", kJoints), Signals("qdd_phy", kJoints)}),
         "KukaPhysicsIntoNetworkModel");
  return m;
}

Model KukaPartsIntoNetworkModel(const KukaHybridOptions& options) {
  Model m = Skeleton(KukaHybridStructure::kPartsIntoNetwork, options);
  KukaBlockOptions b;
  b.parts = DynamicsParts::kTorques;
  const std::vector<std::string> parts = Concat({Signals("tau_u", kJoints),
                                                 Signals("tau_c", kJoints),
                                                 Signals("tau_g", kJoints),
                                                 {"tau_hwc2"}});
  AddPhysics(&m, options, b, parts);
  AddMlp(&m, options, Concat({StateSignals(), parts}), "KukaPartsIntoNetworkModel");
  return m;
}

Model KukaScaledPartsIntoNetworkModel(const KukaHybridOptions& options) {
  Model m = Skeleton(KukaHybridStructure::kScaledPartsIntoNetwork, options);
  KukaBlockOptions b;
  b.parts = DynamicsParts::kAccelerations;
  const std::vector<std::string> parts =
      Concat({Signals("qdd_u", kJoints), Signals("qdd_c", kJoints), Signals("qdd_g", kJoints),
              Signals("qdd_hwc", kJoints)});
  AddPhysics(&m, options, b, parts);
  AddMlp(&m, options, Concat({StateSignals(), parts}), "KukaScaledPartsIntoNetworkModel");
  return m;
}

Model KukaVelocityNetworkPerJointModel(const KukaHybridOptions& options) {
  Model m = Skeleton(KukaHybridStructure::kVelocityNetworkPerJoint, options);
  AddPhysics(&m, options, {}, {}, Signals("tau_ann", kJoints));
  AddPerJoint(&m, options, false, "KukaVelocityNetworkPerJointModel");
  return m;
}

Model KukaVelocityPositionsPerJointModel(const KukaHybridOptions& options) {
  Model m = Skeleton(KukaHybridStructure::kVelocityPositionsPerJoint, options);
  AddPhysics(&m, options, {}, {}, Signals("tau_ann", kJoints));
  AddPerJoint(&m, options, true, "KukaVelocityPositionsPerJointModel");
  return m;
}

Model KukaHybridModel(KukaHybridStructure structure, const KukaHybridOptions& options) {
  switch (structure) {
    case KukaHybridStructure::kPhysicsOnly:
      return KukaPhysicsOnlyModel(options);
    case KukaHybridStructure::kNetworkOnly:
      return KukaNetworkOnlyModel(options);
    case KukaHybridStructure::kNetworkPlusPhysics:
      return KukaNetworkPlusPhysicsModel(options);
    case KukaHybridStructure::kPhysicsIntoNetwork:
      return KukaPhysicsIntoNetworkModel(options);
    case KukaHybridStructure::kPartsIntoNetwork:
      return KukaPartsIntoNetworkModel(options);
    case KukaHybridStructure::kScaledPartsIntoNetwork:
      return KukaScaledPartsIntoNetworkModel(options);
    case KukaHybridStructure::kVelocityNetworkPerJoint:
      return KukaVelocityNetworkPerJointModel(options);
    case KukaHybridStructure::kVelocityPositionsPerJoint:
      return KukaVelocityPositionsPerJointModel(options);
  }
  throw std::invalid_argument("KukaHybridModel: unknown structure");
}

Model ResidualInverseDynamicsModel(const SerialChain& chain,
                                   const ResidualInverseDynamicsOptions& options) {
  const char* who = "ResidualInverseDynamicsModel";
  if (options.hidden_state < 1 || options.layers < 1) {
    throw std::invalid_argument(
        std::string(who) + ": expected hidden_state >= 1 and layers >= 1, got " +
        std::to_string(options.hidden_state) + " and " + std::to_string(options.layers));
  }
  const int n = chain.dof();
  Model m("seed 001 residual inverse dynamics (" + chain.name() + ")");
  const auto physics = MakeInverseDynamicsBlock(
      chain, InverseDynamicsBlockOptions{options.parameters, options.physics_torque_feature});
  std::vector<std::string> joint_signals;
  for (const SignalInfo& s : physics->info().inputs) {
    m.AddInput(s.name, s.unit, s.description, s.typical_min, s.typical_max);
    joint_signals.push_back(s.name);
  }
  std::vector<std::string> physics_outputs = Signals("tau", n);
  if (options.physics_torque_feature)
    physics_outputs = Concat({physics_outputs, Signals("tau_p", n)});
  m.AddBlock("phy", physics, joint_signals, physics_outputs);
  if (!options.joint_friction.empty()) {
    for (int j = 1; j <= n; ++j) {
      // A prismatic joint's friction in its units (m/s, N) unless the options say otherwise.
      BlockOptions friction = options.joint_friction_options;
      if (chain.link(j - 1).joint_type == JointType::kPrismatic &&
          !friction.words.count("motion")) {
        friction.words["motion"] = "prismatic";
      }
      m.AddBlock(Numbered("f", j), options.joint_friction, friction, {Numbered("qd", j)},
                 {Numbered("tau", j)});
    }
  }
  // GRU layers.
  const BlockOptions& extra = options.network;
  NetworkOptions(extra, who, {"sizes"});
  std::uint32_t seed = 0;
  if (auto it = extra.numbers.find("seed"); it != extra.numbers.end() && it->second.size() == 1) {
    seed = static_cast<std::uint32_t>(it->second[0]);
  }
  std::vector<std::string> inputs = joint_signals;
  if (options.physics_torque_feature) inputs = Concat({inputs, Signals("tau_p", n)});
  for (int k = 1; k <= options.layers; ++k) {
    const bool last = k == options.layers;
    BlockOptions o;
    if (extra.numbers.count("tau")) o.numbers["tau"] = extra.numbers.at("tau");
    if (extra.numbers.count("seed")) o.numbers["seed"] = {static_cast<double>(seed + k - 1)};
    for (const char* key : {"input_mean", "input_std"}) {
      if (k == 1 && extra.numbers.count(key)) o.numbers[key] = extra.numbers.at(key);
    }
    for (const char* key : {"output_mean", "output_std"}) {
      if (last && extra.numbers.count(key)) o.numbers[key] = extra.numbers.at(key);
    }
    for (const auto& [key, value] : extra.numbers) {
      if (key != "tau" && key != "seed" && key.rfind("input_", 0) != 0 &&
          key.rfind("output_", 0) != 0) {
        o.numbers[key] = value;  // unknown keys: let the block reject them with a suggestion
      }
    }
    o.words = extra.words;
    if (last && !o.words.count("output_unit")) o.words["output_unit"] = "N m";
    const int n_out = last ? n : options.hidden_state;
    o.numbers["sizes"] = {static_cast<double>(inputs.size()),
                          static_cast<double>(options.hidden_state), static_cast<double>(n_out)};
    const std::string instance = Numbered("gru", k);
    const std::vector<std::string> outputs =
        last ? Signals("tau", n) : Signals("h" + std::to_string(k) + "_", n_out);
    if (last) {
      m.Augment(instance, "network.gru", o, inputs, outputs);
    } else {
      m.AddBlock(instance, "network.gru", o, inputs, outputs);
    }
    inputs = outputs;
  }
  for (int j = 1; j <= n; ++j) m.AddOutput(Numbered("tau", j));
  return m;
}

}  // namespace graybox::models
