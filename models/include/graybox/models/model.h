// Model: blocks connected through named signals, built into the state-space model the estimators
// consume,
//     xdot = f(x, u, p),    y = h(x, u, p),
// with named states, inputs, outputs and parameters.
//
// Signals. A signal is a named scalar. Its value is the sum of everything that contributes to it:
// an external input of the same name (measured data driving the model), and the outputs of blocks
// connected to it (a connection written "-name" subtracts). Every block state is also a signal,
// named "<instance>.<state>", so a friction block reads the velocity state of the arm it brakes.
// Blocks read signals through their inputs; a block is evaluated after every block that contributes
// to a signal it reads. A cycle of such dependencies without a state in between is an algebraic
// loop and is rejected.
//
//   Model m("drive");
//   m.AddInput("u", "N m", "motor torque");
//   m.AddBlock("load", "mechanics.inertia", {}, {"torque"}, {});   // state load.omega
//   ... connect "u" into "torque", a friction block reading "load.omega" and writing "-torque"
//   m.AddOutput("load.omega");
//   StateSpaceModel ss = m.Build();
//
// Internal signals. The built model exposes every named signal, not only its states and declared
// outputs (StateSpaceModel::signals): each with its unit, the physical role its blocks declare
// (SignalRole in block.h: position, velocity, force, ...), the blocks that produce it, and its
// value as an expression of (x, u, p). SignalFunction() turns any of them into a Function, and
// EvaluateSignals() evaluates them along a trajectory, so a caller can see the force of a friction
// block or the velocity a block reads wherever the model has been simulated or measured.
//
// Parameters are addressed as "<instance>.<parameter>" (the problem files use the same names);
// each starts at its block's nominal value, free unless the block declares it a known setting
// (ParameterInfo::fixed_by_default), and may be fixed or freed, re-bounded and re-scaled.
//
// Augmentation. Augment() adds a block exactly like AddBlock() but starts every parameter that has
// a neutral value at it, so the augmented model's outputs equal the original ones until the
// parameters move (blocks whose effect vanishes at neutral: friction terms, residual networks with
// zero output weights). InsertOnSignal() puts a single-input single-output block in series on a
// signal (an input delay on a motor torque, a dead zone): every reader of the signal then reads the
// block's output instead; InsertOnInput() on a model input before the blocks that add to it.
// InsertForReaders() does the same for chosen block instances only (a dead zone in the drive that
// reads a controller output the data also log), and InsertOnOutput() for a measured channel only (a
// sensor offset: the physics keeps reading the true signal, the channel keeps its name). These are
// what the sim-to-real gap diagnosis does for every candidate effect; augmentation.h states each of
// them as data (Augmentation, ApplyAugmentation), which a problem file writes as a
// [[model.augment]] table.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "graybox/expr/function.h"
#include "graybox/models/block.h"

namespace graybox::models {

/// A parameter of a model: the block's metadata, its qualified name and its current setting.
struct ModelParameter {
  std::string name;  // "<instance>.<parameter>"
  ParameterInfo info;
  double value = 0.0;
  bool free = true;
  /// Typical magnitude for optimizer scaling (defaults to max(|nominal|, 1e-3 * something > 0)).
  double scale = 1.0;
  /// Current bounds (start as the block's; may be narrowed).
  double lower = 0.0;
  double upper = 0.0;
};

/// Where the value of a model signal comes from.
enum class SignalSource {
  kInput,        // an external input (data), possibly with block outputs added to it
  kState,        // a block state "<instance>.<state>"
  kBlockOutput,  // the sum of the block outputs connected to it
};

/// One named signal of a built model. A signal is a scalar: the sum of its external input (if
/// declared), its state (if it is one) and every block output connected to it ("-name" subtracts),
/// as described at the top of this file. Block outputs left unconnected ("") are not signals.
struct SignalDescription {
  /// The qualified name ("force", "load.qd", "friction.out"), unit (SI, as declared by the input,
  /// the state, or the first block output connected to it), description, typical range, and role.
  /// The role is the first one set among: the declaring input, state or block output, the other
  /// block outputs connected to it, then the inputs of the blocks that read it (so an external
  /// input read as "qd" by a friction block is a velocity). kNone when none declares one.
  SignalInfo info;
  SignalSource source = SignalSource::kBlockOutput;
  /// The block instances that produce it, in the order they were added: the owner of a state, or
  /// every block whose output is connected to the signal. Empty for an external input no block
  /// adds to.
  std::vector<std::string> blocks;
  /// Number of scalar entries; always 1 (a vector quantity, such as a robot's joint torques, is one
  /// signal per entry). Kept so that callers do not assume it.
  int size = 1;
  /// The value as an expression of the model's symbols x, u and p (the inputs of `dynamics`).
  expr::Expr value;
};

/// The built model: symbolic Functions plus metadata. Immutable; cheap to copy (Functions and
/// expressions are shared).
struct StateSpaceModel {
  std::string name;
  std::vector<SignalInfo> states;   // qualified names "<instance>.<state>"
  std::vector<SignalInfo> inputs;   // external inputs
  std::vector<SignalInfo> outputs;  // the declared output signals
  std::vector<ModelParameter> parameters;
  /// True when any block is stiff (integrate with an implicit method).
  bool stiff = false;
  /// Inputs "x", "u", "p"; output "xdot".
  expr::Function dynamics;
  /// Inputs "x", "u", "p"; output "y".
  expr::Function output;
  /// Every named signal of the model: the external inputs (in declaration order), then the states
  /// (in state order), then the other signals written by block outputs (in the order the blocks
  /// were added). Names are unique.
  std::vector<SignalDescription> signals;

