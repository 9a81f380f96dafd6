#include "tape.h"

#include <algorithm>
#include <array>
#include <limits>
#include <unordered_map>
#include <unordered_set>

#include "node.h"
#include "op_defs.h"

namespace graybox::expr {

using internal::Node;
using internal::OpDef;

namespace {
// Code_<name>: the tape opcode of every graph operation and fused form, for the dispatch macros.
#define GRAYBOX_TAPE_CODE_CONST(e, n, s) \
  constexpr std::uint8_t Code_##e = static_cast<std::uint8_t>(Op::e);
GRAYBOX_EXPR_OPS(GRAYBOX_TAPE_CODE_CONST)
#undef GRAYBOX_TAPE_CODE_CONST
constexpr std::uint8_t Code_kMulAdd = tape_code::kMulAdd;
constexpr std::uint8_t Code_kMulSub = tape_code::kMulSub;
constexpr std::uint8_t Code_kSubMul = tape_code::kSubMul;
}  // namespace

namespace {

struct Pending {
  std::uint8_t code;
  const Node* result;
  std::array<const Node*, 3> operands;
  int arity;
};

// Reorders a topologically sorted instruction list into runs of equal opcodes: a ready list per
// opcode; the opcode with the most ready instructions is drained (including instructions that
// become ready meanwhile) before switching.
std::vector<Pending> GroupByOpcode(const std::vector<Pending>& in) {
  const std::size_t n = in.size();
  std::unordered_map<const Node*, int> producer;
  for (std::size_t k = 0; k < n; ++k) producer[in[k].result] = static_cast<int>(k);
  std::vector<int> waiting(n, 0);
  std::vector<std::vector<int>> users(n);
  for (std::size_t k = 0; k < n; ++k) {
    for (int a = 0; a < in[k].arity; ++a) {
      auto it = producer.find(in[k].operands[a]);
      if (it == producer.end()) continue;
      bool duplicate = false;
      for (int b = 0; b < a; ++b) duplicate = duplicate || in[k].operands[b] == in[k].operands[a];
      if (duplicate) continue;
      ++waiting[k];
      users[it->second].push_back(static_cast<int>(k));
    }
  }
  std::vector<std::vector<int>> ready(tape_code::kCount);
  std::size_t num_ready = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (waiting[k] == 0) {
      ready[in[k].code].push_back(static_cast<int>(k));
      ++num_ready;
    }
  }
  std::vector<Pending> out;
  out.reserve(n);
  while (num_ready > 0) {
    std::size_t code = 0;
    for (std::size_t c = 1; c < ready.size(); ++c) {
      if (ready[c].size() > ready[code].size()) code = c;
    }
    // Drain this opcode; its queue may grow while draining (FIFO keeps dependency order).
    for (std::size_t head = 0; head < ready[code].size(); ++head) {
      const int k = ready[code][head];
      out.push_back(in[k]);
      --num_ready;
      for (int u : users[k]) {
        if (--waiting[u] == 0) {
          ready[in[u].code].push_back(u);
          ++num_ready;
        }
      }
    }
    ready[code].clear();
  }
  return out;
}

}  // namespace

