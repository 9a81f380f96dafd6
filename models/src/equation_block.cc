#include "graybox/models/equation_block.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "builtin_blocks.h"
#include "graybox/util/did_you_mean.h"

namespace graybox::models {
namespace {

constexpr double kPi = 3.14159265358979323846;

// ---- Expression trees ---------------------------------------------------------------------------

enum class Source { kInput, kState, kParameter, kOutput };

struct Node {
  enum class Kind { kNumber, kSymbol, kNegate, kBinary, kCall };
  Kind kind = Kind::kNumber;
  double value = 0.0;  // kNumber (constants are folded to numbers)
  Source source = Source::kInput;
  int index = 0;   // kSymbol
  std::string op;  // kBinary: + - * / ^ < <= > >= == !=; kCall: the function
  std::vector<Node> args;
};

struct Function {
  const char* name;
  int arity;
};
constexpr Function kFunctions[] = {
    {"sqrt", 1},       {"exp", 1},        {"log", 1},     {"sin", 1},        {"cos", 1},
    {"tan", 1},        {"atan", 1},       {"tanh", 1},    {"abs", 1},        {"sign", 1},
    {"erf", 1},        {"square", 1},     {"sigmoid", 1}, {"softplus", 1},   {"atan2", 2},
    {"min", 2},        {"max", 2},        {"pow", 2},     {"smooth_abs", 2}, {"smooth_sign", 2},
    {"smooth_max", 3}, {"smooth_min", 3}, {"if_else", 3},
};

const Function* FindFunction(const std::string& name) {
  for (const Function& f : kFunctions) {
    if (name == f.name) return &f;
  }
  return nullptr;
}

std::vector<std::string> FunctionNames() {
  std::vector<std::string> names;
  for (const Function& f : kFunctions) names.emplace_back(f.name);
  return names;
}

// What a name in an expression may refer to.
struct Symbol {
  Source source;
  int index;
};
struct Scope {
  std::map<std::string, Symbol> symbols;
  std::map<std::string, double> constants;
  std::vector<std::string> Names() const {
    std::vector<std::string> n;
    for (const auto& [k, v] : symbols) n.push_back(k);
    for (const auto& [k, v] : constants) n.push_back(k);
    n.emplace_back("pi");
    return n;
  }
};

// Recursive descent over one expression (the grammar of the header).
class Parser {
 public:
  Parser(std::string field, const std::string& text, const Scope& scope)
      : field_(std::move(field)), text_(text), scope_(scope) {}

  Node Parse() {
    Skip();
    if (pos_ >= text_.size()) Fail(pos_, "expected an expression, got an empty text");
    Node n = Comparison();
    Skip();
    if (pos_ < text_.size()) {
      Fail(pos_, "expected an operator or the end, got '" + std::string(1, text_[pos_]) + "'");
    }
    return n;
  }

