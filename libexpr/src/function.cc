#include "graybox/expr/function.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>
#include <unordered_set>

#include "graybox/expr/derivatives.h"
#include "node.h"
#include "tape.h"

namespace graybox::expr {

FunctionIo::FunctionIo(std::string n, std::vector<Expr> e)
    : name(std::move(n)), exprs(std::move(e)), sparsity(Sparsity::Dense(exprs.size(), 1)) {}

FunctionIo::FunctionIo(std::string n, std::vector<Expr> e, Sparsity s)
    : name(std::move(n)), exprs(std::move(e)), sparsity(std::move(s)) {
  if (sparsity.nnz() != static_cast<int>(exprs.size())) {
    throw std::invalid_argument(
        "FunctionIo '" + name + "': expected " + std::to_string(sparsity.nnz()) +
        " expressions (the sparsity's nonzeros), got " + std::to_string(exprs.size()));
  }
}

struct Function::Data {
  std::string name;
  std::vector<FunctionIo> inputs;
  std::vector<FunctionIo> outputs;
  std::unique_ptr<Tape> tape;        // one point at a time: runs of equal opcodes
  std::unique_ptr<Tape> batch_tape;  // kLanes points at a time: fewest registers
};

namespace {

std::string NameList(const std::vector<FunctionIo>& ios) {
  std::string s;
  for (const auto& io : ios) s += (s.empty() ? "'" : ", '") + io.name + "'";
  return s.empty() ? "(none)" : s;
}

void CheckNames(const std::string& fname, const std::vector<FunctionIo>& ios, const char* kind,
                std::set<std::string>* seen) {
  for (const auto& io : ios) {
    if (io.name.empty()) {
      throw std::invalid_argument("Function '" + fname + "': expected a nonempty " + kind +
                                  " name, got \"\"");
    }
    if (!seen->insert(io.name).second) {
      throw std::invalid_argument("Function '" + fname + "': " + kind + " name '" + io.name +
                                  "' is used twice; expected unique names");
    }
  }
}

std::vector<std::vector<Expr>> ExprLists(const std::vector<FunctionIo>& ios) {
  std::vector<std::vector<Expr>> lists;
  for (const auto& io : ios) lists.push_back(io.exprs);
  return lists;
}

}  // namespace

Function::Function() : Function("empty", {}, {}) {}

Function::Function(std::string name, std::vector<FunctionIo> inputs,
                   std::vector<FunctionIo> outputs) {
  std::set<std::string> seen;
  CheckNames(name, inputs, "input", &seen);
  CheckNames(name, outputs, "output", &seen);
  std::unordered_set<const internal::Node*> symbols;
  for (const auto& in : inputs) {
    for (std::size_t k = 0; k < in.exprs.size(); ++k) {
      const Expr& s = in.exprs[k];
      if (!s.IsSymbol()) {
        throw std::invalid_argument("Function '" + name + "': input '" + in.name + "'[" +
                                    std::to_string(k) + "]: expected a symbol, got " +
                                    s.ToString());
      }
      if (!symbols.insert(s.node()).second) {
        throw std::invalid_argument("Function '" + name + "': input '" + in.name + "'[" +
                                    std::to_string(k) + "]: symbol '" + s.Name() +
                                    "' appears twice among the inputs");
      }
    }
  }
  for (const auto& out : outputs) {
    for (const Expr& s : FreeSymbols(out.exprs)) {
      if (!symbols.count(s.node())) {
        throw std::invalid_argument("Function '" + name + "': output '" + out.name +
                                    "' depends on symbol '" + s.Name() +
                                    "', which is not among the inputs");
      }
    }
  }
  auto data = std::make_shared<Data>();
  data->tape = std::make_unique<Tape>(ExprLists(inputs), ExprLists(outputs),
                                      Tape::Schedule::kGroupedByOpcode);
  data->batch_tape =
      std::make_unique<Tape>(ExprLists(inputs), ExprLists(outputs), Tape::Schedule::kDepthFirst);
  data->name = std::move(name);
  data->inputs = std::move(inputs);
  data->outputs = std::move(outputs);
  data_ = std::move(data);
}

const std::string& Function::name() const { return data_->name; }
int Function::NumInputs() const { return static_cast<int>(data_->inputs.size()); }
int Function::NumOutputs() const { return static_cast<int>(data_->outputs.size()); }

namespace {
void CheckIndex(const std::string& fname, int i, int n, const char* kind) {
  if (i < 0 || i >= n) {
    throw std::out_of_range("Function '" + fname + "': expected " + kind + " index in [0, " +
                            std::to_string(n) + "), got " + std::to_string(i));
  }
}
}  // namespace

const std::string& Function::InputName(int i) const {
  CheckIndex(name(), i, NumInputs(), "input");
  return data_->inputs[i].name;
}
const std::string& Function::OutputName(int i) const {
  CheckIndex(name(), i, NumOutputs(), "output");
  return data_->outputs[i].name;
}
int Function::InputIndex(const std::string& n) const {
  for (int i = 0; i < NumInputs(); ++i) {
    if (data_->inputs[i].name == n) return i;
  }
  throw std::invalid_argument("Function '" + name() + "': unknown input '" + n +
                              "'; expected one of " + NameList(data_->inputs));
}
int Function::OutputIndex(const std::string& n) const {
  for (int i = 0; i < NumOutputs(); ++i) {
    if (data_->outputs[i].name == n) return i;
  }
  throw std::invalid_argument("Function '" + name() + "': unknown output '" + n +
                              "'; expected one of " + NameList(data_->outputs));
}
int Function::InputSize(int i) const {
  CheckIndex(name(), i, NumInputs(), "input");
  return static_cast<int>(data_->inputs[i].exprs.size());
}
int Function::OutputSize(int i) const {
  CheckIndex(name(), i, NumOutputs(), "output");
  return static_cast<int>(data_->outputs[i].exprs.size());
}
const std::vector<Expr>& Function::InputSymbols(int i) const {
  CheckIndex(name(), i, NumInputs(), "input");
  return data_->inputs[i].exprs;
}
const std::vector<Expr>& Function::OutputExprs(int i) const {
  CheckIndex(name(), i, NumOutputs(), "output");
  return data_->outputs[i].exprs;
}
const Sparsity& Function::OutputSparsity(int i) const {
  CheckIndex(name(), i, NumOutputs(), "output");
  return data_->outputs[i].sparsity;
}
std::vector<Expr> Function::AllInputSymbols() const {
  std::vector<Expr> all;
  for (const auto& in : data_->inputs) all.insert(all.end(), in.exprs.begin(), in.exprs.end());
  return all;
}
int Function::NumInstructions() const { return static_cast<int>(data_->tape->code().size()); }
int Function::NumRegisters() const { return data_->tape->num_registers(); }
std::size_t Function::NumNodes() const {
  std::vector<Expr> all;
  for (const auto& out : data_->outputs) all.insert(all.end(), out.exprs.begin(), out.exprs.end());
  return CountNodes(all);
}

Workspace Function::MakeWorkspace() const {
  Workspace ws;
  const Tape& tape = *data_->tape;
  ws.owner_ = &tape;
  ws.registers_.assign(tape.num_registers(), 0.0);
  for (const auto& [r, v] : tape.constants()) ws.registers_[r] = v;
  const Tape& batch = *data_->batch_tape;
  ws.batch_registers_.assign(static_cast<std::size_t>(batch.num_registers()) * Tape::kLanes, 0.0);
  for (const auto& [r, v] : batch.constants()) {
    for (int l = 0; l < Tape::kLanes; ++l) ws.batch_registers_[r * Tape::kLanes + l] = v;
  }
  return ws;
}

namespace {

EvalStatus NonFinite(const Function& f, int output, int index, double value) {
  EvalStatus s;
  s.ok = false;
  s.output = output;
  s.index = index;
  s.value = value;
  std::ostringstream os;
  os << "Function '" << f.name() << "': output '" << f.OutputName(output) << "'[" << index
     << "] = " << value;
  s.message = os.str();
  return s;
}

}  // namespace

EvalStatus Function::Evaluate(const double* const* inputs, double* const* outputs,
                              Workspace* ws) const {
  const Tape& tape = *data_->tape;
  if (ws == nullptr || ws->owner_ != &tape) {
    throw std::invalid_argument("Function '" + name() +
                                "'::Evaluate: expected a workspace from this function's "
                                "MakeWorkspace(), got " +
                                (ws == nullptr ? "null" : "a workspace of another function"));
  }
  double* r = ws->registers_.data();
  const auto& in_regs = tape.input_registers();
  for (std::size_t i = 0; i < in_regs.size(); ++i) {
    const double* x = inputs[i];
    for (std::size_t k = 0; k < in_regs[i].size(); ++k) {
      if (in_regs[i][k] >= 0) r[in_regs[i][k]] = x[k];
    }
  }
  tape.Run(r);
  EvalStatus status;
  const auto& out_regs = tape.output_registers();
  for (std::size_t j = 0; j < out_regs.size(); ++j) {
    double* y = outputs[j];
    if (y == nullptr) continue;
    for (std::size_t k = 0; k < out_regs[j].size(); ++k) {
      const double v = r[out_regs[j][k]];
      y[k] = v;
      if (status.ok && !std::isfinite(v)) {
        status = NonFinite(*this, static_cast<int>(j), static_cast<int>(k), v);
      }
    }
  }
  return status;
}

std::vector<Eigen::VectorXd> Function::operator()(
    const std::vector<Eigen::VectorXd>& inputs) const {
  if (static_cast<int>(inputs.size()) != NumInputs()) {
    throw std::invalid_argument("Function '" + name() + "': expected " +
                                std::to_string(NumInputs()) + " inputs, got " +
                                std::to_string(inputs.size()));
  }
  std::vector<const double*> in(inputs.size());
  for (int i = 0; i < NumInputs(); ++i) {
    if (inputs[i].size() != InputSize(i)) {
      throw std::invalid_argument("Function '" + name() + "': input '" + InputName(i) +
                                  "': expected size " + std::to_string(InputSize(i)) + ", got " +
                                  std::to_string(inputs[i].size()));
    }
    in[i] = inputs[i].data();
  }
  std::vector<Eigen::VectorXd> outputs(NumOutputs());
  std::vector<double*> out(NumOutputs());
  for (int j = 0; j < NumOutputs(); ++j) {
    outputs[j].resize(OutputSize(j));
    out[j] = outputs[j].data();
  }
  Workspace ws = MakeWorkspace();
  const EvalStatus status = Evaluate(in.data(), out.data(), &ws);
  if (!status.ok) throw NonFiniteError(status.message);
  return outputs;
}

EvalStatus Function::EvaluateBatch(const std::vector<Eigen::MatrixXd>& inputs,
                                   std::vector<Eigen::MatrixXd>* outputs, Workspace* ws) const {
  const Tape& tape = *data_->tape;
  if (ws == nullptr || ws->owner_ != &tape) {
    throw std::invalid_argument("Function '" + name() +
                                "'::EvaluateBatch: expected a workspace from this function's "
                                "MakeWorkspace()");
  }
  if (static_cast<int>(inputs.size()) != NumInputs()) {
    throw std::invalid_argument("Function '" + name() + "'::EvaluateBatch: expected " +
                                std::to_string(NumInputs()) + " inputs, got " +
                                std::to_string(inputs.size()));
  }
  const Eigen::Index npoints = inputs.empty() ? 1 : inputs[0].cols();
  for (int i = 0; i < NumInputs(); ++i) {
    if (inputs[i].rows() != InputSize(i) || inputs[i].cols() != npoints) {
      throw std::invalid_argument(
          "Function '" + name() + "'::EvaluateBatch: input '" + InputName(i) + "': expected " +
          std::to_string(InputSize(i)) + "x" + std::to_string(npoints) + ", got " +
          std::to_string(inputs[i].rows()) + "x" + std::to_string(inputs[i].cols()));
    }
  }
  outputs->resize(NumOutputs());
  for (int j = 0; j < NumOutputs(); ++j) {
    if ((*outputs)[j].rows() != OutputSize(j) || (*outputs)[j].cols() != npoints) {
      (*outputs)[j].resize(OutputSize(j), npoints);
    }
  }
  constexpr int L = Tape::kLanes;
  double* r = ws->batch_registers_.data();
  const Tape& batch = *data_->batch_tape;
  const auto& in_regs = batch.input_registers();
  const auto& out_regs = batch.output_registers();
  EvalStatus status;
  for (Eigen::Index p0 = 0; p0 < npoints; p0 += L) {
    const int lanes = static_cast<int>(std::min<Eigen::Index>(L, npoints - p0));
    for (std::size_t i = 0; i < in_regs.size(); ++i) {
      for (std::size_t k = 0; k < in_regs[i].size(); ++k) {
        const int reg = in_regs[i][k];
        if (reg < 0) continue;
        for (int l = 0; l < L; ++l) {
          r[reg * L + l] = inputs[i](k, p0 + std::min(l, lanes - 1));
        }
      }
    }
    batch.RunBatch(r);
    for (std::size_t j = 0; j < out_regs.size(); ++j) {
      Eigen::MatrixXd& y = (*outputs)[j];
      for (std::size_t k = 0; k < out_regs[j].size(); ++k) {
        const double* src = r + out_regs[j][k] * L;
        for (int l = 0; l < lanes; ++l) {
          const double v = src[l];
          y(k, p0 + l) = v;
          if (status.ok && !std::isfinite(v)) {
            status = NonFinite(*this, static_cast<int>(j), static_cast<int>(k), v);
            status.message += " at point " + std::to_string(p0 + l);
          }
        }
      }
    }
  }
  return status;
}

std::vector<std::vector<Expr>> Function::Call(const std::vector<std::vector<Expr>>& args) const {
  if (static_cast<int>(args.size()) != NumInputs()) {
    throw std::invalid_argument("Function '" + name() + "'::Call: expected " +
                                std::to_string(NumInputs()) + " arguments, got " +
                                std::to_string(args.size()));
  }
  std::vector<Expr> from, to, all;
  for (int i = 0; i < NumInputs(); ++i) {
    if (static_cast<int>(args[i].size()) != InputSize(i)) {
      throw std::invalid_argument("Function '" + name() + "'::Call: argument '" + InputName(i) +
                                  "': expected size " + std::to_string(InputSize(i)) + ", got " +
                                  std::to_string(args[i].size()));
    }
    from.insert(from.end(), data_->inputs[i].exprs.begin(), data_->inputs[i].exprs.end());
    to.insert(to.end(), args[i].begin(), args[i].end());
  }
  for (const auto& out : data_->outputs) all.insert(all.end(), out.exprs.begin(), out.exprs.end());
  const std::vector<Expr> subst = Substitute(all, from, to);
  std::vector<std::vector<Expr>> result;
  std::size_t offset = 0;
  for (const auto& out : data_->outputs) {
    result.emplace_back(subst.begin() + offset, subst.begin() + offset + out.exprs.size());
    offset += out.exprs.size();
  }
  return result;
}

namespace {
std::vector<FunctionIo> CopyInputs(const Function& f) {
  std::vector<FunctionIo> ins;
  for (int i = 0; i < f.NumInputs(); ++i) ins.emplace_back(f.InputName(i), f.InputSymbols(i));
  return ins;
}
std::vector<Expr> AllOutputs(const Function& f) {
  std::vector<Expr> all;
  for (int j = 0; j < f.NumOutputs(); ++j) {
    all.insert(all.end(), f.OutputExprs(j).begin(), f.OutputExprs(j).end());
  }
  return all;
}
}  // namespace

Function Function::Forward(int num_directions) const {
  std::vector<FunctionIo> ins = CopyInputs(*this);
  const std::vector<Expr> x = AllInputSymbols();
  std::vector<std::vector<Expr>> seeds;
  for (int d = 0; d < num_directions; ++d) {
    std::vector<Expr> seed;
    for (int i = 0; i < NumInputs(); ++i) {
      const std::string n = "fwd" + std::to_string(d) + "_" + InputName(i);
      auto s = Expr::Symbols(n, InputSize(i));
      seed.insert(seed.end(), s.begin(), s.end());
      ins.emplace_back(n, std::move(s));
    }
    seeds.push_back(std::move(seed));
  }
  const auto tangents = ForwardDerivative(AllOutputs(*this), x, seeds);
  std::vector<FunctionIo> outs;
  for (int d = 0; d < num_directions; ++d) {
    std::size_t offset = 0;
    for (int j = 0; j < NumOutputs(); ++j) {
      std::vector<Expr> t(tangents[d].begin() + offset,
                          tangents[d].begin() + offset + OutputSize(j));
      offset += OutputSize(j);
      outs.emplace_back("fwd" + std::to_string(d) + "_" + OutputName(j), std::move(t),
                        OutputSparsity(j));
    }
  }
  return Function(name() + "_fwd", std::move(ins), std::move(outs));
}

Function Function::Reverse(int num_directions) const {
  std::vector<FunctionIo> ins = CopyInputs(*this);
  const std::vector<Expr> x = AllInputSymbols();
  std::vector<std::vector<Expr>> seeds;
  for (int d = 0; d < num_directions; ++d) {
    std::vector<Expr> seed;
    for (int j = 0; j < NumOutputs(); ++j) {
      const std::string n = "adj" + std::to_string(d) + "_" + OutputName(j);
      auto s = Expr::Symbols(n, OutputSize(j));
      seed.insert(seed.end(), s.begin(), s.end());
      ins.emplace_back(n, std::move(s));
    }
    seeds.push_back(std::move(seed));
  }
  const auto adjoints = ReverseDerivative(AllOutputs(*this), x, seeds);
  std::vector<FunctionIo> outs;
  for (int d = 0; d < num_directions; ++d) {
    std::size_t offset = 0;
    for (int i = 0; i < NumInputs(); ++i) {
      std::vector<Expr> a(adjoints[d].begin() + offset,
                          adjoints[d].begin() + offset + InputSize(i));
      offset += InputSize(i);
      outs.emplace_back("adj" + std::to_string(d) + "_" + InputName(i), std::move(a));
    }
  }
  return Function(name() + "_rev", std::move(ins), std::move(outs));
}

Sparsity Function::JacobianSparsity(const std::string& output, const std::string& input) const {
  return expr::JacobianSparsity(OutputExprs(OutputIndex(output)), InputSymbols(InputIndex(input)));
}

Function Function::Jacobian(const std::string& output, const std::string& input) const {
  Sparsity pattern;
  std::vector<Expr> nz =
      SparseJacobian(OutputExprs(OutputIndex(output)), InputSymbols(InputIndex(input)), &pattern);
  const std::string n = "jac_" + output + "_" + input;
  return Function(name() + "_" + n, CopyInputs(*this), {FunctionIo(n, std::move(nz), pattern)});
}

Function Function::Gradient(const std::string& output, const std::string& input) const {
  const int j = OutputIndex(output);
  if (OutputSize(j) != 1) {
    throw std::invalid_argument("Function '" + name() + "'::Gradient: expected output '" + output +
                                "' with 1 entry, got " + std::to_string(OutputSize(j)));
  }
  std::vector<Expr> g = expr::Gradient(OutputExprs(j)[0], InputSymbols(InputIndex(input)));
  const std::string n = "grad_" + output + "_" + input;
  return Function(name() + "_" + n, CopyInputs(*this), {FunctionIo(n, std::move(g))});
}

Function Function::Hessian(const std::string& output, const std::string& input) const {
  const int j = OutputIndex(output);
  if (OutputSize(j) != 1) {
    throw std::invalid_argument("Function '" + name() + "'::Hessian: expected output '" + output +
                                "' with 1 entry, got " + std::to_string(OutputSize(j)));
  }
  const std::vector<Expr>& x = InputSymbols(InputIndex(input));
  const std::vector<Expr> g = expr::Gradient(OutputExprs(j)[0], x);
  Sparsity pattern;
  std::vector<Expr> nz = SparseHessian(g, x, &pattern);
  const std::string n = "hess_" + output + "_" + input;
  return Function(name() + "_" + n, CopyInputs(*this), {FunctionIo(n, std::move(nz), pattern)});
}

}  // namespace graybox::expr