Tape::Tape(const std::vector<std::vector<Expr>>& inputs,
           const std::vector<std::vector<Expr>>& outputs, Schedule schedule) {
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

  const std::unordered_set<const Node*> root_set = [&] {
    std::unordered_set<const Node*> set;
    for (const Expr& e : roots) set.insert(e.node());
    return set;
  }();
  std::vector<int> use_count(order.size(), 0);
  for (const Node* n : order) {
    for (int a = 0; a < Arity(n->op); ++a) ++use_count[position[n->args[a].get()]];
  }
  auto fusable_mul = [&](const Node* m) {
    return m->op == Op::kMul && use_count[position[m]] == 1 && !root_set.count(m);
  };

  // Instructions as (code, result node, operand nodes); fused multiplications are not emitted.
  std::vector<Pending> pending;
  std::unordered_set<const Node*> fused;
  pending.reserve(order.size());
  for (const Node* n : order) {
    if (n->op == Op::kConstant || n->op == Op::kSymbol) continue;
    const Node* x = n->args[0].get();
    const Node* y = n->args[1].get();
    if (n->op == Op::kAdd && x != y && (fusable_mul(x) || fusable_mul(y))) {
      const Node* m = fusable_mul(x) ? x : y;
      const Node* other = m == x ? y : x;
      pending.push_back({tape_code::kMulAdd, n, {m->args[0].get(), m->args[1].get(), other}, 3});
      fused.insert(m);
    } else if (n->op == Op::kSub && x != y && fusable_mul(x)) {
      pending.push_back({tape_code::kMulSub, n, {x->args[0].get(), x->args[1].get(), y}, 3});
      fused.insert(x);
    } else if (n->op == Op::kSub && x != y && fusable_mul(y)) {
      pending.push_back({tape_code::kSubMul, n, {y->args[0].get(), y->args[1].get(), x}, 3});
      fused.insert(y);
    } else {
      const int arity = Arity(n->op);
      Pending p{static_cast<std::uint8_t>(n->op), n, {nullptr, nullptr, nullptr}, arity};
      for (int a = 0; a < arity; ++a) p.operands[a] = n->args[a].get();
      pending.push_back(p);
    }
  }
  // A fused multiplication was emitted before its user; drop it now that the user reads its
  // operands directly.
  pending.erase(std::remove_if(pending.begin(), pending.end(),
                               [&](const Pending& p) { return fused.count(p.result) > 0; }),
                pending.end());

  if (schedule == Schedule::kGroupedByOpcode) pending = GroupByOpcode(pending);

  // Last use (instruction index) of every value; outputs live to the end.
  constexpr int kForever = std::numeric_limits<int>::max();
  std::unordered_map<const Node*, int> last_use;
  for (std::size_t k = 0; k < pending.size(); ++k) {
    for (int a = 0; a < pending[k].arity; ++a)
      last_use[pending[k].operands[a]] = static_cast<int>(k);
  }
  for (const Expr& e : roots) last_use[e.node()] = kForever;

  std::vector<int> free_list;
  int num_registers = num_pinned;
  code_.reserve(pending.size() + 1);
  for (std::size_t k = 0; k < pending.size(); ++k) {
    const Pending& p = pending[k];
    Instruction ins{p.code, 0, 0, 0, 0};
    std::int32_t* slots[3] = {&ins.a, &ins.b, &ins.c};
    for (int a = 0; a < p.arity; ++a) *slots[a] = reg.at(p.operands[a]);
    // Free dead operands first so the result may reuse one of their registers.
    for (int a = 0; a < p.arity; ++a) {
      const Node* operand = p.operands[a];
      const int r = reg.at(operand);
      bool duplicate = false;
      for (int b = 0; b < a; ++b) duplicate = duplicate || p.operands[b] == operand;
      if (!duplicate && r >= num_pinned && last_use.at(operand) == static_cast<int>(k)) {
        free_list.push_back(r);
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
    reg[p.result] = r;
    code_.push_back(ins);
  }
  num_registers_ = num_registers;
  // Sentinel that ends Run's threaded dispatch; code() hides it.
  code_.push_back(Instruction{tape_code::kEnd, 0, 0, 0, 0});

  output_registers_.resize(outputs.size());
  for (std::size_t j = 0; j < outputs.size(); ++j) {
    for (const Expr& e : outputs[j]) output_registers_[j].push_back(reg.at(e.node()));
  }
}

namespace {

// Value of one instruction on one point; the fused forms compose the op table's definitions.
template <std::uint8_t kCode>
inline double Apply(double x, double y, double z) {
  if constexpr (kCode == tape_code::kMulAdd || kCode == tape_code::kMulSub ||
                kCode == tape_code::kSubMul) {
    const double m[2] = {x, y};
    const double product = OpDef<Op::kMul>::F(m);
    if constexpr (kCode == tape_code::kMulAdd) {
      const double v[2] = {product, z};
      return OpDef<Op::kAdd>::F(v);
    } else if constexpr (kCode == tape_code::kMulSub) {
      const double v[2] = {product, z};
      return OpDef<Op::kSub>::F(v);
    } else {
      const double v[2] = {z, product};
      return OpDef<Op::kSub>::F(v);
    }
  } else {
    const double v[3] = {x, y, z};
    return OpDef<static_cast<Op>(kCode)>::F(v);
  }
}

template <std::uint8_t kCode>
inline void Lanes(double* r, const Instruction& in) {
  constexpr int L = Tape::kLanes;
  double* out = r + static_cast<std::ptrdiff_t>(in.out) * L;
  const double* a = r + static_cast<std::ptrdiff_t>(in.a) * L;
  const double* b = r + static_cast<std::ptrdiff_t>(in.b) * L;
  const double* c = r + static_cast<std::ptrdiff_t>(in.c) * L;
  // out may equal a, b or c; computing into a local first lets the compiler vectorise without
  // alias checks.
  double tmp[L];
  for (int l = 0; l < L; ++l) tmp[l] = Apply<kCode>(a[l], b[l], c[l]);
  for (int l = 0; l < L; ++l) out[l] = tmp[l];
}

}  // namespace

#define GRAYBOX_TAPE_CODES(X)   \
  GRAYBOX_EXPR_OPS_NO_LEAVES(X) \
  X(kMulAdd, 3, "") X(kMulSub, 3, "") X(kSubMul, 3, "")

void Tape::Run(double* r) const {
  const Instruction* ip = code_.data();
#if defined(__GNUC__)
  // Threaded dispatch: one indirect jump per handler (better branch prediction than one switch).
  static const void* const kLabels[tape_code::kCount] = {
#define GRAYBOX_EXPR_LABEL(e, n, s) &&label_##e,
      GRAYBOX_EXPR_OPS(GRAYBOX_EXPR_LABEL)
#undef GRAYBOX_EXPR_LABEL
          && label_kMulAdd,
      &&label_kMulSub, &&label_kSubMul, &&label_end};
  goto* kLabels[ip->code];
#define GRAYBOX_TAPE_HANDLER(e, n, s)                           \
  label_##e : do {                                              \
    r[ip->out] = Apply<Code_##e>(r[ip->a], r[ip->b], r[ip->c]); \
    ++ip;                                                       \
  }                                                             \
  while (ip->code == Code_##e)                                  \
    ;                                                           \
  goto* kLabels[ip->code];
  GRAYBOX_TAPE_CODES(GRAYBOX_TAPE_HANDLER)
#undef GRAYBOX_TAPE_HANDLER
label_kConstant:
label_kSymbol:
label_end:
  return;
#else
  for (; ip->code != tape_code::kEnd; ++ip) {
    switch (ip->code) {
#define GRAYBOX_TAPE_CASE(e, n, s)                              \
  case Code_##e:                                                \
    r[ip->out] = Apply<Code_##e>(r[ip->a], r[ip->b], r[ip->c]); \
    break;
      GRAYBOX_TAPE_CODES(GRAYBOX_TAPE_CASE)
#undef GRAYBOX_TAPE_CASE
      default:
        break;
    }
  }
#endif
}

void Tape::RunBatch(double* r) const {
  for (const Instruction& in : code()) {
    switch (in.code) {
#define GRAYBOX_TAPE_CASE(e, n, s) \
  case Code_##e:                   \
    Lanes<Code_##e>(r, in);        \
    break;
      GRAYBOX_TAPE_CODES(GRAYBOX_TAPE_CASE)
#undef GRAYBOX_TAPE_CASE
      default:
        break;
    }
  }
}

}  // namespace graybox::expr
