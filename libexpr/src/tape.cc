#include "tape.h"

#include <limits>
#include <unordered_map>

#include "node.h"
#include "op_defs.h"

namespace graybox::expr {

using internal::Node;
using internal::OpDef;

Tape::Tape(const std::vector<std::vector<Expr>>& inputs,
           const std::vector<std::vector<Expr>>& outputs) {
  std::vector<Expr> roots;
  for (const auto& out : outputs) roots.insert(roots.end(), out.begin(), out.end());
  const std::vector<const Node*> order = internal::TopologicalOrder(internal::Roots(roots));

  std::unordered_map<const Node*, int> position;
  for (std::size_t k = 0; k < order.size(); ++k) position[order[k]] = static_cast<int>(k);

  // Pinned registers: used inputs, then constants.
  std::unordered_map<const Node*, int> reg;
  int next = 0;
  input_registers_.resize(inputs.size());
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    for (const Expr& s : inputs[i]) {
      const bool used = position.count(s.node()) > 0;
      int r = -1;
      if (used) {
        r = next++;
        reg[s.node()] = r;
      }
      input_registers_[i].push_back(r);
    }
  }
  for (const Node* n : order) {
    if (n->op == Op::kConstant) {
      reg[n] = next;
      constants_.push_back({next++, n->value});
    }
  }
  const int num_pinned = next;

  // Last use of every operation node (outputs live to the end).
  constexpr int kForever = std::numeric_limits<int>::max();
  std::vector<int> last_use(order.size(), -1);
  for (std::size_t k = 0; k < order.size(); ++k) {
    for (int a = 0; a < Arity(order[k]->op); ++a) {
      last_use[position[order[k]->args[a].get()]] = static_cast<int>(k);
    }
  }
  for (const Expr& e : roots) last_use[position[e.node()]] = kForever;

  std::vector<int> free_list;
  int num_registers = num_pinned;
  for (std::size_t k = 0; k < order.size(); ++k) {
    const Node* n = order[k];
    if (n->op == Op::kConstant || n->op == Op::kSymbol) continue;
    Instruction ins{n->op, 0, 0, 0, 0};
    std::int32_t* arg_slots[3] = {&ins.a, &ins.b, &ins.c};
    const int arity = Arity(n->op);
    for (int a = 0; a < arity; ++a) *arg_slots[a] = reg.at(n->args[a].get());
    // Free dead arguments first so the result may reuse one of their registers.
    for (int a = 0; a < arity; ++a) {
      const Node* arg = n->args[a].get();
      const int r = reg.at(arg);
      if (r >= num_pinned && last_use[position[arg]] == static_cast<int>(k)) {
        bool duplicate = false;
        for (int b = 0; b < a; ++b) duplicate = duplicate || n->args[b].get() == arg;
        if (!duplicate) free_list.push_back(r);
      }
    }
    int r;
    if (!free_list.empty()) {
      r = free_list.back();
      free_list.pop_back();
    } else {
      r = num_registers++;
    }
    ins.out = r;
    reg[n] = r;
    if (last_use[k] < 0) free_list.push_back(r);  // unused (cannot happen for roots)
    code_.push_back(ins);
  }
  num_registers_ = num_registers;

  output_registers_.resize(outputs.size());
  for (std::size_t j = 0; j < outputs.size(); ++j) {
    for (const Expr& e : outputs[j]) output_registers_[j].push_back(reg.at(e.node()));
  }
}

void Tape::Run(double* r) const {
  for (const Instruction& in : code_) {
    const double v[3] = {r[in.a], r[in.b], r[in.c]};
    double result;
    switch (in.op) {
#define GRAYBOX_EXPR_CASE(e, n, s) \
  case Op::e:                      \
    result = OpDef<Op::e>::F(v);   \
    break;
      GRAYBOX_EXPR_OPS_NO_LEAVES(GRAYBOX_EXPR_CASE)
#undef GRAYBOX_EXPR_CASE
      default:
        result = std::numeric_limits<double>::quiet_NaN();
    }
    r[in.out] = result;
  }
}

namespace {

template <Op op>
inline void Lanes(double* r, const Instruction& in) {
  constexpr int L = Tape::kLanes;
  double* out = r + static_cast<std::ptrdiff_t>(in.out) * L;
  const double* a = r + static_cast<std::ptrdiff_t>(in.a) * L;
  const double* b = r + static_cast<std::ptrdiff_t>(in.b) * L;
  const double* c = r + static_cast<std::ptrdiff_t>(in.c) * L;
  double tmp[L];
  for (int l = 0; l < L; ++l) {
    const double v[3] = {a[l], b[l], c[l]};
    tmp[l] = OpDef<op>::F(v);
  }
  for (int l = 0; l < L; ++l) out[l] = tmp[l];
}

}  // namespace

void Tape::RunBatch(double* r) const {
  for (const Instruction& in : code_) {
    switch (in.op) {
#define GRAYBOX_EXPR_CASE(e, n, s) \
  case Op::e:                      \
    Lanes<Op::e>(r, in);           \
    break;
      GRAYBOX_EXPR_OPS_NO_LEAVES(GRAYBOX_EXPR_CASE)
#undef GRAYBOX_EXPR_CASE
      default:
        break;
    }
  }
}

}  // namespace graybox::expr