 private:
  [[noreturn]] void Fail(std::size_t at, const std::string& message) const {
    throw EquationError(field_, static_cast<int>(at), message);
  }
  void Skip() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
  }
  bool Eat(const std::string& token) {
    Skip();
    if (text_.compare(pos_, token.size(), token) == 0) {
      pos_ += token.size();
      return true;
    }
    return false;
  }
  static Node Binary(const std::string& op, Node a, Node b) {
    Node n;
    n.kind = Node::Kind::kBinary;
    n.op = op;
    n.args.push_back(std::move(a));
    n.args.push_back(std::move(b));
    return n;
  }
  Node Comparison() {
    Node a = Additive();
    for (const char* op : {"<=", ">=", "==", "!=", "<", ">"}) {
      if (Eat(op)) return Binary(op, std::move(a), Additive());
    }
    return a;
  }
  Node Additive() {
    Node a = Term();
    for (;;) {
      if (Eat("+")) {
        a = Binary("+", std::move(a), Term());
      } else if (Eat("-")) {
        a = Binary("-", std::move(a), Term());
      } else {
        return a;
      }
    }
  }
  Node Term() {
    Node a = Unary();
    for (;;) {
      if (Eat("*")) {
        a = Binary("*", std::move(a), Unary());
      } else if (Eat("/")) {
        a = Binary("/", std::move(a), Unary());
      } else {
        return a;
      }
    }
  }
  Node Unary() {
    if (Eat("-")) {
      Node n;
      n.kind = Node::Kind::kNegate;
      n.args.push_back(Unary());
      return n;
    }
    if (Eat("+")) return Unary();
    return Power();
  }
  Node Power() {
    Node base = Primary();
    if (Eat("^")) return Binary("^", std::move(base), Unary());
    return base;
  }
  Node Primary() {
    Skip();
    if (pos_ >= text_.size()) Fail(pos_, "expected a number, a name or '(', got the end");
    const char c = text_[pos_];
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') {
      const char* begin = text_.c_str() + pos_;
      char* end = nullptr;
      const double v = std::strtod(begin, &end);
      if (end == begin) Fail(pos_, "expected a number, got '" + std::string(1, c) + "'");
      pos_ += static_cast<std::size_t>(end - begin);
      Node n;
      n.value = v;
      return n;
    }
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      const std::size_t start = pos_;
      while (pos_ < text_.size() &&
             (std::isalnum(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '_')) {
        ++pos_;
      }
      const std::string name = text_.substr(start, pos_ - start);
      Skip();
      if (pos_ < text_.size() && text_[pos_] == '(') return Call(name, start);
      if (name == "pi") {
        Node n;
        n.value = kPi;
        return n;
      }
      const auto constant = scope_.constants.find(name);
      if (constant != scope_.constants.end()) {
        Node n;
        n.value = constant->second;
        return n;
      }
      const auto symbol = scope_.symbols.find(name);
      if (symbol == scope_.symbols.end()) {
        Fail(start, "unknown name '" + name + "'" + util::DidYouMeanHint(name, scope_.Names()) +
                        (FindFunction(name) ? " ('" + name + "' is a function: call it)" : ""));
      }
      Node n;
      n.kind = Node::Kind::kSymbol;
      n.source = symbol->second.source;
      n.index = symbol->second.index;
      return n;
    }
    if (Eat("(")) {
      Node n = Comparison();
      if (!Eat(")")) Fail(pos_, "expected ')', got " + Rest());
      return n;
    }
    Fail(pos_, "expected a number, a name or '(', got '" + std::string(1, c) + "'");
  }
  Node Call(const std::string& name, std::size_t start) {
    const Function* f = FindFunction(name);
    if (!f) {
      Fail(start, "unknown function '" + name + "'" + util::DidYouMeanHint(name, FunctionNames()));
    }
    Eat("(");
    Node n;
    n.kind = Node::Kind::kCall;
    n.op = name;
    if (!Eat(")")) {
      for (;;) {
        n.args.push_back(Comparison());
        if (Eat(")")) break;
        if (!Eat(","))
          Fail(pos_, "expected ',' or ')' in the arguments of '" + name + "', got " + Rest());
      }
    }
    if (static_cast<int>(n.args.size()) != f->arity) {
      Fail(start, "'" + name + "' takes " + std::to_string(f->arity) + " argument" +
                      (f->arity == 1 ? "" : "s") + ", got " + std::to_string(n.args.size()));
    }
    return n;
  }
  std::string Rest() const {
    return pos_ < text_.size() ? "'" + std::string(1, text_[pos_]) + "'" : "the end";
  }

  std::string field_;
  const std::string& text_;
  const Scope& scope_;
  std::size_t pos_ = 0;
};

// ---- Evaluation on double and on Expr
// -------------------------------------------------------------

