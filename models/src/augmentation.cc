#include "graybox/models/augmentation.h"

#include <algorithm>
#include <memory>
#include <utility>

#include "graybox/util/did_you_mean.h"

namespace graybox::models {
namespace {

using Kind = Augmentation::Kind;

std::string List(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "'" : ", '") + n + "'";
  return s.empty() ? "(none)" : s;
}

bool Contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

// The field is empty unless the kind uses it.
void RequireEmpty(const Augmentation& a, const char* field, bool empty, const std::string& got) {
  if (!empty) {
    throw AugmentationError(a, field,
                            std::string("expected it empty: kind '") +
                                AugmentationKindName(a.kind) + "' does not use it, got " + got);
  }
}

std::string Connections(int count, const std::vector<SignalInfo>& ends) {
  std::string names;
  for (const auto& e : ends) names += (names.empty() ? "" : ", ") + e.name;
  return std::to_string(count) + (names.empty() ? "" : " (" + names + ")");
}

// `name` is a signal of the model (or in `own`, the new block's states).
void CheckSignal(const Augmentation& a, const char* field, const std::string& label,
                 const std::string& name, const std::vector<std::string>& known,
                 const std::string& model) {
  if (Contains(known, name)) return;
  throw AugmentationError(a, field,
                          (label.empty() ? "" : label + ": ") + "expected a signal of model '" +
                              model + "', got '" + name + "'" + util::DidYouMeanHint(name, known));
}

// Every reader is a block instance of the model that reads `signal`; at least one for
// kForReaders.
void CheckReaders(const Augmentation& a, const Model& model, const std::string& signal) {
  const std::vector<Model::Connections> blocks = model.Blocks();
  std::vector<std::string> instances, reading;
  for (const auto& b : blocks) {
    instances.push_back(b.instance);
    if (Contains(b.inputs, signal)) reading.push_back(b.instance);
  }
  for (std::size_t i = 0; i < a.readers.size(); ++i) {
    const std::string& r = a.readers[i];
    const std::string label = "entry " + std::to_string(i) + ": ";
    if (!Contains(instances, r)) {
      throw AugmentationError(a, "readers",
                              label + "expected a block instance of model '" + model.name() +
                                  "', got '" + r + "'" + util::DidYouMeanHint(r, instances));
    }
    if (!Contains(reading, r)) {
      throw AugmentationError(a, "readers",
                              label + "expected an instance that reads '" + signal + "', got '" +
                                  r + "', which does not (instances reading it: " + List(reading) +
                                  ")");
    }
  }
}

}  // namespace

const char* AugmentationKindName(Augmentation::Kind kind) {
  switch (kind) {
    case Kind::kAdd:
      return "add";
    case Kind::kOnSignal:
      return "on_signal";
    case Kind::kOnInput:
      return "on_input";
    case Kind::kOnOutput:
      return "on_output";
    case Kind::kForReaders:
      return "for_readers";
  }
  return "add";
}

bool operator==(const Augmentation& a, const Augmentation& b) {
  return a.kind == b.kind && a.instance == b.instance && a.type == b.type &&
         a.options.numbers == b.options.numbers && a.options.words == b.options.words &&
         a.inputs == b.inputs && a.outputs == b.outputs && a.signal == b.signal &&
         a.readers == b.readers && a.extra_inputs == b.extra_inputs;
}

AugmentationError::AugmentationError(const Augmentation& augmentation, std::string field,
                                     std::string reason)
    : std::invalid_argument("augmentation '" + augmentation.instance + "' (" +
                            AugmentationKindName(augmentation.kind) + "), field '" + field +
                            "': " + reason),
      field_(std::move(field)),
      reason_(std::move(reason)) {}

void Augmentation::Validate() const {
  if (instance.empty() || instance.find('.') != std::string::npos) {
    throw AugmentationError(*this, "instance",
                            "expected a block instance name without '.', got '" + instance + "'");
  }
  if (type.empty()) throw AugmentationError(*this, "type", "expected a block type, got ''");
  const bool add = kind == Kind::kAdd;
  if (!add) {
    RequireEmpty(*this, "inputs", inputs.empty(), List(inputs));
    RequireEmpty(*this, "outputs", outputs.empty(), List(outputs));
    if (signal.empty()) {
      throw AugmentationError(*this, "signal",
                              std::string("expected the ") +
                                  (kind == Kind::kOnOutput ? "output channel" : "signal") +
                                  " to insert the block on, got ''");
    }
  } else {
    RequireEmpty(*this, "signal", signal.empty(), "'" + signal + "'");
  }
  if (add || kind == Kind::kOnSignal || kind == Kind::kOnInput)
    RequireEmpty(*this, "readers", readers.empty(), List(readers));
  if (kind != Kind::kForReaders) {
    RequireEmpty(*this, "extra_inputs", extra_inputs.empty(), List(extra_inputs));
  } else if (readers.empty()) {
    throw AugmentationError(
        *this, "readers",
        "expected at least one block instance that reads '" + signal + "', got none");
  }
}

