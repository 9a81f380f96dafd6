#include "graybox/models/model.h"
#include "graybox/util/did_you_mean.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

namespace graybox::models {

using expr::Expr;

namespace {

std::string Names(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s.empty() ? "(none)" : s;
}

std::string Suggest(const std::string& name, const std::vector<std::string>& known) {
  const std::string hint = util::DidYouMean(name, known);
  return hint.empty() ? "" : "; did you mean '" + hint + "'?";
}

std::shared_ptr<const Block> FromRegistry(const std::string& type, const BlockOptions& options) {
  return std::shared_ptr<const Block>(BlockRegistry::Global().Create(type, options));
}

// "-name" -> ("name", -1); "name" -> ("name", +1).
std::pair<std::string, double> Connection(const std::string& c) {
  if (!c.empty() && c[0] == '-') return {c.substr(1), -1.0};
  return {c, 1.0};
}

template <typename T, typename Key>
int IndexByName(const std::vector<T>& items, const std::string& name, Key key, const char* kind,
                const std::string& model) {
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (key(items[i]) == name) return static_cast<int>(i);
  }
  std::vector<std::string> names;
  names.reserve(items.size());
  for (const T& item : items) names.push_back(key(item));
  throw std::invalid_argument("model '" + model + "': unknown " + kind + " '" + name + "'" +
                              Suggest(name, names));
}

}  // namespace

double DefaultParameterScale(const ParameterInfo& info) {
  if (info.nominal != 0.0) return std::fabs(info.nominal);
  if (std::isfinite(info.lower) && std::isfinite(info.upper) && info.upper > info.lower) {
    return info.upper - info.lower;
  }
  return 1.0;
}

Eigen::VectorXd StateSpaceModel::ParameterValues() const {
  Eigen::VectorXd p(NumParameters());
  for (int i = 0; i < NumParameters(); ++i) p[i] = parameters[i].value;
  return p;
}

int StateSpaceModel::ParameterIndex(const std::string& n) const {
  return IndexByName(
      parameters, n, [](const ModelParameter& p) -> const std::string& { return p.name; },
      "parameter", name);
}
int StateSpaceModel::StateIndex(const std::string& n) const {
  return IndexByName(
      states, n, [](const SignalInfo& s) -> const std::string& { return s.name; }, "state", name);
}
int StateSpaceModel::InputIndex(const std::string& n) const {
  return IndexByName(
      inputs, n, [](const SignalInfo& s) -> const std::string& { return s.name; }, "input", name);
}
int StateSpaceModel::OutputIndex(const std::string& n) const {
  return IndexByName(
      outputs, n, [](const SignalInfo& s) -> const std::string& { return s.name; }, "output", name);
}
int StateSpaceModel::SignalIndex(const std::string& n) const {
  return IndexByName(
      signals, n, [](const SignalDescription& s) -> const std::string& { return s.info.name; },
      "signal", name);
}

expr::Function StateSpaceModel::SignalFunction(const std::vector<std::string>& names) const {
  std::vector<Expr> values;
  values.reserve(names.size());
  for (const auto& n : names) values.push_back(signals[SignalIndex(n)].value);
  // The symbols of `dynamics`, so the signal Function takes exactly the same x, u and p.
  return expr::Function(name + "_signals",
                        {{"x", dynamics.InputSymbols(0)},
                         {"u", dynamics.InputSymbols(1)},
                         {"p", dynamics.InputSymbols(2)}},
                        {{"signals", values}});
}