  int NumStates() const { return static_cast<int>(states.size()); }
  int NumInputs() const { return static_cast<int>(inputs.size()); }
  int NumOutputs() const { return static_cast<int>(outputs.size()); }
  int NumParameters() const { return static_cast<int>(parameters.size()); }
  int NumSignals() const { return static_cast<int>(signals.size()); }
  /// Current parameter values in order.
  Eigen::VectorXd ParameterValues() const;
  /// Index of a parameter, state, input or output by name; std::invalid_argument with a
  /// did-you-mean suggestion otherwise.
  int ParameterIndex(const std::string& name) const;
  int StateIndex(const std::string& name) const;
  int InputIndex(const std::string& name) const;
  int OutputIndex(const std::string& name) const;
  /// Index of a signal in `signals`; std::invalid_argument with a did-you-mean suggestion
  /// otherwise.
  int SignalIndex(const std::string& name) const;

  /// The signals `names` (in that order; repeats allowed, empty allowed) as a Function with inputs
  /// "x" (NumStates()), "u" (NumInputs()), "p" (NumParameters()) and one output "signals" of
  /// names.size() entries, in the signals' units. Like `dynamics`, the Function is immutable:
  /// evaluate it concurrently with one Workspace per thread (Function::MakeWorkspace()); its
  /// derivatives come from Function::Jacobian etc. Compiling it costs about as much as compiling
  /// `output`, so build it once and reuse it. Throws std::invalid_argument for an unknown name:
  /// "model 'm': unknown signal 'x'; did you mean 'y'?".
  expr::Function SignalFunction(const std::vector<std::string>& names) const;

  /// The signals `names` along a trajectory: row k of the N x names.size() result is the signals
  /// at x = X.row(k) (X is N x NumStates()), u = U.row(k) (U is N x NumInputs()) and the parameter
  /// vector p (NumParameters()), the same for every row. Builds SignalFunction(names) on every
  /// call (reuse SignalFunction for repeated evaluation). Throws std::invalid_argument for an
  /// unknown name or wrong sizes ("expected X, got Y"). A non-finite value (a division by a zero
  /// mass, an overflow) is returned as it is, not thrown; `status`, when given, reports the first
  /// one (EvalStatus::ok is false and `message` names it).
  Eigen::MatrixXd EvaluateSignals(const std::vector<std::string>& names, const Eigen::MatrixXd& X,
                                  const Eigen::MatrixXd& U, const Eigen::VectorXd& p,
                                  expr::EvalStatus* status = nullptr) const;
};

class Model {
 public:
  explicit Model(std::string name);

  const std::string& name() const { return name_; }

  /// Declares an external input signal (driven by data).
  void AddInput(const std::string& signal, const std::string& unit,
                const std::string& description = "", double typical_min = -1.0,
                double typical_max = 1.0);