double IfElse(double c, double a, double b) { return c != 0.0 ? a : b; }
expr::Expr IfElse(const expr::Expr& c, const expr::Expr& a, const expr::Expr& b) {
  return expr::if_else(c, a, b);
}
double Compare(const std::string& op, double a, double b) {
  if (op == "<") return a < b ? 1.0 : 0.0;
  if (op == "<=") return a <= b ? 1.0 : 0.0;
  if (op == ">") return a > b ? 1.0 : 0.0;
  if (op == ">=") return a >= b ? 1.0 : 0.0;
  if (op == "==") return a == b ? 1.0 : 0.0;
  return a != b ? 1.0 : 0.0;
}
expr::Expr Compare(const std::string& op, const expr::Expr& a, const expr::Expr& b) {
  if (op == "<") return expr::lt(a, b);
  if (op == "<=") return expr::le(a, b);
  if (op == ">") return expr::gt(a, b);
  if (op == ">=") return expr::ge(a, b);
  if (op == "==") return expr::eq(a, b);
  return expr::ne(a, b);
}
double Square(double x) { return x * x; }
expr::Expr Square(const expr::Expr& x) { return expr::square(x); }

template <typename Scalar>
struct Values {
  const Scalar* u;
  const Scalar* x;
  const Scalar* p;
  const std::vector<Scalar>* y;
};

template <typename Scalar>
Scalar Eval(const Node& n, const Values<Scalar>& v) {
  using expr::sigmoid;
  using expr::sign;
  using expr::smooth_abs;
  using expr::smooth_max;
  using expr::smooth_min;
  using expr::smooth_sign;
  using expr::softplus;
  using std::abs;
  using std::atan;
  using std::atan2;
  using std::cos;
  using std::erf;
  using std::exp;
  using std::log;
  using std::max;
  using std::min;
  using std::pow;
  using std::sin;
  using std::sqrt;
  using std::tan;
  using std::tanh;
  switch (n.kind) {
    case Node::Kind::kNumber:
      return Scalar(n.value);
    case Node::Kind::kSymbol:
      switch (n.source) {
        case Source::kInput:
          return v.u[n.index];
        case Source::kState:
          return v.x[n.index];
        case Source::kParameter:
          return v.p[n.index];
        case Source::kOutput:
          return (*v.y)[n.index];
      }
      return Scalar(0.0);
    case Node::Kind::kNegate:
      return -Eval(n.args[0], v);
    case Node::Kind::kBinary: {
      const Scalar a = Eval(n.args[0], v), b = Eval(n.args[1], v);
      if (n.op == "+") return a + b;
      if (n.op == "-") return a - b;
      if (n.op == "*") return a * b;
      if (n.op == "/") return a / b;
      if (n.op == "^") return pow(a, b);
      return Compare(n.op, a, b);
    }
    case Node::Kind::kCall: {
      std::vector<Scalar> a;
      for (const Node& arg : n.args) a.push_back(Eval(arg, v));
      const std::string& f = n.op;
      if (f == "sqrt") return sqrt(a[0]);
      if (f == "exp") return exp(a[0]);
      if (f == "log") return log(a[0]);
      if (f == "sin") return sin(a[0]);
      if (f == "cos") return cos(a[0]);
      if (f == "tan") return tan(a[0]);
      if (f == "atan") return atan(a[0]);
      if (f == "tanh") return tanh(a[0]);
      if (f == "abs") return abs(a[0]);
      if (f == "sign") return sign(a[0]);
      if (f == "erf") return erf(a[0]);
      if (f == "square") return Square(a[0]);
      if (f == "sigmoid") return sigmoid(a[0]);
      if (f == "softplus") return softplus(a[0]);
      if (f == "atan2") return atan2(a[0], a[1]);
      if (f == "min") return min(a[0], a[1]);
      if (f == "max") return max(a[0], a[1]);
      if (f == "pow") return pow(a[0], a[1]);
      if (f == "smooth_abs") return smooth_abs(a[0], a[1]);
      if (f == "smooth_sign") return smooth_sign(a[0], a[1]);
      if (f == "smooth_max") return smooth_max(a[0], a[1], a[2]);
      if (f == "smooth_min") return smooth_min(a[0], a[1], a[2]);
      return IfElse(a[0], a[1], a[2]);
    }
  }
  return Scalar(0.0);
}