Eigen::MatrixXd StateSpaceModel::EvaluateSignals(const std::vector<std::string>& names,
                                                 const Eigen::MatrixXd& X, const Eigen::MatrixXd& U,
                                                 const Eigen::VectorXd& p,
                                                 expr::EvalStatus* status) const {
  auto expect = [&](bool ok, const std::string& what, const std::string& expected,
                    const std::string& got) {
    if (ok) return;
    throw std::invalid_argument("model '" + name + "': EvaluateSignals: " + what + ": expected " +
                                expected + ", got " + got);
  };
  auto shape = [](const Eigen::MatrixXd& m) {
    return std::to_string(m.rows()) + " x " + std::to_string(m.cols());
  };
  const Eigen::Index n = X.rows();
  expect(X.cols() == NumStates(), "X",
         "N x " + std::to_string(NumStates()) + " (one row per sample, one column per state)",
         shape(X));
  expect(U.rows() == n && U.cols() == NumInputs(), "U",
         std::to_string(n) + " x " + std::to_string(NumInputs()) + " (the rows of X)", shape(U));
  expect(p.size() == NumParameters(), "p", std::to_string(NumParameters()) + " parameters",
         std::to_string(p.size()));
  const expr::Function f = SignalFunction(names);
  expr::Workspace ws = f.MakeWorkspace();
  std::vector<Eigen::MatrixXd> out;
  const expr::EvalStatus st =
      f.EvaluateBatch({X.transpose(), U.transpose(), p.replicate(1, n)}, &out, &ws);
  if (status) *status = st;
  return out[0].transpose();
}

Model::Model(std::string name) : name_(std::move(name)) {}

void Model::AddInput(const std::string& signal, const std::string& unit,
                     const std::string& description, double typical_min, double typical_max) {
  if (signal.empty() || signal.find('.') != std::string::npos || signal[0] == '-') {
    throw std::invalid_argument("model '" + name_ +
                                "': expected an input name without '.' or leading '-', got '" +
                                signal + "'");
  }
  for (const auto& in : inputs_) {
    if (in.info.name == signal) {
      throw std::invalid_argument("model '" + name_ + "': input '" + signal + "' declared twice");
    }
  }
  inputs_.push_back({SignalInfo{signal, unit, description, typical_min, typical_max}});
}

std::vector<std::string> Model::InstanceNames() const {
  std::vector<std::string> names;
  for (const auto& inst : instances_) names.push_back(inst.name);
  return names;
}

const Model::Instance* Model::FindInstance(const std::string& n) const {
  const auto it = instance_index_.find(n);
  return it == instance_index_.end() ? nullptr : &instances_[it->second];
}

void Model::IndexParameters() {
  parameter_index_.clear();
  parameter_index_.reserve(parameters_.size());
  for (std::size_t i = 0; i < parameters_.size(); ++i) parameter_index_[parameters_[i].name] = i;
}

void Model::CheckNewInstance(const std::string& instance) const {
  if (instance.empty() || instance.find('.') != std::string::npos) {
    throw std::invalid_argument("model '" + name_ +
                                "': expected a block instance name without '.', got '" + instance +
                                "'");
  }
  if (FindInstance(instance)) {
    throw std::invalid_argument("model '" + name_ + "': block instance '" + instance +
                                "' added twice");
  }
}

void Model::AddBlock(const std::string& instance, std::shared_ptr<const Block> block,
                     const std::vector<std::string>& inputs,
                     const std::vector<std::string>& outputs) {
  if (!block) {
    throw std::invalid_argument("model '" + name_ + "': block '" + instance + "' is null");
  }
  CheckNewInstance(instance);
  const BlockInfo& info = block->info();
  if (static_cast<int>(inputs.size()) != block->NumInputs()) {
    throw std::invalid_argument("model '" + name_ + "': block '" + instance + "' (" + info.type +
                                "): expected " + std::to_string(block->NumInputs()) +
                                " input connections, got " + std::to_string(inputs.size()));
  }
  if (static_cast<int>(outputs.size()) != block->NumOutputs()) {
    throw std::invalid_argument("model '" + name_ + "': block '" + instance + "' (" + info.type +
                                "): expected " + std::to_string(block->NumOutputs()) +
                                " output connections, got " + std::to_string(outputs.size()));
  }
  for (const auto& out : outputs) {
    const std::string target = Connection(out).first;
    const auto dot = target.find('.');
    const Instance* owner =
        dot == std::string::npos ? nullptr : FindInstance(target.substr(0, dot));
    if (owner == nullptr) continue;
    for (const auto& s : owner->block->info().states) {
      if (target.compare(dot + 1, std::string::npos, s.name) == 0) {
        throw std::invalid_argument("model '" + name_ + "': block '" + instance +
                                    "' writes to state signal '" + target +
                                    "'; states are written only by their own block");
      }
    }
  }
  for (const ParameterInfo& par : info.parameters) {
    ModelParameter mp;
    mp.name = instance + "." + par.name;
    mp.info = par;
    mp.value = par.nominal;
    mp.free = !par.fixed_by_default;
    mp.scale = DefaultParameterScale(par);
    mp.lower = par.lower;
    mp.upper = par.upper;
    parameter_index_[mp.name] = parameters_.size();
    parameters_.push_back(mp);
  }
  instance_index_[instance] = instances_.size();
  instances_.push_back({instance, std::move(block), inputs, outputs});
}

