// Block: one documented physical (or learned) effect, written once and evaluated on doubles and on
// libexpr expressions.
//
// A block is a small state-space system with parameters,
//     xdot = f(x, u, p),    y = h(x, u, p),
// with named inputs u, outputs y, states x and parameters p, each with a unit and a meaning. A
// Coulomb friction block has input "qd" [rad/s], output "tau" [N m] and parameters "fc" [N m] and
// "steepness" [s/rad]; a LuGre block adds the bristle state "z" [rad]; a DC motor has the armature
// current and the shaft speed as states. Models (model.h) are built by connecting blocks through
// named signals; the estimators see the parameters by their qualified names "<instance>.<param>".
//
// Every parameter declares a nominal value, bounds, and, where one exists, its NEUTRAL value: the
// value at which the block's output does not change the model it is added to (zero friction, zero
// network output weights, infinite stiffness expressed as zero compliance, ...). The sim-to-real
// gap diagnosis adds candidate blocks to a fitted model at their neutral values, which by
// construction leaves every output unchanged, and then re-fits.
//
// Writing a block: derive from BlockBase<Derived>, fill a BlockInfo in the constructor, and define
//     template <typename Scalar> void Compute(const BlockArgs<Scalar>& a) const;
// which must write every output a.y[i] and every state derivative a.xdot[i]. Use unqualified math
// calls after `using std::tanh;` etc., so that Scalar = graybox::expr::Expr finds the libexpr
// overloads. Register its factory in the family's Register*Blocks function (src/builtin_blocks.h;
// called once when the global registry is first used), so the shared test suites check its
// derivatives, metadata and double/Expr agreement automatically.
#pragma once

#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "graybox/expr/expr.h"

namespace graybox::models {

/// What physical quantity a signal is, when that is unambiguous. The sim-to-real gap diagnosis
/// reads it to attach candidate effects where they belong (friction on a velocity, ripple on a
/// position, a delay or gain error on a force). Mechanical roles refer to one axis in generalised
/// coordinates: a position is a length [m] or an angle [rad], a force is a force [N] or a torque
/// [N m]. Relative quantities that are not an axis' own (a spring deflection, a bristle
/// deflection), commands, flows and network signals keep kNone.
enum class SignalRole {
  kNone,
  kPosition,      // q of an axis [m] or [rad]
  kVelocity,      // dq/dt [m/s] or [rad/s]
  kAcceleration,  // d^2q/dt^2 [m/s^2] or [rad/s^2]
  kForce,         // a force or torque acting along the axis [N] or [N m]
  kPressure,      // an absolute or gauge pressure [Pa, kPa, bar]
  kVoltage,       // an electric voltage [V]
  kCurrent,       // an electric current [A]
};

/// "none", "position", "velocity", "acceleration", "force", "pressure", "voltage", "current".
const char* SignalRoleName(SignalRole role);

/// A named scalar signal (input, output or state) of a block.
struct SignalInfo {
  std::string name;         // local name, e.g. "qd"
  std::string unit;         // SI unit, e.g. "rad/s"
  std::string description;  // one line
  /// Typical operating range [typical_min, typical_max] (for test points, scaling and the regime
  /// analysis of the diagnosis); not a hard limit.
  double typical_min = -1.0;
  double typical_max = 1.0;
  /// The physical quantity, where unambiguous (see SignalRole); kNone otherwise.
  SignalRole role = SignalRole::kNone;
};

/// A scalar parameter of a block.
struct ParameterInfo {
  std::string name;         // local name, e.g. "fc"
  std::string unit;         // SI unit, e.g. "N m"
  std::string description;  // one line: what it means physically
  double nominal = 0.0;     // a typical value (initial guess for identification)
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
  /// Value at which the block leaves the model it is added to unchanged, or NaN when there is none.
  double neutral = std::numeric_limits<double>::quiet_NaN();
  /// True for a known setting rather than an unknown to identify (a controller gain, a saturation
  /// level): Model::AddBlock starts such a parameter fixed, and a caller (or a problem file's
  /// `free = true`) frees it explicitly. Its nominal value is then the value used, so it is finite.
  bool fixed_by_default = false;
  bool HasNeutral() const { return neutral == neutral; }
};

/// The description of a block type and instance configuration.
struct BlockInfo {
  std::string type;         // registry key, e.g. "friction.lugre"
  std::string description;  // what the block models, in one or two sentences
  std::string reference;    // where the equations come from, e.g. "seed 002 eq. 5-4 to 5-7"
  std::vector<SignalInfo> inputs;
  std::vector<SignalInfo> outputs;
  std::vector<SignalInfo> states;
  std::vector<ParameterInfo> parameters;
  /// True when f is stiff at nominal parameters (integrate with an implicit method, CVODES).
  bool stiff = false;
};

/// Evaluation arguments: pointers to arrays sized as in BlockInfo. Inputs are read-only; the block
/// writes every entry of y and xdot.
template <typename Scalar>
struct BlockArgs {
  const Scalar* x = nullptr;
  const Scalar* u = nullptr;
  const Scalar* p = nullptr;
  Scalar* xdot = nullptr;
  Scalar* y = nullptr;
};

/// Configuration of a block instance: numbers (sizes, breakpoints, constants) and words
/// (activation names), by key. Unknown keys are rejected by the block's factory with a
/// did-you-mean suggestion.
struct BlockOptions {
  std::map<std::string, std::vector<double>> numbers;
  std::map<std::string, std::string> words;
};

class Block {
 public:
  virtual ~Block() = default;
  const BlockInfo& info() const { return info_; }
  int NumInputs() const { return static_cast<int>(info_.inputs.size()); }
  int NumOutputs() const { return static_cast<int>(info_.outputs.size()); }
  int NumStates() const { return static_cast<int>(info_.states.size()); }
  int NumParameters() const { return static_cast<int>(info_.parameters.size()); }
  /// Nominal parameter values in declaration order.
  std::vector<double> NominalParameters() const;

