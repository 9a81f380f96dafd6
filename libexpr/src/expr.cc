#include "graybox/expr/expr.h"

#include <pthread.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <mutex>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "node.h"

namespace graybox::expr {
namespace internal {
namespace {

std::atomic<std::uint64_t> next_id{1};

struct Key {
  Op op;
  std::uint64_t value_bits;
  std::uint64_t a0, a1, a2;
  bool operator==(const Key& o) const {
    return op == o.op && value_bits == o.value_bits && a0 == o.a0 && a1 == o.a1 && a2 == o.a2;
  }
};

struct KeyHash {
  std::size_t operator()(const Key& k) const {
    std::uint64_t h = static_cast<std::uint64_t>(k.op) * 0x9E3779B97F4A7C15ULL;
    for (std::uint64_t v : {k.value_bits, k.a0, k.a1, k.a2}) {
      h ^= v + 0x9E3779B97F4A7C15ULL + (h << 6) + (h >> 2);
    }
    return static_cast<std::size_t>(h);
  }
};

// The hash-consing table. Entries hold weak references: a node lives as long as some Expr holds
// it; expired entries are swept when the table has doubled since the last sweep.
class NodeTable {
 public:
  // A process forked while another thread holds the table's lock would inherit it locked: fork
  // waits for the lock and both processes release it (a diagnosis runs re-fits in forked
  // processes while its other threads build expressions).
  NodeTable() {
    pthread_atfork([] { Table().mutex_.lock(); }, [] { Table().mutex_.unlock(); },
                   [] { Table().mutex_.unlock(); });
  }
  // The process' one table.
  static NodeTable& Table();

  std::shared_ptr<const Node> Intern(const Key& key, Node&& proto) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = table_.find(key);
    if (it != table_.end()) {
      if (auto alive = it->second.lock()) return alive;
    }
    auto node = std::make_shared<Node>(std::move(proto));
    node->id = next_id.fetch_add(1, std::memory_order_relaxed);
    std::shared_ptr<const Node> result = node;
    if (it != table_.end()) {
      it->second = result;
    } else {
      table_.emplace(key, result);
      if (table_.size() > 2 * swept_size_ + 1024) Sweep();
    }
    return result;
  }

 private:
  void Sweep() {
    for (auto it = table_.begin(); it != table_.end();) {
      if (it->second.expired()) {
        it = table_.erase(it);
      } else {
        ++it;
      }
    }
    swept_size_ = table_.size();
  }