void Model::AddBlock(const std::string& instance, const std::string& type,
                     const BlockOptions& options, const std::vector<std::string>& inputs,
                     const std::vector<std::string>& outputs) {
  AddBlock(instance, FromRegistry(type, options), inputs, outputs);
}

void Model::Augment(const std::string& instance, std::shared_ptr<const Block> block,
                    const std::vector<std::string>& inputs,
                    const std::vector<std::string>& outputs) {
  AddBlock(instance, std::move(block), inputs, outputs);
  for (auto& p : parameters_) {
    if (p.name.rfind(instance + ".", 0) == 0 && p.info.HasNeutral()) p.value = p.info.neutral;
  }
}

void Model::Augment(const std::string& instance, const std::string& type,
                    const BlockOptions& options, const std::vector<std::string>& inputs,
                    const std::vector<std::string>& outputs) {
  Augment(instance, FromRegistry(type, options), inputs, outputs);
}

void Model::ReplaceBlock(const std::string& instance, std::shared_ptr<const Block> block) {
  const auto found = instance_index_.find(instance);
  if (found == instance_index_.end()) {
    throw std::invalid_argument("model '" + name_ + "': ReplaceBlock: unknown block instance '" +
                                instance + "'" + Suggest(instance, InstanceNames()));
  }
  if (!block) {
    throw std::invalid_argument("model '" + name_ + "': ReplaceBlock('" + instance +
                                "'): the block is null");
  }
  const auto it = instances_.begin() + static_cast<std::ptrdiff_t>(found->second);
  const BlockInfo& old_info = it->block->info();
  const BlockInfo& info = block->info();
  const std::string where =
      "model '" + name_ + "': ReplaceBlock('" + instance + "', " + info.type + "): ";
  if (block->NumInputs() != it->block->NumInputs() ||
      block->NumOutputs() != it->block->NumOutputs()) {
    throw std::invalid_argument(
        where + "expected " + std::to_string(it->block->NumInputs()) + " inputs and " +
        std::to_string(it->block->NumOutputs()) + " outputs (as " + old_info.type + "), got " +
        std::to_string(block->NumInputs()) + " and " + std::to_string(block->NumOutputs()));
  }
  bool same_states = info.states.size() == old_info.states.size();
  for (std::size_t k = 0; same_states && k < info.states.size(); ++k) {
    same_states = info.states[k].name == old_info.states[k].name;
  }
  if (!same_states) {
    throw std::invalid_argument(where + "expected the states of " + old_info.type +
                                " (other blocks read them)");
  }
  // The instance's parameters are contiguous in parameters_, in instance order (Build relies on
  // it): after those of the instances before it.
  const std::string prefix = instance + ".";
  std::ptrdiff_t offset = 0;
  for (auto i = instances_.begin(); i != it; ++i) offset += i->block->NumParameters();
  const auto first = parameters_.begin() + offset;
  const auto last = first + it->block->NumParameters();
  std::vector<ModelParameter> replaced;
  for (const ParameterInfo& par : info.parameters) {
    ModelParameter mp;
    mp.name = prefix + par.name;
    const auto old =
        std::find_if(first, last, [&](const ModelParameter& p) { return p.name == mp.name; });
    if (old != last) {
      mp = *old;
      mp.info = par;
    } else {
      mp.info = par;
      mp.value = par.HasNeutral() ? par.neutral : par.nominal;
      mp.free = !par.fixed_by_default;
      mp.scale = DefaultParameterScale(par);
      mp.lower = par.lower;
      mp.upper = par.upper;
    }
    replaced.push_back(mp);
  }
  const auto at = parameters_.erase(first, last);
  parameters_.insert(at, replaced.begin(), replaced.end());
  IndexParameters();
  it->block = std::move(block);
}