  /// Adds a block instance. inputs[i] names the signal feeding block input i ("" leaves the input
  /// unconnected: it reads 0, e.g. the external torque of a joint nothing loads); outputs[i] names
  /// the signal block output i adds to ("-name" subtracts; "" leaves the output unconnected).
  /// Its parameters start at their nominal values, free except those the block declares
  /// fixed_by_default (known settings such as controller gains; Free() them to identify them).
  /// Throws std::invalid_argument for a repeated instance name, wrong connection counts, or a
  /// name containing '.'.
  void AddBlock(const std::string& instance, std::shared_ptr<const Block> block,
                const std::vector<std::string>& inputs, const std::vector<std::string>& outputs);
  /// The same with a block created from the global registry.
  void AddBlock(const std::string& instance, const std::string& type, const BlockOptions& options,
                const std::vector<std::string>& inputs, const std::vector<std::string>& outputs);

  /// AddBlock, then every parameter of the new instance that has a neutral value is set to it.
  void Augment(const std::string& instance, std::shared_ptr<const Block> block,
               const std::vector<std::string>& inputs, const std::vector<std::string>& outputs);
  void Augment(const std::string& instance, const std::string& type, const BlockOptions& options,
               const std::vector<std::string>& inputs, const std::vector<std::string>& outputs);

  /// Replaces the block of `instance` by `block` with the same connections: another
  /// configuration of the same element (a joint in its backlash form). The new block must have
  /// as many inputs and outputs and the same states (names, in order). Its parameters whose
  /// local names the old block had keep their value, free flag, scale and bounds; the others
  /// start at their neutral values (their nominal values when they have none), free unless
  /// fixed_by_default. Throws std::invalid_argument, leaving the model unchanged, for an unknown
  /// instance (did-you-mean) or a block that differs in connections or states.
  void ReplaceBlock(const std::string& instance, std::shared_ptr<const Block> block);
  void ReplaceBlock(const std::string& instance, const std::string& type,
                    const BlockOptions& options);

  /// Puts a one-input one-output block in series on `signal`: the block reads `signal`, its
  /// output is the new signal "<instance>.out", and every block input and model output that read
  /// `signal` reads "<instance>.out" instead. Parameters start at their neutral values. The
  /// overloads with a type string create the block from the global registry. The insert
  /// operations throw std::invalid_argument, leaving the model unchanged, for an unknown signal,
  /// a block with the wrong number of connections, or an instance name AddBlock rejects.
  void InsertOnSignal(const std::string& signal, const std::string& instance,
                      std::shared_ptr<const Block> block,
                      const std::vector<std::string>& extra_inputs = {});
  void InsertOnSignal(const std::string& signal, const std::string& instance,
                      const std::string& type, const BlockOptions& options = {});

  /// Puts a one-input one-output block in series on the model input `input` alone, before the
  /// blocks that add to the same signal (a transport delay of a motor torque command that friction
  /// blocks subtract from): the block reads the raw input, its output is the new signal
  /// "<instance>.out", and every block output that added to (or subtracted from) `input` adds to
  /// "<instance>.out" instead, so "<instance>.out" = block(input) + those contributions; every
  /// block input and model output that read `input` reads "<instance>.out". On an input nothing
  /// adds to it is InsertOnSignal. Parameters start at their neutral values. A block with more
  /// inputs reads `extra_inputs` on inputs 2, 3, ... (the first-order hold reads the input's
  /// rate). Throws std::invalid_argument, leaving the model unchanged, for a name that is not a
  /// model input, a block without 1 + extra_inputs.size() inputs and 1 output, or an instance
  /// name AddBlock rejects.
  void InsertOnInput(const std::string& input, const std::string& instance,
                     std::shared_ptr<const Block> block,
                     const std::vector<std::string>& extra_inputs = {});

  /// Puts a one-input one-output block in series on the measured channel `output` only (a sensor
  /// error): the block reads the channel's signal and the channel then reports "<instance>.out"
  /// while keeping its name (StateSpaceModel::outputs[j].name, the name data, output weights and
  /// reports use). Block inputs that read the signal keep reading it, except those of the
  /// instances listed in `readers` (a controller that reads the same sensor), which read
  /// "<instance>.out" too. Parameters start at their neutral values. Throws
  /// std::invalid_argument for an unknown output or reader, or a block that is not 1-in 1-out.
  void InsertOnOutput(const std::string& output, const std::string& instance,
                      std::shared_ptr<const Block> block,
                      const std::vector<std::string>& readers = {});
  void InsertOnOutput(const std::string& output, const std::string& instance,
                      const std::string& type, const BlockOptions& options,
                      const std::vector<std::string>& readers = {});