void ApplyAugmentation(Model* model, const Augmentation& a) {
  a.Validate();
  for (const auto& b : model->Blocks()) {
    if (b.instance == a.instance) {
      throw AugmentationError(a, "instance",
                              "expected a new instance name, got '" + a.instance +
                                  "', which model '" + model->name() + "' already has (" + b.type +
                                  ")");
    }
  }
  std::shared_ptr<const Block> block;
  try {
    block = BlockRegistry::Global().Create(a.type, a.options);
  } catch (const std::invalid_argument& e) {
    const auto types = BlockRegistry::Global().Types();
    throw AugmentationError(a, Contains(types, a.type) ? "options" : "type", e.what());
  }
  const BlockInfo& info = block->info();
  const std::vector<std::string> signals = model->Signals();
  const std::string& name = model->name();
  const int ins = block->NumInputs(), outs = block->NumOutputs();
  auto counts = [&] {
    return "type '" + a.type + "' with " + Connections(ins, info.inputs) + " input(s) and " +
           Connections(outs, info.outputs) + " output(s)";
  };
  switch (a.kind) {
    case Kind::kAdd: {
      if (static_cast<int>(a.inputs.size()) != ins) {
        throw AugmentationError(a, "inputs",
                                "expected " + std::to_string(ins) + " input connection(s) (" +
                                    counts() + "), got " + std::to_string(a.inputs.size()));
      }
      if (static_cast<int>(a.outputs.size()) != outs) {
        throw AugmentationError(a, "outputs",
                                "expected " + std::to_string(outs) + " output connection(s) (" +
                                    counts() + "), got " + std::to_string(a.outputs.size()));
      }
      std::vector<std::string> readable = signals;
      for (const auto& s : info.states) readable.push_back(a.instance + "." + s.name);
      for (std::size_t i = 0; i < a.inputs.size(); ++i) {
        CheckSignal(a, "inputs", "entry " + std::to_string(i), a.inputs[i], readable, name);
      }
      try {
        model->Augment(a.instance, block, a.inputs, a.outputs);
      } catch (const std::invalid_argument& e) {
        // What the checks above leave to AddBlock: an output written to another block's state.
        throw AugmentationError(a, "outputs", e.what());
      }
      return;
    }
    case Kind::kOnSignal:
    case Kind::kOnInput:
    case Kind::kOnOutput:
      if (ins != 1 || outs != 1) {
        throw AugmentationError(a, "type",
                                "expected a block with 1 input and 1 output, got " + counts());
      }
      break;
    case Kind::kForReaders: {
      const int expected = 1 + static_cast<int>(a.extra_inputs.size());
      if (ins < 1 || outs != 1) {
        throw AugmentationError(
            a, "type", "expected a block with at least 1 input and 1 output, got " + counts());
      }
      if (ins != expected) {
        throw AugmentationError(a, "extra_inputs",
                                "expected " + std::to_string(ins - 1) +
                                    " extra input(s) after the signal (" + counts() + "), got " +
                                    std::to_string(a.extra_inputs.size()));
      }
      break;
    }
  }
  if (a.kind == Kind::kOnOutput) {
    std::vector<std::string> channels;
    std::string observed;
    for (const auto& [channel, signal] : model->Outputs()) {
      channels.push_back(channel);
      if (channel == a.signal) observed = signal;
    }
    if (observed.empty()) {
      throw AugmentationError(a, "signal",
                              "expected an output channel of model '" + name + "' (" +
                                  List(channels) + "), got '" + a.signal + "'" +
                                  util::DidYouMeanHint(a.signal, channels));
    }
    CheckReaders(a, *model, observed);
  } else if (a.kind == Kind::kOnInput) {
    std::vector<std::string> inputs;
    for (const auto& in : model->Build().inputs) inputs.push_back(in.name);
    if (!Contains(inputs, a.signal)) {
      throw AugmentationError(a, "signal",
                              "expected an input of model '" + name + "' (" + List(inputs) +
                                  "), got '" + a.signal + "'" +
                                  util::DidYouMeanHint(a.signal, inputs));
    }
  } else {
    CheckSignal(a, "signal", "", a.signal, signals, name);
  }
  if (a.kind == Kind::kForReaders) {
    CheckReaders(a, *model, a.signal);
    for (std::size_t i = 0; i < a.extra_inputs.size(); ++i) {
      CheckSignal(a, "extra_inputs", "entry " + std::to_string(i), a.extra_inputs[i], signals,
                  name);
    }
  }
  // The checks above cover every defect the Model operations report, so the model is changed
  // only when they succeed.
  switch (a.kind) {
    case Kind::kOnSignal:
      model->InsertOnSignal(a.signal, a.instance, block);
      break;
    case Kind::kOnInput:
      model->InsertOnInput(a.signal, a.instance, block);
      break;
    case Kind::kOnOutput:
      model->InsertOnOutput(a.signal, a.instance, block, a.readers);
      break;
    case Kind::kForReaders:
      model->InsertForReaders(a.signal, a.instance, block, a.readers, a.extra_inputs);
      break;
    case Kind::kAdd:
      break;
  }
}

}  // namespace graybox::models