void Model::ReplaceBlock(const std::string& instance, const std::string& type,
                         const BlockOptions& options) {
  ReplaceBlock(instance, FromRegistry(type, options));
}

void Model::InsertOnSignal(const std::string& signal, const std::string& instance,
                           std::shared_ptr<const Block> block,
                           const std::vector<std::string>& extra_inputs) {
  const int inputs = 1 + static_cast<int>(extra_inputs.size());
  if (!block || block->NumInputs() != inputs || block->NumOutputs() != 1) {
    throw std::invalid_argument(
        "model '" + name_ + "': InsertOnSignal('" + signal + "'): expected a block with " +
        std::to_string(inputs) + " input(s) and 1 output, got " +
        (block ? std::to_string(block->NumInputs()) + " and " + std::to_string(block->NumOutputs())
               : std::string("null")));
  }
  const std::vector<std::string> known = Signals();
  if (std::find(known.begin(), known.end(), signal) == known.end()) {
    throw std::invalid_argument("model '" + name_ + "': InsertOnSignal: unknown signal '" + signal +
                                "'" + Suggest(signal, known));
  }
  CheckNewInstance(instance);
  const std::string replacement = instance + ".out";
  for (auto& inst : instances_) {
    for (auto& in : inst.inputs) {
      if (in == signal) in = replacement;
    }
  }
  for (std::size_t j = 0; j < outputs_.size(); ++j) {
    if (outputs_[j] != signal) continue;
    if (output_names_[j] == outputs_[j]) output_names_[j] = replacement;
    outputs_[j] = replacement;
  }
  std::vector<std::string> reads = {signal};
  reads.insert(reads.end(), extra_inputs.begin(), extra_inputs.end());
  Augment(instance, std::move(block), reads, {replacement});
}

void Model::InsertOnInput(const std::string& input, const std::string& instance,
                          std::shared_ptr<const Block> block,
                          const std::vector<std::string>& extra_inputs) {
  const int arity = 1 + static_cast<int>(extra_inputs.size());
  if (!block || block->NumInputs() != arity || block->NumOutputs() != 1) {
    throw std::invalid_argument(
        "model '" + name_ + "': InsertOnInput('" + input + "'): expected a block with " +
        std::to_string(arity) + " input(s) and 1 output, got " +
        (block ? std::to_string(block->NumInputs()) + " and " + std::to_string(block->NumOutputs())
               : std::string("null")));
  }
  std::vector<std::string> inputs;
  for (const auto& in : inputs_) inputs.push_back(in.info.name);
  if (std::find(inputs.begin(), inputs.end(), input) == inputs.end()) {
    throw std::invalid_argument("model '" + name_ +
                                "': InsertOnInput: expected a model input, got '" + input + "'" +
                                Suggest(input, inputs));
  }
  CheckNewInstance(instance);
  // The blocks that add to the input add to the block's output instead; InsertOnSignal then
  // redirects the readers and adds the block on the input, now the raw input alone.
  const std::string replacement = instance + ".out";
  for (auto& inst : instances_) {
    for (auto& out : inst.outputs) {
      const auto [target, sign] = Connection(out);
      if (target == input) out = (sign < 0.0 ? "-" : "") + replacement;
    }
  }
  InsertOnSignal(input, instance, std::move(block), extra_inputs);
}

void Model::InsertOnOutput(const std::string& output, const std::string& instance,
                           std::shared_ptr<const Block> block,
                           const std::vector<std::string>& readers) {
  if (!block || block->NumInputs() != 1 || block->NumOutputs() != 1) {
    throw std::invalid_argument(
        "model '" + name_ + "': InsertOnOutput('" + output +
        "'): expected a block with 1 input and 1 output, got " +
        (block ? std::to_string(block->NumInputs()) + " and " + std::to_string(block->NumOutputs())
               : std::string("null")));
  }
  const auto channel = std::find(output_names_.begin(), output_names_.end(), output);
  if (channel == output_names_.end()) {
    throw std::invalid_argument("model '" + name_ + "': InsertOnOutput: unknown output '" + output +
                                "'" + Suggest(output, output_names_));
  }
  const std::size_t j = static_cast<std::size_t>(channel - output_names_.begin());
  InsertForReaders(outputs_[j], instance, std::move(block), readers);
  outputs_[j] = instance + ".out";
}