  /// Puts a one-input one-output block in series on `signal` for the block instances `readers`
  /// only (an actuator error on the command one block acts on): the block reads `signal`, and
  /// those instances' inputs that read `signal` read "<instance>.out" instead; other readers and
  /// the model outputs keep reading `signal` (a logged command stays the command). Parameters
  /// start at their neutral values. A block with more inputs reads `extra_inputs` on inputs 2, 3,
  /// ... (a payload's gravity reads the axis position). Throws std::invalid_argument for an
  /// unknown signal or reader, or a block that does not have 1 + extra_inputs.size() inputs and
  /// 1 output.
  void InsertForReaders(const std::string& signal, const std::string& instance,
                        std::shared_ptr<const Block> block, const std::vector<std::string>& readers,
                        const std::vector<std::string>& extra_inputs = {});
  void InsertForReaders(const std::string& signal, const std::string& instance,
                        const std::string& type, const BlockOptions& options,
                        const std::vector<std::string>& readers,
                        const std::vector<std::string>& extra_inputs = {});

  /// Declares an output (a measured channel) as a signal name.
  void AddOutput(const std::string& signal);

  /// One block instance and its connections, as added.
  struct Connections {
    std::string instance;
    std::string type;                  // BlockInfo::type
    std::vector<std::string> inputs;   // the signal each block input reads
    std::vector<std::string> outputs;  // the connection of each output ("-name", "name", "")
  };
  /// Every block instance in the order added.
  std::vector<Connections> Blocks() const;
  /// The declared output channels: (channel name, signal it reports), in declaration order. The
  /// two are equal unless InsertOnOutput put a block on the channel.
  std::vector<std::pair<std::string, std::string>> Outputs() const;

  /// Parameter access by qualified name (did-you-mean on unknown names).
  ModelParameter& Parameter(const std::string& name);
  const std::vector<ModelParameter>& parameters() const { return parameters_; }
  void SetParameter(const std::string& name, double value);
  void Fix(const std::string& name);
  void Free(const std::string& name);

  /// Names of every signal known so far (inputs, states, block outputs).
  std::vector<std::string> Signals() const;

  /// Builds the symbolic state-space model. Throws std::invalid_argument for a signal that is
  /// read but never produced (with a suggestion), an algebraic loop (listing the blocks), a block
  /// output subtracted ("-name") from a signal that no block reads and no output reports (a
  /// typo; with the closest read signal), a model input nothing reads, or no states and no
  /// outputs. A signal written with "+" and read by nobody is an internal signal (allowed).
  /// Also refused: a block input or output in the rotational unit of a prismatic signal (rad,
  /// rad/s, rad/s^2, N m against m, m/s, m/s^2, N) or the reverse, naming the block and the
  /// motion option to set.
  StateSpaceModel Build() const;

 private:
  struct Instance {
    std::string name;
    std::shared_ptr<const Block> block;
    std::vector<std::string> inputs;
    std::vector<std::string> outputs;
  };
  struct Input {
    SignalInfo info;
  };
  const Instance* FindInstance(const std::string& name) const;
  // Rebuilds parameter_index_ after parameters_ was reordered.
  void IndexParameters();
  // Every instance name, in the order added (for did-you-mean suggestions).
  std::vector<std::string> InstanceNames() const;
  // Throws std::invalid_argument unless `instance` is a valid name no instance has yet.
  void CheckNewInstance(const std::string& instance) const;
  // Throws std::invalid_argument for a rotational port on a prismatic signal or the reverse
  // (Build's doc); `signal_info`: every signal's info, from its input, state or first producer.
  void CheckAxisUnits(const std::map<std::string, SignalInfo>& signal_info) const;

  std::string name_;
  std::vector<Input> inputs_;
  std::vector<Instance> instances_;
  std::vector<std::string> outputs_;       // the signal each channel reports
  std::vector<std::string> output_names_;  // the channel's name (outputs_[j] unless aliased)
  std::vector<ModelParameter> parameters_;
  // Name -> position in instances_ and parameters_: lookups stay O(1) in models of many blocks.
  std::unordered_map<std::string, std::size_t> instance_index_;
  std::unordered_map<std::string, std::size_t> parameter_index_;
};

/// Default optimizer scale of a parameter: |nominal|, or the width of finite bounds, or 1.
double DefaultParameterScale(const ParameterInfo& info);

}  // namespace graybox::models
