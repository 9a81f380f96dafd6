// Augmentation: one change to a model stated as data, "add a block at its neutral value, or insert
// one in series on a signal", so that it can be written down (a problem file's [[model.augment]]
// table, docs/problem-format.md), compared, and applied to any model that has the signals it
// names. ApplyAugmentation() creates the block from the global registry (block.h) and calls the
// matching operation of Model (model.h); each kind below is one of them:
//
//   kAdd         Model::Augment(instance, type, options, inputs, outputs): the block is added
//                with its connections, as AddBlock takes them. A Coulomb friction force on the
//                velocity of a sliding mass:
//                  {kAdd, "coulomb", "friction.coulomb", {words: motion = prismatic},
//                   inputs = {"load.qd"}, outputs = {"-force"}}
//   kOnSignal    Model::InsertOnSignal(signal, instance, ...): a one-input one-output block in
//                series on `signal`; every block input and model output that read `signal`
//                reads "<instance>.out" instead. A first-order delay of the force command u:
//                  {kOnSignal, "input_delay", "delay.first_order", {words: unit = N},
//                   signal = "u"}
//   kOnInput     Model::InsertOnInput(signal, instance, ...): a one-input one-output block on the
//                model input `signal` alone, before the blocks that add to that signal (friction
//                subtracted from a motor torque input keeps acting undelayed). A first-order delay
//                of the torque command tau_m of a motor with friction:
//                  {kOnInput, "input_delay", "delay.first_order", {words: unit = N m},
//                   signal = "tau_m"}
//   kOnOutput    Model::InsertOnOutput(signal, instance, ..., readers): a one-input one-output
//                block on the measured channel named `signal` only (a sensor error); the channel
//                keeps its name, the physics keeps reading the true signal, and the block
//                instances in `readers` (a controller reading the same sensor) read the block's
//                output too. A position sensor offset seen by the controller as well:
//                  {kOnOutput, "sensor_offset", "sensor.offset", {words: unit = m},
//                   signal = "load.q", readers = {"controller"}}
//   kForReaders  Model::InsertForReaders(signal, instance, ..., readers, extra_inputs): in series
//                on `signal` for the block instances in `readers` only (at least one); other
//                readers and the model outputs keep reading `signal` (a logged command stays the
//                command). A block with more inputs reads `extra_inputs` on its inputs 2, 3, ...
//                A dead zone in the drive that reads the controller output nu:
//                  {kForReaders, "deadzone", "actuator.deadzone", {words: unit = V},
//                   signal = "nu", readers = {"drive"}}
//                and a payload whose gravity reads the axis position:
//                  {kForReaders, "payload", "mechanics.payload", {...}, signal = "force",
//                   readers = {"load"}, extra_inputs = {"load.q"}}
//
// Every kind starts the new block's parameters at their neutral values (ParameterInfo::neutral;
// those without one at their nominal values), free unless the block declares them
// fixed_by_default, so the augmented model's outputs equal the original ones until a parameter
// moves. The fields a kind does not use must be empty.
//
// Errors. Validate() checks what needs no model; ApplyAugmentation() checks the rest against the
// model before changing it (a failed augmentation leaves the model as it was). Both throw
// AugmentationError, a std::invalid_argument naming the augmentation's instance, the field and
// what was expected and found, with a did-you-mean suggestion for names:
//   "augmentation 'input_delay' (on_signal), field 'signal': expected a signal of model 'm', got
//    'uu'; did you mean 'u'?"
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "graybox/models/block.h"
#include "graybox/models/model.h"

namespace graybox::models {

struct Augmentation {
  enum class Kind { kAdd, kOnSignal, kOnInput, kOnOutput, kForReaders };
  Kind kind = Kind::kAdd;
  /// The new block instance (no '.'; not an instance the model already has).
  std::string instance;
  /// A registered block type (BlockRegistry::Global()) and its options.
  std::string type;
  BlockOptions options;
  /// kAdd only: the signal each block input reads and the connection of each block output
  /// ("name" adds to the signal, "-name" subtracts, "" leaves the output unconnected), exactly
  /// as Model::AddBlock takes them. The inputs must be signals the model has when the
  /// augmentation is applied, or states of the new block.
  std::vector<std::string> inputs;
  std::vector<std::string> outputs;
  /// kOnSignal and kForReaders: the signal the block is put on; kOnInput: the model input;
  /// kOnOutput: the output channel's name (StateSpaceModel::outputs[j].name).
  std::string signal;
  /// kOnOutput (optional) and kForReaders (at least one): block instances that read `signal` and
  /// read the block's output "<instance>.out" instead.
  std::vector<std::string> readers;
  /// kForReaders only: the signals of the block's inputs after the first.
  std::vector<std::string> extra_inputs;

  /// Throws AugmentationError for what is wrong without a model: an empty or dotted instance
  /// name, an empty type, an empty `signal` for the insert kinds, no readers for kForReaders, a
  /// field the kind does not use that is not empty.
  void Validate() const;
};

/// "add", "on_signal", "on_input", "on_output", "for_readers" (the problem-file keys of the
/// kinds).
const char* AugmentationKindName(Augmentation::Kind kind);

/// Field-wise equality (options compared value by value).
bool operator==(const Augmentation& a, const Augmentation& b);
inline bool operator!=(const Augmentation& a, const Augmentation& b) { return !(a == b); }

/// A defect of an augmentation: what() is "augmentation '<instance>' (<kind>), field '<field>':
/// <reason>"; field() is the Augmentation member ("instance", "type", "options", "inputs",
/// "outputs", "signal", "readers", "extra_inputs") so that a caller can point at its own source
/// of it (a problem file's key).
class AugmentationError : public std::invalid_argument {
 public:
  AugmentationError(const Augmentation& augmentation, std::string field, std::string reason);
  const std::string& field() const { return field_; }
  /// The message without the augmentation and the field.
  const std::string& reason() const { return reason_; }

 private:
  std::string field_;
  std::string reason_;
};

/// Applies `augmentation` to `model` (see the file comment): Validate(), the block created from
/// the registry, the names and connection counts checked against the model and the block, then
/// the Model operation of the kind. Throws AugmentationError (the model unchanged) for an unknown
/// type or bad options (field "type" / "options"), a repeated instance, a connection count that
/// does not match the block (inputs, outputs, extra_inputs; a block that is not one-input
/// one-output for kOnSignal and kOnOutput: field "type"), an unknown signal, output channel or
/// reader, or a reader that does not read the signal.
void ApplyAugmentation(Model* model, const Augmentation& augmentation);

}  // namespace graybox::models