void Model::InsertForReaders(const std::string& signal, const std::string& instance,
                             std::shared_ptr<const Block> block,
                             const std::vector<std::string>& readers,
                             const std::vector<std::string>& extra_inputs) {
  const int inputs = 1 + static_cast<int>(extra_inputs.size());
  if (!block || block->NumInputs() != inputs || block->NumOutputs() != 1) {
    throw std::invalid_argument(
        "model '" + name_ + "': InsertForReaders('" + signal + "'): expected a block with " +
        std::to_string(inputs) + " input(s) and 1 output, got " +
        (block ? std::to_string(block->NumInputs()) + " and " + std::to_string(block->NumOutputs())
               : std::string("null")));
  }
  const std::vector<std::string> known = Signals();
  if (std::find(known.begin(), known.end(), signal) == known.end()) {
    throw std::invalid_argument("model '" + name_ + "': InsertForReaders: unknown signal '" +
                                signal + "'" + Suggest(signal, known));
  }
  for (const auto& r : readers) {
    if (!FindInstance(r)) {
      throw std::invalid_argument("model '" + name_ + "': InsertForReaders: unknown reader '" + r +
                                  "'" + Suggest(r, InstanceNames()));
    }
  }
  CheckNewInstance(instance);
  const std::string replacement = instance + ".out";
  for (auto& inst : instances_) {
    if (std::find(readers.begin(), readers.end(), inst.name) == readers.end()) continue;
    for (auto& in : inst.inputs) {
      if (in == signal) in = replacement;
    }
  }
  std::vector<std::string> block_inputs = {signal};
  block_inputs.insert(block_inputs.end(), extra_inputs.begin(), extra_inputs.end());
  Augment(instance, std::move(block), block_inputs, {replacement});
}

void Model::InsertOnSignal(const std::string& signal, const std::string& instance,
                           const std::string& type, const BlockOptions& options) {
  InsertOnSignal(signal, instance, FromRegistry(type, options));
}

void Model::InsertOnOutput(const std::string& output, const std::string& instance,
                           const std::string& type, const BlockOptions& options,
                           const std::vector<std::string>& readers) {
  InsertOnOutput(output, instance, FromRegistry(type, options), readers);
}

void Model::InsertForReaders(const std::string& signal, const std::string& instance,
                             const std::string& type, const BlockOptions& options,
                             const std::vector<std::string>& readers,
                             const std::vector<std::string>& extra_inputs) {
  InsertForReaders(signal, instance, FromRegistry(type, options), readers, extra_inputs);
}

void Model::AddOutput(const std::string& signal) {
  outputs_.push_back(signal);
  output_names_.push_back(signal);
}

std::vector<Model::Connections> Model::Blocks() const {
  std::vector<Connections> out;
  for (const auto& inst : instances_) {
    out.push_back({inst.name, inst.block->info().type, inst.inputs, inst.outputs});
  }
  return out;
}

std::vector<std::pair<std::string, std::string>> Model::Outputs() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (std::size_t j = 0; j < outputs_.size(); ++j) out.push_back({output_names_[j], outputs_[j]});
  return out;
}

ModelParameter& Model::Parameter(const std::string& n) {
  const auto it = parameter_index_.find(n);
  if (it != parameter_index_.end()) return parameters_[it->second];
  std::vector<std::string> names;
  names.reserve(parameters_.size());
  for (const ModelParameter& p : parameters_) names.push_back(p.name);
  throw std::invalid_argument("model '" + name_ + "': unknown parameter '" + n + "'" +
                              Suggest(n, names));
}

void Model::SetParameter(const std::string& n, double value) {
  ModelParameter& p = Parameter(n);
  if (!std::isfinite(value) || value < p.lower || value > p.upper) {
    throw std::invalid_argument("model '" + name_ + "': parameter '" + n +
                                "': expected a value in [" + std::to_string(p.lower) + ", " +
                                std::to_string(p.upper) + "], got " + std::to_string(value));
  }
  p.value = value;
}

void Model::Fix(const std::string& n) { Parameter(n).free = false; }
void Model::Free(const std::string& n) { Parameter(n).free = true; }