// ---- The block
// ------------------------------------------------------------------------------------

std::vector<std::string> SplitNames(const BlockOptions& o, const std::string& key) {
  std::vector<std::string> names;
  const auto it = o.words.find(key);
  if (it == o.words.end()) return names;
  std::string cur;
  auto flush = [&]() {
    std::size_t b = cur.find_first_not_of(" \t"), e = cur.find_last_not_of(" \t");
    const std::string name = b == std::string::npos ? "" : cur.substr(b, e - b + 1);
    if (name.empty())
      throw EquationError(key, -1, "expected comma-separated names, got an empty one");
    bool ok = std::isalpha(static_cast<unsigned char>(name[0])) || name[0] == '_';
    for (const char ch : name)
      ok = ok && (std::isalnum(static_cast<unsigned char>(ch)) || ch == '_');
    if (!ok)
      throw EquationError(key, -1, "expected a name [A-Za-z_][A-Za-z0-9_]*, got '" + name + "'");
    names.push_back(name);
    cur.clear();
  };
  for (const char ch : it->second) {
    if (ch == ',') {
      flush();
    } else {
      cur += ch;
    }
  }
  if (!it->second.empty()) flush();
  return names;
}

SignalRole ParseRole(const std::string& key, const std::string& text) {
  std::vector<std::string> names;
  for (const SignalRole r :
       {SignalRole::kNone, SignalRole::kPosition, SignalRole::kVelocity, SignalRole::kAcceleration,
        SignalRole::kForce, SignalRole::kPressure, SignalRole::kVoltage, SignalRole::kCurrent}) {
    if (text == SignalRoleName(r)) return r;
    names.emplace_back(SignalRoleName(r));
  }
  throw EquationError(key, -1, "unknown role '" + text + "'" + util::DidYouMeanHint(text, names));
}