  std::mutex mutex_;
  std::unordered_map<Key, std::weak_ptr<const Node>, KeyHash> table_;
  std::size_t swept_size_ = 0;
};

NodeTable& NodeTable::Table() {
  static NodeTable* table = new NodeTable();  // never destroyed: Exprs may outlive statics
  return *table;
}

NodeTable& Table() { return NodeTable::Table(); }

std::uint64_t Bits(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

std::shared_ptr<const Node> InternConstant(double v);

std::shared_ptr<const Node> MakeConstant(double v) {
  // 0 and 1 are by far the most frequent constants (Eigen zero-initialises, seeds are 0/1):
  // keep them alive for good and skip the table lookup.
  static const std::shared_ptr<const Node> zero = InternConstant(0.0);
  static const std::shared_ptr<const Node> one = InternConstant(1.0);
  // -0.0 is a node of its own (the table is keyed by bits): folding keeps the sign of zero as
  // IEEE arithmetic and the tape do (1/-(0) = -inf, atan2(-(0), -1) = -pi). Both zeros are zero
  // for the simplifications, which compare values (IsZero).
  if (v == 0.0 && !std::signbit(v)) return zero;
  if (v == 1.0) return one;
  return InternConstant(v);
}

std::shared_ptr<const Node> InternConstant(double v) {
  Node proto;
  proto.op = Op::kConstant;
  proto.value = v;
  Key key{Op::kConstant, Bits(v), 0, 0, 0};
  return Table().Intern(key, std::move(proto));
}

// Iteratively released children, so destroying a long chain does not recurse deeply.
thread_local std::vector<std::shared_ptr<const Node>>* pending_release = nullptr;

}  // namespace

Node::~Node() {
  std::vector<std::shared_ptr<const Node>> local;
  const bool owner = pending_release == nullptr;
  if (owner) pending_release = &local;
  for (auto& a : args) {
    if (a) pending_release->push_back(std::move(a));
  }
  if (owner) {
    while (!local.empty()) {
      auto p = std::move(local.back());
      local.pop_back();
      p.reset();
    }
    pending_release = nullptr;
  }
}

std::vector<const Node*> Roots(const std::vector<Expr>& exprs) {
  std::vector<const Node*> roots;
  roots.reserve(exprs.size());
  for (const Expr& e : exprs) roots.push_back(e.node());
  return roots;
}

std::vector<const Node*> TopologicalOrder(const std::vector<const Node*>& roots) {
  std::vector<const Node*> order;
  std::unordered_map<const Node*, bool> visited;  // true once emitted
  std::vector<std::pair<const Node*, int>> stack;
  for (const Node* root : roots) {
    if (visited.count(root)) continue;
    stack.push_back({root, 0});
    visited[root] = false;
    while (!stack.empty()) {
      auto& [n, next] = stack.back();
      const int arity = Arity(n->op);
      if (next < arity) {
        const Node* child = n->args[next++].get();
        if (!visited.count(child)) {
          visited[child] = false;
          stack.push_back({child, 0});
        }
      } else {
        visited[n] = true;
        order.push_back(n);
        stack.pop_back();
      }
    }
  }
  return order;
}

Expr Share(const Node* node) {
  // Every node is created by make_shared in NodeTable, so it is owned by a control block; the
  // caller's raw pointer comes from a live Expr, which keeps it alive.
  return Expr(node->shared_from_this());
}

}  // namespace internal

using internal::Node;

namespace {

Expr MakeRaw(Op op, const Expr* a) {
  Node proto;
  proto.op = op;
  const int arity = Arity(op);
  std::uint64_t ids[3] = {0, 0, 0};
  for (int i = 0; i < arity; ++i) {
    proto.args[i] = a[i].node()->shared_from_this();
    ids[i] = a[i].Id();
    proto.depends_on_symbols = proto.depends_on_symbols || a[i].DependsOnSymbols();
  }
  internal::Key key{op, 0, ids[0], ids[1], ids[2]};
  return Expr(internal::Table().Intern(key, std::move(proto)));
}

// Simplifications of the trivial cases; returns true and sets `out` when one applies.
bool Simplify(Op op, const Expr* a, Expr* out) {
  const Expr& x = a[0];
  const Expr& y = a[1];
  switch (op) {
    case Op::kAdd:
      if (x.IsZero()) return *out = y, true;
      if (y.IsZero()) return *out = x, true;
      // a + (-b) and (-a) + b are exactly a - b and b - a in IEEE arithmetic.
      if (y.op() == Op::kNeg) return *out = x - y.Arg(0), true;
      if (x.op() == Op::kNeg) return *out = y - x.Arg(0), true;
      return false;
    case Op::kSub:
      if (y.IsZero()) return *out = x, true;
      if (x.IsZero()) return *out = -y, true;
      if (x.IsSame(y)) return *out = Expr(0.0), true;
      if (y.op() == Op::kNeg) return *out = x + y.Arg(0), true;  // a - (-b) = a + b exactly
      return false;
    case Op::kMul:
      if (x.IsZero() || y.IsZero()) return *out = Expr(0.0), true;
      if (x.IsOne()) return *out = y, true;
      if (y.IsOne()) return *out = x, true;
      if (x.IsConstant(-1.0)) return *out = -y, true;
      if (y.IsConstant(-1.0)) return *out = -x, true;
      return false;
    case Op::kDiv:
      if (y.IsOne()) return *out = x, true;
      if (x.IsZero()) return *out = Expr(0.0), true;
      return false;
    case Op::kNeg:
      if (x.op() == Op::kNeg) return *out = x.Arg(0), true;
      return false;
    case Op::kPow:
      if (y.IsOne()) return *out = x, true;
      if (y.IsZero()) return *out = Expr(1.0), true;
      return false;
    case Op::kIfElse:
      if (x.IsConstant()) return *out = (x.Value() != 0.0 ? a[1] : a[2]), true;
      if (a[1].IsSame(a[2])) return *out = a[1], true;
      return false;
    default:
      return false;
  }
}

Expr MakeOp(Op op, Expr a0, Expr a1 = Expr(), Expr a2 = Expr()) {
  Expr a[3] = {std::move(a0), std::move(a1), std::move(a2)};
  const int arity = Arity(op);
  bool all_constant = true;
  for (int i = 0; i < arity; ++i) all_constant = all_constant && a[i].IsConstant();
  if (all_constant) {
    double v[3] = {0, 0, 0};
    for (int i = 0; i < arity; ++i) v[i] = a[i].Value();
    return Expr(EvaluateOp(op, v));
  }
  Expr simplified;
  if (Simplify(op, a, &simplified)) return simplified;
  if (IsCommutative(op) && a[1].Id() < a[0].Id()) std::swap(a[0], a[1]);
  return MakeRaw(op, a);
}

}  // namespace

Expr::Expr() : Expr(0.0) {}
Expr::Expr(double value) : node_(internal::MakeConstant(value)) {}

Expr Expr::Symbol(const std::string& name) {
  Node proto;
  proto.op = Op::kSymbol;
  proto.name = name;
  proto.depends_on_symbols = true;
  // Symbols are never merged: the key carries a fresh id.
  static std::atomic<std::uint64_t> symbol_counter{1};
  internal::Key key{Op::kSymbol, symbol_counter.fetch_add(1), 0, 0, 0};
  return Expr(internal::Table().Intern(key, std::move(proto)));
}

std::vector<Expr> Expr::Symbols(const std::string& name, int n) {
  std::vector<Expr> s;
  s.reserve(n);
  for (int i = 0; i < n; ++i) s.push_back(Symbol(name + "_" + std::to_string(i)));
  return s;
}

Expr Expr::Make(Op op, const std::vector<Expr>& args) {
  if (op == Op::kConstant || op == Op::kSymbol) {
    throw std::invalid_argument("Expr::Make: expected an operation, got a constant or symbol op");
  }
  if (static_cast<int>(args.size()) != Arity(op)) {
    throw std::invalid_argument(std::string("Expr::Make(") + OpName(op) + "): expected " +
                                std::to_string(Arity(op)) + " arguments, got " +
                                std::to_string(args.size()));
  }
  return MakeOp(op, args[0], args.size() > 1 ? args[1] : Expr(),
                args.size() > 2 ? args[2] : Expr());
}

Op Expr::op() const { return node_->op; }
bool Expr::IsConstant(double v) const { return node_->op == Op::kConstant && node_->value == v; }
double Expr::Value() const {
  if (node_->op != Op::kConstant) {
    throw std::logic_error("Expr::Value: expected a constant, got " + ToString());
  }
  return node_->value;
}
const std::string& Expr::Name() const { return node_->name; }
Expr Expr::Arg(int i) const {
  if (i < 0 || i >= NumArgs()) {
    throw std::out_of_range("Expr::Arg: expected index in [0, " + std::to_string(NumArgs()) +
                            "), got " + std::to_string(i));
  }
  return Expr(node_->args[i]);
}
std::uint64_t Expr::Id() const { return node_->id; }
bool Expr::DependsOnSymbols() const { return node_->depends_on_symbols; }
std::size_t Expr::CountNodes() const { return internal::TopologicalOrder({node()}).size(); }

std::size_t CountNodes(const std::vector<Expr>& exprs) {
  return internal::TopologicalOrder(internal::Roots(exprs)).size();
}

namespace {

// Rendering stops after this many characters (see Expr::ToString).
constexpr std::size_t kMaxRenderedChars = 65536;

// Iterative, so any depth renders without recursion, and bounded, so a DAG whose expansion is
// exponential (e = e*e repeated) stops early. A work item is a node to render or a fixed text.
std::string Render(const Node* root) {
  struct Item {
    const Node* node;
    const char* text;
  };
  std::vector<Item> stack{{root, nullptr}};
  std::string out;
  std::ostringstream number;
  number.precision(17);
  while (!stack.empty()) {
    if (out.size() > kMaxRenderedChars) {
      out += "...";
      break;
    }
    const Item item = stack.back();
    stack.pop_back();
    if (item.text != nullptr) {
      out += item.text;
      continue;
    }
    const Node* n = item.node;
    switch (n->op) {
      case Op::kConstant:
        number.str("");
        number << n->value;
        out += number.str();
        break;
      case Op::kSymbol:
        out += n->name;
        break;
      case Op::kAdd:
      case Op::kSub:
      case Op::kMul:
      case Op::kDiv:
      case Op::kLt:
      case Op::kLe:
      case Op::kEq:
      case Op::kNe:
      case Op::kAnd:
      case Op::kOr:  // (a op b)
        out += '(';
        stack.push_back({nullptr, ")"});
        stack.push_back({n->args[1].get(), nullptr});
        stack.push_back({nullptr, OpName(n->op)});
        stack.push_back({n->args[0].get(), nullptr});
        break;
      case Op::kNeg:  // (-a)
        out += "(-";
        stack.push_back({nullptr, ")"});
        stack.push_back({n->args[0].get(), nullptr});
        break;
      default: {  // name(a, b, ...)
        out += OpName(n->op);
        out += '(';
        stack.push_back({nullptr, ")"});
        for (int i = Arity(n->op) - 1; i >= 0; --i) {
          stack.push_back({n->args[i].get(), nullptr});
          if (i > 0) stack.push_back({nullptr, ", "});
        }
      }
    }
  }
  return out;
}

}  // namespace

std::string Expr::ToString() const { return Render(node()); }

std::ostream& operator<<(std::ostream& os, const Expr& e) { return os << e.ToString(); }

Expr& Expr::operator+=(const Expr& b) { return *this = *this + b; }
Expr& Expr::operator-=(const Expr& b) { return *this = *this - b; }
Expr& Expr::operator*=(const Expr& b) { return *this = *this * b; }
Expr& Expr::operator/=(const Expr& b) { return *this = *this / b; }

Expr operator+(const Expr& a, const Expr& b) { return MakeOp(Op::kAdd, a, b); }
Expr operator-(const Expr& a, const Expr& b) { return MakeOp(Op::kSub, a, b); }
Expr operator*(const Expr& a, const Expr& b) { return MakeOp(Op::kMul, a, b); }
Expr operator/(const Expr& a, const Expr& b) { return MakeOp(Op::kDiv, a, b); }
Expr operator-(const Expr& a) { return MakeOp(Op::kNeg, a); }

bool operator==(const Expr& a, const Expr& b) {
  if (a.IsConstant() && b.IsConstant()) return a.Value() == b.Value();
  return a.IsSame(b);
}
bool operator!=(const Expr& a, const Expr& b) { return !(a == b); }

Expr pow(const Expr& x, const Expr& y) { return MakeOp(Op::kPow, x, y); }
Expr sqrt(const Expr& x) { return MakeOp(Op::kSqrt, x); }
Expr exp(const Expr& x) { return MakeOp(Op::kExp, x); }
Expr log(const Expr& x) { return MakeOp(Op::kLog, x); }
Expr sin(const Expr& x) { return MakeOp(Op::kSin, x); }
Expr cos(const Expr& x) { return MakeOp(Op::kCos, x); }
Expr tan(const Expr& x) { return MakeOp(Op::kTan, x); }
Expr atan(const Expr& x) { return MakeOp(Op::kAtan, x); }
Expr atan2(const Expr& y, const Expr& x) { return MakeOp(Op::kAtan2, y, x); }
Expr tanh(const Expr& x) { return MakeOp(Op::kTanh, x); }
Expr abs(const Expr& x) { return MakeOp(Op::kAbs, x); }
Expr fabs(const Expr& x) { return MakeOp(Op::kAbs, x); }
Expr erf(const Expr& x) { return MakeOp(Op::kErf, x); }
Expr min(const Expr& a, const Expr& b) { return MakeOp(Op::kMin, a, b); }
Expr max(const Expr& a, const Expr& b) { return MakeOp(Op::kMax, a, b); }
Expr square(const Expr& x) { return x * x; }
Expr sigmoid(const Expr& x) { return MakeOp(Op::kSigmoid, x); }
Expr softplus(const Expr& x) { return MakeOp(Op::kSoftplus, x); }
Expr sign(const Expr& x) { return MakeOp(Op::kSign, x); }

double sigmoid(double x) {
  const double a[1] = {x};
  return EvaluateOp(Op::kSigmoid, a);
}
double softplus(double x) {
  const double a[1] = {x};
  return EvaluateOp(Op::kSoftplus, a);
}
double sign(double x) {
  const double a[1] = {x};
  return EvaluateOp(Op::kSign, a);
}

Expr lt(const Expr& a, const Expr& b) { return MakeOp(Op::kLt, a, b); }
Expr le(const Expr& a, const Expr& b) { return MakeOp(Op::kLe, a, b); }
Expr gt(const Expr& a, const Expr& b) { return MakeOp(Op::kLt, b, a); }
Expr ge(const Expr& a, const Expr& b) { return MakeOp(Op::kLe, b, a); }
Expr eq(const Expr& a, const Expr& b) { return MakeOp(Op::kEq, a, b); }
Expr ne(const Expr& a, const Expr& b) { return MakeOp(Op::kNe, a, b); }
Expr logical_and(const Expr& a, const Expr& b) { return MakeOp(Op::kAnd, a, b); }
Expr logical_or(const Expr& a, const Expr& b) { return MakeOp(Op::kOr, a, b); }
Expr logical_not(const Expr& a) { return MakeOp(Op::kNot, a); }
Expr if_else(const Expr& c, const Expr& a, const Expr& b) { return MakeOp(Op::kIfElse, c, a, b); }

std::vector<Expr> Substitute(const std::vector<Expr>& exprs, const std::vector<Expr>& from,
                             const std::vector<Expr>& to) {
  if (from.size() != to.size()) {
    throw std::invalid_argument("Substitute: expected as many replacements as symbols (" +
                                std::to_string(from.size()) + "), got " +
                                std::to_string(to.size()));
  }
  std::unordered_map<const Node*, Expr> map;
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (!from[i].IsSymbol()) {
      throw std::invalid_argument("Substitute: expected a symbol at position " + std::to_string(i) +
                                  ", got " + from[i].ToString());
    }
    map[from[i].node()] = to[i];
  }
  const auto order = internal::TopologicalOrder(internal::Roots(exprs));
  for (const Node* n : order) {
    if (map.count(n)) continue;
    if (!n->depends_on_symbols || n->op == Op::kSymbol) {
      map[n] = internal::Share(n);
      continue;
    }
    Expr a[3];
    bool changed = false;
    for (int i = 0; i < Arity(n->op); ++i) {
      a[i] = map.at(n->args[i].get());
      changed = changed || a[i].node() != n->args[i].get();
    }
    map[n] = changed ? MakeOp(n->op, a[0], a[1], a[2]) : internal::Share(n);
  }
  std::vector<Expr> out;
  out.reserve(exprs.size());
  for (const Expr& e : exprs) out.push_back(map.at(e.node()));
  return out;
}

std::vector<Expr> FreeSymbols(const std::vector<Expr>& exprs) {
  std::vector<Expr> symbols;
  for (const Node* n : internal::TopologicalOrder(internal::Roots(exprs))) {
    if (n->op == Op::kSymbol) symbols.push_back(internal::Share(n));
  }
  return symbols;
}

}  // namespace graybox::expr