std::vector<std::string> Model::Signals() const {
  std::set<std::string> names;
  for (const auto& in : inputs_) names.insert(in.info.name);
  for (const auto& inst : instances_) {
    for (const auto& s : inst.block->info().states) names.insert(inst.name + "." + s.name);
    for (const auto& out : inst.outputs) {
      if (!out.empty()) names.insert(Connection(out).first);
    }
  }
  return {names.begin(), names.end()};
}

namespace {

// The quantity (0 position, 1 velocity, 2 acceleration, 3 force) and kind (false prismatic, true
// rotational) of a mechanical axis unit; quantity -1 for other units.
std::pair<int, bool> AxisUnit(const std::string& unit) {
  static const std::map<std::string, std::pair<int, bool>> kUnits = {
      {"m", {0, false}},     {"rad", {0, true}},     {"m/s", {1, false}}, {"rad/s", {1, true}},
      {"m/s^2", {2, false}}, {"rad/s^2", {2, true}}, {"N", {3, false}},   {"N m", {3, true}}};
  const auto it = kUnits.find(unit);
  return it == kUnits.end() ? std::make_pair(-1, false) : it->second;
}

}  // namespace

// A block whose input (or output) is the rotational form of a prismatic signal (rad/s read from
// a slide's m/s), or the reverse, is refused: its parameters would be reported in the wrong
// units (a friction block on a mechanics.mass reported N m s/rad without motion = "prismatic").
void Model::CheckAxisUnits(const std::map<std::string, SignalInfo>& signal_info) const {
  auto check = [&](const Instance& inst, const std::string& signal, const SignalInfo& port,
                   const char* verb) {
    // Only ports with a mechanical role: a network's or a generic block's units are nominal.
    if (port.role == SignalRole::kNone) return;
    const auto it = signal_info.find(signal);
    if (it == signal_info.end()) return;
    const std::pair<int, bool> a = AxisUnit(port.unit), b = AxisUnit(it->second.unit);
    if (a.first < 0 || a.first != b.first || a.second == b.second) return;
    throw std::invalid_argument(
        "model '" + name_ + "': block '" + inst.name + "' (" + inst.block->info().type + ") " +
        verb + " signal '" + signal + "' in " + port.unit + " (its " + port.name + "), but '" +
        signal + "' is in " + it->second.unit + ": a " + (a.second ? "rotational" : "prismatic") +
        " block on a " + (b.second ? "rotational" : "prismatic") +
        " axis; where the block has a motion option, set motion = \"" +
        (b.second ? "rotational" : "prismatic") + "\"");
  };
  for (const Instance& inst : instances_) {
    const BlockInfo& info = inst.block->info();
    for (std::size_t k = 0; k < inst.inputs.size() && k < info.inputs.size(); ++k) {
      if (!inst.inputs[k].empty()) check(inst, inst.inputs[k], info.inputs[k], "reads");
    }
    for (std::size_t k = 0; k < inst.outputs.size() && k < info.outputs.size(); ++k) {
      if (!inst.outputs[k].empty()) {
        check(inst, Connection(inst.outputs[k]).first, info.outputs[k], "writes");
      }
    }
  }
}