class EquationBlock : public BlockBase<EquationBlock> {
 public:
  explicit EquationBlock(const BlockOptions& o) {
    info_.type = kEquationBlock;
    info_.reference = "equations written in the problem file (docs/problem-format.md)";
    const auto word = [&](const std::string& key, const std::string& fallback) {
      const auto it = o.words.find(key);
      return it == o.words.end() ? fallback : it->second;
    };
    info_.description = word("description",
                             "Equation block: states, outputs and parameters "
                             "written as equations in the problem file.");
    const std::vector<std::string> inputs = SplitNames(o, "inputs"),
                                   states = SplitNames(o, "states"),
                                   outputs = SplitNames(o, "outputs"),
                                   parameters = SplitNames(o, "parameters"),
                                   constants = SplitNames(o, "constants");
    if (states.empty() && outputs.empty()) {
      throw EquationError("states", -1, "expected at least one state or output, got none");
    }
    // Every name once, none a function or "pi".
    std::map<std::string, std::string> used;
    std::set<std::string> known_keys = {"inputs",     "states",    "outputs",
                                        "parameters", "constants", "description"};
    auto claim = [&](const std::string& list, const std::string& name) {
      if (FindFunction(name) || name == "pi") {
        throw EquationError(list, -1,
                            "'" + name +
                                "' is a function or constant of the expression "
                                "language; expected another name");
      }
      const auto [it, fresh] = used.emplace(name, list);
      if (!fresh) {
        throw EquationError(list, -1,
                            "the name '" + name + "' is used twice (also in '" + it->second + "')");
      }
    };
    auto signal = [&](const std::string& list, const std::string& name) {
      claim(list, name);
      SignalInfo s;
      s.name = name;
      s.unit = word("unit." + name, "1");
      s.description = word("description." + name,
                           list.substr(0, list.size() - 1) + " " + name + " of the equation block");
      const auto range = o.numbers.find("range." + name);
      if (range != o.numbers.end()) {
        if (range->second.size() != 2 || !(range->second[0] < range->second[1])) {
          throw EquationError("range." + name, -1, "expected {min, max} with min < max");
        }
        s.typical_min = range->second[0];
        s.typical_max = range->second[1];
      }
      const auto role = o.words.find("role." + name);
      if (role != o.words.end()) s.role = ParseRole("role." + name, role->second);
      for (const char* k : {"unit.", "description.", "range.", "role."})
        known_keys.insert(k + name);
      return s;
    };
    for (const auto& n : inputs) info_.inputs.push_back(signal("inputs", n));
    for (const auto& n : states) info_.states.push_back(signal("states", n));
    for (const auto& n : outputs) info_.outputs.push_back(signal("outputs", n));
    for (const auto& n : parameters) {
      claim("parameters", n);
      ParameterInfo p;
      p.name = n;
      p.unit = word("unit." + n, "1");
      p.description = word("description." + n, "parameter " + n + " of the equation block");
      const auto number = [&](const std::string& key) -> const std::vector<double>* {
        known_keys.insert(key);
        const auto it = o.numbers.find(key);
        return it == o.numbers.end() ? nullptr : &it->second;
      };
      known_keys.insert("unit." + n);
      known_keys.insert("description." + n);
      p.nominal = 1.0;
      if (const auto* v = number("nominal." + n)) p.nominal = v->at(0);
      if (const auto* b = number("bounds." + n)) {
        if (b->size() != 2 || !(b->at(0) <= b->at(1))) {
          throw EquationError("bounds." + n, -1, "expected {lower, upper} with lower <= upper");
        }
        p.lower = b->at(0);
        p.upper = b->at(1);
      }
      if (const auto* v = number("neutral." + n)) p.neutral = v->at(0);
      if (p.nominal < p.lower || p.nominal > p.upper) {
        throw EquationError("nominal." + n, -1,
                            "expected a nominal value inside the bounds [" +
                                std::to_string(p.lower) + ", " + std::to_string(p.upper) +
                                "], got " + std::to_string(p.nominal));
      }
      info_.parameters.push_back(p);
    }
    Scope scope;
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      scope.symbols[inputs[i]] = {Source::kInput, static_cast<int>(i)};
    }
    for (std::size_t i = 0; i < states.size(); ++i) {
      scope.symbols[states[i]] = {Source::kState, static_cast<int>(i)};
    }
    for (std::size_t i = 0; i < parameters.size(); ++i) {
      scope.symbols[parameters[i]] = {Source::kParameter, static_cast<int>(i)};
    }
    for (const auto& c : constants) {
      claim("constants", c);
      const std::string key = "constant." + c;
      known_keys.insert(key);
      const auto it = o.numbers.find(key);
      if (it == o.numbers.end() || it->second.size() != 1) {
        throw EquationError(key, -1, "expected the value of constant '" + c + "', got none");
      }
      scope.constants[c] = it->second[0];
    }
    // Outputs in order, each may use the ones before it; derivatives may use them all.
    for (std::size_t i = 0; i < outputs.size(); ++i) {
      const std::string key = "value." + outputs[i];
      known_keys.insert(key);
      const auto it = o.words.find(key);
      if (it == o.words.end()) {
        throw EquationError(key, -1,
                            "output '" + outputs[i] + "' has no equation: expected '" + key + "'");
      }
      outputs_.push_back(Parser(key, it->second, scope).Parse());
      scope.symbols[outputs[i]] = {Source::kOutput, static_cast<int>(i)};
    }
    for (const auto& s : states) {
      const std::string key = "derivative." + s;
      known_keys.insert(key);
      const auto it = o.words.find(key);
      if (it == o.words.end()) {
        throw EquationError(
            key, -1,
            "state '" + s + "' has no equation: expected '" + key + "' (its time derivative)");
      }
      derivatives_.push_back(Parser(key, it->second, scope).Parse());
    }
    // Every option key is one of the above.
    const std::vector<std::string> known(known_keys.begin(), known_keys.end());
    for (const auto& [k, v] : o.words) {
      if (!known_keys.count(k)) {
        throw EquationError(k, -1, "unknown option '" + k + "'" + util::DidYouMeanHint(k, known));
      }
    }
    for (const auto& [k, v] : o.numbers) {
      if (!known_keys.count(k)) {
        throw EquationError(k, -1, "unknown option '" + k + "'" + util::DidYouMeanHint(k, known));
      }
    }
  }

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    std::vector<Scalar> y;
    y.reserve(outputs_.size());
    const Values<Scalar> v{a.u, a.x, a.p, &y};
    for (const Node& n : outputs_) y.push_back(Eval(n, v));
    for (std::size_t i = 0; i < y.size(); ++i) a.y[i] = y[i];
    for (std::size_t i = 0; i < derivatives_.size(); ++i) a.xdot[i] = Eval(derivatives_[i], v);
  }

 private:
  std::vector<Node> outputs_;
  std::vector<Node> derivatives_;
};

}  // namespace