  virtual void Evaluate(const BlockArgs<double>& args) const = 0;
  virtual void Evaluate(const BlockArgs<expr::Expr>& args) const = 0;

 protected:
  BlockInfo info_;
};

/// CRTP helper: forwards both Evaluate overloads to Derived::Compute<Scalar>.
template <typename Derived>
class BlockBase : public Block {
 public:
  void Evaluate(const BlockArgs<double>& args) const final {
    static_cast<const Derived*>(this)->template Compute<double>(args);
  }
  void Evaluate(const BlockArgs<expr::Expr>& args) const final {
    static_cast<const Derived*>(this)->template Compute<expr::Expr>(args);
  }
};

using BlockFactory = std::function<std::unique_ptr<Block>(const BlockOptions&)>;

/// The registry of block types. Global() holds every built-in block; it is built on first use
/// (thread-safe) and read-only afterwards unless a user registers their own types.
class BlockRegistry {
 public:
  static BlockRegistry& Global();
  /// Registers a factory and the options the shared tests instantiate it with. Throws
  /// std::logic_error when `type` is already registered.
  void Register(const std::string& type, BlockFactory factory, BlockOptions test_options = {});
  /// Creates a block; throws std::invalid_argument "unknown block type 'x'; did you mean 'y'?"
  std::unique_ptr<Block> Create(const std::string& type, const BlockOptions& options = {}) const;
  /// All registered types, sorted.
  std::vector<std::string> Types() const;
  const BlockOptions& TestOptions(const std::string& type) const;

 private:
  struct Entry {
    BlockFactory factory;
    BlockOptions test_options;
  };
  std::map<std::string, Entry> entries_;
};

/// Throws std::invalid_argument naming the block type when `options` holds a key outside `known`
/// (with the closest known key as a suggestion).
void CheckOptionKeys(const std::string& type, const BlockOptions& options,
                     const std::vector<std::string>& known);

}  // namespace graybox::models