StateSpaceModel Model::Build() const {
  StateSpaceModel ss;
  ss.name = name_;
  ss.parameters = parameters_;
  // Symbols.
  std::vector<Expr> x, u, p;
  std::map<std::string, std::vector<Expr>> contributions;
  std::map<std::string, SignalInfo> signal_info;
  for (const auto& in : inputs_) {
    const Expr s = Expr::Symbol(in.info.name);
    u.push_back(s);
    ss.inputs.push_back(in.info);
    contributions[in.info.name].push_back(s);
    signal_info[in.info.name] = in.info;
  }
  std::vector<int> state_offset, parameter_offset;
  for (const auto& inst : instances_) {
    state_offset.push_back(static_cast<int>(x.size()));
    for (const auto& s : inst.block->info().states) {
      SignalInfo qualified = s;
      qualified.name = inst.name + "." + s.name;
      const Expr sym = Expr::Symbol(qualified.name);
      x.push_back(sym);
      ss.states.push_back(qualified);
      contributions[qualified.name].push_back(sym);
      signal_info[qualified.name] = qualified;
    }
    ss.stiff = ss.stiff || inst.block->info().stiff;
  }
  for (const auto& par : parameters_) p.push_back(Expr::Symbol(par.name));
  {
    int offset = 0;
    for (const auto& inst : instances_) {
      parameter_offset.push_back(offset);
      offset += inst.block->NumParameters();
    }
  }
  // Which instances produce each signal, and the signal order of StateSpaceModel::signals:
  // inputs, states, then block-output signals by first appearance.
  std::map<std::string, std::vector<int>> producers;
  std::vector<std::string> signal_order;
  for (const auto& in : inputs_) signal_order.push_back(in.info.name);
  for (const auto& s : ss.states) signal_order.push_back(s.name);
  for (std::size_t i = 0; i < instances_.size(); ++i) {
    for (std::size_t k = 0; k < instances_[i].outputs.size(); ++k) {
      const auto& out = instances_[i].outputs[k];
      if (out.empty()) continue;
      const std::string target = Connection(out).first;
      producers[target].push_back(static_cast<int>(i));
      SignalInfo info = instances_[i].block->info().outputs[k];
      info.name = target;
      if (signal_info.emplace(target, info).second) signal_order.push_back(target);
      // The first role declared by a producer (SignalDescription::info).
      SignalInfo& known = signal_info[target];
      if (known.role == SignalRole::kNone) known.role = info.role;
    }
  }
  // Then the role of the block inputs that read a signal without one.
  for (const auto& inst : instances_) {
    for (std::size_t k = 0; k < inst.inputs.size(); ++k) {
      auto it = signal_info.find(inst.inputs[k]);
      if (it != signal_info.end() && it->second.role == SignalRole::kNone) {
        it->second.role = inst.block->info().inputs[k].role;
      }
    }
  }
  CheckAxisUnits(signal_info);
  const std::vector<std::string> known = Signals();
  auto check_known = [&](const std::string& s, const std::string& where) {
    // "" is an unconnected block input: it reads 0 (AddBlock).
    if (s.empty() || contributions.count(s) || producers.count(s)) return;
    throw std::invalid_argument("model '" + name_ + "': " + where + " reads signal '" + s +
                                "', which no input, state or block output provides" +
                                Suggest(s, known));
  };
  // Dependency order (Kahn): instance i waits for every producer of a signal it reads.
  const int n = static_cast<int>(instances_.size());
  std::vector<std::set<int>> waits_for(n);
  for (int i = 0; i < n; ++i) {
    for (std::size_t k = 0; k < instances_[i].inputs.size(); ++k) {
      const std::string& s = instances_[i].inputs[k];
      check_known(s, "block '" + instances_[i].name + "' input '" +
                         instances_[i].block->info().inputs[k].name + "'");
      auto it = producers.find(s);
      if (it == producers.end()) continue;
      for (int j : it->second) waits_for[i].insert(j);
    }
  }
  for (const auto& out : outputs_) {
    if (out.empty()) {
      throw std::invalid_argument("model '" + name_ + "': an output names no signal");
    }
    check_known(out, "output");
  }
  std::vector<int> order;
  std::vector<bool> done(n, false);
  while (static_cast<int>(order.size()) < n) {
    bool progress = false;
    for (int i = 0; i < n; ++i) {
      if (done[i]) continue;
      bool ready = true;
      for (int j : waits_for[i]) ready = ready && done[j];
      if (!ready) continue;
      done[i] = true;
      order.push_back(i);
      progress = true;
    }
    if (!progress) {
      std::vector<std::string> loop;
      for (int i = 0; i < n; ++i) {
        if (!done[i]) loop.push_back(instances_[i].name);
      }
      throw std::invalid_argument("model '" + name_ + "': algebraic loop among blocks " +
                                  Names(loop) + "; expected a state between them");
    }
  }
  // A contribution subtracted from a signal that no block reads and no output reports, and a
  // model input nothing reads, are mistakes: a typo in a connection ("-forc" for "-force")
  // would disconnect a friction block silently (its parameters never move). A signal written
  // with "+" and read by nobody is an internal signal (reports, the diagnosis' regimes); ""
  // leaves a block output unconnected on purpose.
  {
    std::set<std::string> read(outputs_.begin(), outputs_.end());
    for (const auto& inst : instances_) read.insert(inst.inputs.begin(), inst.inputs.end());
    read.erase("");
    const std::vector<std::string> read_list(read.begin(), read.end());
    for (const auto& inst : instances_) {
      for (std::size_t k = 0; k < inst.outputs.size(); ++k) {
        if (inst.outputs[k].empty()) continue;
        const auto [target, sign] = Connection(inst.outputs[k]);
        if (sign > 0 || read.count(target)) continue;
        throw std::invalid_argument(
            "model '" + name_ + "': block '" + inst.name + "' output '" +
            inst.block->info().outputs[k].name + "' subtracts from signal '" + target +
            "', which no block reads and no output reports" + Suggest(target, read_list) +
            " (write \"\" to leave the output unconnected)");
      }
    }
    for (const auto& in : inputs_) {
      if (read.count(in.info.name)) continue;
      throw std::invalid_argument("model '" + name_ + "': input '" + in.info.name +
                                  "' is read by no block and reported by no output" +
                                  Suggest(in.info.name, read_list));
    }
  }
  auto value = [&](const std::string& s) {
    Expr sum(0.0);
    for (const Expr& c : contributions[s]) sum += c;
    return sum;
  };
  // Evaluate the blocks symbolically.
  std::vector<Expr> xdot(x.size());
  for (int i : order) {
    const Instance& inst = instances_[i];
    const Block& b = *inst.block;
    std::vector<Expr> in;
    for (const auto& s : inst.inputs) in.push_back(value(s));
    std::vector<Expr> y(b.NumOutputs()), dx(b.NumStates());
    BlockArgs<Expr> args{x.data() + state_offset[i], in.data(), p.data() + parameter_offset[i],
                         dx.data(), y.data()};
    b.Evaluate(args);
    for (int k = 0; k < b.NumStates(); ++k) xdot[state_offset[i] + k] = dx[k];
    for (std::size_t k = 0; k < inst.outputs.size(); ++k) {
      if (inst.outputs[k].empty()) continue;
      const auto [target, sign] = Connection(inst.outputs[k]);
      contributions[target].push_back(sign > 0 ? y[k] : -y[k]);
    }
  }
  std::vector<Expr> y;
  for (std::size_t j = 0; j < outputs_.size(); ++j) {
    const std::string& out = outputs_[j];
    y.push_back(value(out));
    // An aliased channel (InsertOnOutput) keeps the metadata of the signal it was declared on.
    const std::string& shown = signal_info.count(output_names_[j]) ? output_names_[j] : out;
    SignalInfo info =
        signal_info.count(shown) ? signal_info[shown] : SignalInfo{out, "", "", -1, 1};
    info.name = output_names_[j];
    ss.outputs.push_back(info);
  }
  // Every named signal with its value (all blocks have contributed by now).
  std::set<std::string> input_names;
  for (const auto& in : inputs_) input_names.insert(in.info.name);
  std::map<std::string, std::string> state_owner;
  for (const auto& inst : instances_) {
    for (const auto& st : inst.block->info().states) {
      state_owner[inst.name + "." + st.name] = inst.name;
    }
  }
  for (const std::string& s : signal_order) {
    SignalDescription d;
    d.info = signal_info[s];
    d.info.name = s;
    if (input_names.count(s)) {
      d.source = SignalSource::kInput;
    } else if (state_owner.count(s)) {
      d.source = SignalSource::kState;
      d.blocks.push_back(state_owner[s]);
    } else {
      d.source = SignalSource::kBlockOutput;
    }
    if (auto it = producers.find(s); it != producers.end()) {
      for (int i : it->second) {
        if (std::find(d.blocks.begin(), d.blocks.end(), instances_[i].name) == d.blocks.end()) {
          d.blocks.push_back(instances_[i].name);
        }
      }
    }
    d.value = value(s);
    ss.signals.push_back(std::move(d));
  }
  if (x.empty() && y.empty()) {
    throw std::invalid_argument("model '" + name_ + "': expected states or outputs, got neither");
  }
  ss.dynamics =
      expr::Function(name_ + "_dynamics", {{"x", x}, {"u", u}, {"p", p}}, {{"xdot", xdot}});
  ss.output = expr::Function(name_ + "_output", {{"x", x}, {"u", u}, {"p", p}}, {{"y", y}});
  return ss;
}

}  // namespace graybox::models