EquationError::EquationError(std::string field, int offset, const std::string& message)
    : std::invalid_argument(field + ": " +
                            (offset >= 0 ? "column " + std::to_string(offset + 1) + ": " : "") +
                            message),
      field_(std::move(field)),
      offset_(offset),
      reason_(message) {}

std::unique_ptr<Block> MakeEquationBlock(const BlockOptions& options) {
  return std::make_unique<EquationBlock>(options);
}

namespace internal {

void RegisterEquationBlocks(BlockRegistry& registry) {
  // The shared tests' example: a mass on a nonlinear spring with a square-root damper, a gated
  // force and an output product, exercising every operator and most functions.
  BlockOptions test;
  test.words["inputs"] = "f";
  test.words["unit.f"] = "N";
  test.words["role.f"] = "force";
  test.numbers["range.f"] = {-2.0, 2.0};
  test.words["states"] = "q, v";
  test.words["unit.q"] = "m";
  test.words["role.q"] = "position";
  test.words["unit.v"] = "m/s";
  test.words["role.v"] = "velocity";
  test.numbers["range.q"] = {-0.5, 0.5};
  test.numbers["range.v"] = {-1.0, 1.0};
  test.words["parameters"] = "k, k3, c, m";
  test.words["unit.k"] = "N/m";
  test.words["unit.k3"] = "N/m^3";
  test.words["unit.c"] = "N s^0.5/m^0.5";
  test.words["unit.m"] = "kg";
  test.numbers["nominal.k"] = {4.0};
  test.numbers["nominal.k3"] = {2.0};
  test.numbers["neutral.k3"] = {0.0};
  test.numbers["nominal.c"] = {0.3};
  test.numbers["bounds.c"] = {0.0, 10.0};
  test.numbers["nominal.m"] = {1.5};
  test.numbers["bounds.m"] = {0.1, 10.0};
  test.words["constants"] = "eps";
  test.numbers["constant.eps"] = {1e-3};
  test.words["outputs"] = "spring, power";
  test.words["unit.spring"] = "N";
  test.words["unit.power"] = "W";
  test.words["value.spring"] = "k*q + k3*q^3 + if_else(q > 0.2, 0.5*(q - 0.2)^2, 0)";
  test.words["value.power"] = "f * v - sqrt(v^2 + eps^2) * c * smooth_abs(v, eps)";
  test.words["derivative.q"] = "v";
  test.words["derivative.v"] =
      "(f - spring - c*sign(v)*sqrt(abs(v) + eps) - 0.1*tanh(v/0.05)*exp(-square(v)) + "
      "0.01*atan2(q, 1 + v^2) * max(min(v, 1), -1)) / m";
  registry.Register(kEquationBlock, MakeEquationBlock, test);
}

}  // namespace internal
}  // namespace graybox::models
