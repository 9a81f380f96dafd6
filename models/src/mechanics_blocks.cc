// The mechanics, control and signal blocks; equations, units, parameters and the smoothing are
// documented in include/graybox/models/mechanics.h.
#include "graybox/models/mechanics.h"
#include "graybox/util/did_you_mean.h"

#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "builtin_blocks.h"

namespace graybox::models {

namespace internal {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNoNeutral = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;

ParameterInfo Parameter(std::string name, std::string unit, std::string description, double nominal,
                        double lower, double upper, double neutral = kNoNeutral) {
  ParameterInfo p;
  p.name = std::move(name);
  p.unit = std::move(unit);
  p.description = std::move(description);
  p.nominal = nominal;
  p.lower = lower;
  p.upper = upper;
  p.neutral = neutral;
  return p;
}

std::string Format(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// The word option `key` when present (any value), else `fallback`.
std::string Word(const BlockOptions& options, const std::string& key, const std::string& fallback) {
  auto it = options.words.find(key);
  return it == options.words.end() ? fallback : it->second;
}

// "motion" = "prismatic" | "rotational"; true for rotational.
bool Rotational(const std::string& type, const BlockOptions& options) {
  const std::string motion = Word(options, "motion", "prismatic");
  if (motion == "prismatic") return false;
  if (motion == "rotational") return true;
  const std::string hint = util::DidYouMean(motion, {"prismatic", "rotational"});
  throw std::invalid_argument(
      "block '" + type + "': option 'motion' expected 'prismatic' or 'rotational', got '" + motion +
      "'" + (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
}

// The single number of option `key`, > 0, or `fallback` when absent.
double PositiveNumber(const std::string& type, const BlockOptions& options, const std::string& key,
                      double fallback) {
  auto it = options.numbers.find(key);
  if (it == options.numbers.end()) return fallback;
  if (it->second.size() != 1 || !(it->second[0] > 0.0) || !std::isfinite(it->second[0])) {
    throw std::invalid_argument(
        "block '" + type + "': option '" + key + "' expected one finite number > 0, got " +
        (it->second.size() == 1 ? Format(it->second[0])
                                : std::to_string(it->second.size()) + " values"));
  }
  return it->second[0];
}

// Linear and angular variants of the signals of one axis.
struct AxisUnits {
  std::string position, velocity, force, mass;
  double position_min, position_max, speed, force_max, nominal_mass;
};
AxisUnits Axis(bool rotational) {
  if (rotational) return {"rad", "rad/s", "N m", "kg m^2", -kPi, kPi, 10.0, 10.0, 0.01};
  return {"m", "m/s", "N", "kg", 0.0, 0.25, 0.3, 150.0, 1.0};
}

// ---- mechanics.mass -----------------------------------------------------------------------------
class MassBlock : public BlockBase<MassBlock> {
 public:
  explicit MassBlock(const BlockOptions& options) {
    CheckOptionKeys(kMassBlock, options, {"motion"});
    const bool rotational = Rotational(kMassBlock, options);
    const AxisUnits a = Axis(rotational);
    info_.type = kMassBlock;
    info_.description =
        rotational ? "Rigid body rotating about one axis: dq/dt = qd, dqd/dt = torque / inertia."
                   : "Rigid body sliding along one axis: dq/dt = qd, dqd/dt = force / mass.";
    info_.reference = "Newton's second law; EMPS load (data/emps/SOURCE.md, M = 95.1 kg)";
    info_.states = {{"q", a.position, rotational ? "angle of the body" : "position of the body",
                     a.position_min, a.position_max, SignalRole::kPosition},
                    {"qd", a.velocity, rotational ? "angular velocity" : "velocity", -a.speed,
                     a.speed, SignalRole::kVelocity}};
    info_.inputs = {{"force", a.force,
                     rotational ? "net torque on the body about the axis"
                                : "net force on the body along the axis",
                     -a.force_max, a.force_max, SignalRole::kForce}};
    info_.parameters = {Parameter("mass", a.mass,
                                  rotational ? "moment of inertia about the axis" : "moving mass",
                                  a.nominal_mass, 1e-9, kInf)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.xdot[0] = a.x[1];
    a.xdot[1] = a.u[0] / a.p[0];
  }
};

// ---- control.cascade_p --------------------------------------------------------------------------
class CascadePController : public BlockBase<CascadePController> {
 public:
  explicit CascadePController(const BlockOptions& options) {
    CheckOptionKeys(kCascadePController, options, {"motion", "smoothing"});
    const bool rotational = Rotational(kCascadePController, options);
    const AxisUnits a = Axis(rotational);
    smoothing_ =
        PositiveNumber(kCascadePController, options, "smoothing", kDefaultSaturationSmoothing);
    info_.type = kCascadePController;
    info_.description =
        "Cascaded proportional position and velocity loops, nu = kp kv (qr - q) - kv qd, with a "
        "smooth saturation |nu| < limit.";
    info_.reference = "EMPS benchmark controller (data/emps/SOURCE.md; kp, kv and viradm = 10 V)";
    // The reference is not a quantity of the axis (no role); the command is a voltage.
    info_.inputs = {
        {"qr", a.position, "position reference", a.position_min, a.position_max},
        {"q", a.position, "measured position", a.position_min, a.position_max,
         SignalRole::kPosition},
        {"qd", a.velocity, "measured velocity", -a.speed, a.speed, SignalRole::kVelocity}};
    info_.outputs = {
        {"nu", "V", "controller output (drive command)", -10.0, 10.0, SignalRole::kVoltage}};
    // Known settings of the EMPS controller, not unknowns of the plant (mechanics.h).
    info_.parameters = {
        Parameter("kp", "1/s", "position loop gain", 160.18, 0.0, kInf),
        Parameter("kv", "V s/" + a.position, "velocity loop gain", 243.45, 0.0, kInf),
        Parameter("limit", "V", "saturation level of the output", 10.0, 1e-6, kInf)};
    for (ParameterInfo& par : info_.parameters) par.fixed_by_default = true;
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    using std::sqrt;
    const Scalar& kp = a.p[0];
    const Scalar& kv = a.p[1];
    const Scalar& limit = a.p[2];
    const Scalar v = kv * (kp * (a.u[0] - a.u[1]) - a.u[2]);
    const Scalar up = v + limit, down = v - limit;
    const double e2 = smoothing_ * smoothing_;
    // (A - B) / 2 with A^2 - B^2 = 4 L v, written without the cancellation of A - B.
    a.y[0] = 2.0 * limit * v / (sqrt(up * up + e2) + sqrt(down * down + e2));
  }

 private:
  double smoothing_ = kDefaultSaturationSmoothing;
};

// ---- signal.gain --------------------------------------------------------------------------------
class GainBlock : public BlockBase<GainBlock> {
 public:
  explicit GainBlock(const BlockOptions& options) {
    CheckOptionKeys(kGainBlock, options, {"input_unit", "output_unit"});
    const std::string in = Word(options, "input_unit", "1");
    const std::string out = Word(options, "output_unit", "1");
    if (in.empty() || out.empty()) {
      throw std::invalid_argument("block '" + std::string(kGainBlock) +
                                  "': options 'input_unit' and 'output_unit' expected a unit, got "
                                  "an empty word");
    }
    const std::string k_unit = in == "1" ? out : out + "/" + in;
    info_.type = kGainBlock;
    info_.description = "Static gain y = k u (neutral k = 1: the identity).";
    info_.reference = "EMPS drive gain tau = g_tau nu (data/emps/SOURCE.md)";
    info_.inputs = {{"u", in, "input signal", -10.0, 10.0}};
    info_.outputs = {{"y", out, "output signal k u", -10.0, 10.0}};
    info_.parameters = {Parameter("k", k_unit, "gain", 1.0, -kInf, kInf, 1.0)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = a.p[0] * a.u[0];
  }
};

// ---- signal.integrator --------------------------------------------------------------------------
class IntegratorBlock : public BlockBase<IntegratorBlock> {
 public:
  explicit IntegratorBlock(const BlockOptions& options) {
    CheckOptionKeys(kIntegratorBlock, options, {"input_unit", "output_unit"});
    const std::string in = Word(options, "input_unit", "1/s");
    const std::string out = Word(options, "output_unit", "1");
    if (in.empty() || out.empty()) {
      throw std::invalid_argument("block '" + std::string(kIntegratorBlock) +
                                  "': options 'input_unit' and 'output_unit' expected a unit, got "
                                  "an empty word");
    }
    info_.type = kIntegratorBlock;
    info_.description =
        "Integrator dy/dt = u (with a forward-difference input: a first-order hold).";
    info_.reference = "first-order hold of the EMPS reference (data/emps/SOURCE.md, qg at 1 kHz)";
    info_.inputs = {{"u", in, "rate", -1.0, 1.0}};
    info_.states = {{"y", out, "integral of the input", -1.0, 1.0}};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.xdot[0] = a.u[0];
  }
};

// ---- signal.first_order_hold --------------------------------------------------------------------
class FirstOrderHoldBlock : public BlockBase<FirstOrderHoldBlock> {
 public:
  explicit FirstOrderHoldBlock(const BlockOptions& options) {
    CheckOptionKeys(kFirstOrderHold, options, {"unit"});
    const std::string unit = Word(options, "unit", "1");
    if (unit.empty()) {
      throw std::invalid_argument("block '" + std::string(kFirstOrderHold) +
                                  "': option 'unit' expected a unit, got an empty word");
    }
    info_.type = kFirstOrderHold;
    info_.description =
        "First-order hold of a sampled signal: an integrator of its forward difference, started "
        "at its first sample (linear between samples).";
    info_.reference = "mechanics.h (signal.first_order_hold)";
    info_.inputs = {{"u", unit, "sampled signal (for the wiring; not used)", -10.0, 10.0},
                    {"r", unit + "/s", "forward difference of the sampled signal", -1e3, 1e3}};
    info_.states = {{"y", unit, "the signal, linear between samples", -10.0, 10.0}};
    info_.outputs = {{"v", unit, "the signal, linear between samples", -10.0, 10.0}};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.xdot[0] = a.u[1];
    a.y[0] = a.x[0];
  }
};

template <typename T>
BlockFactory Factory() {
  return [](const BlockOptions& options) { return std::make_unique<T>(options); };
}

}  // namespace

void RegisterMechanicsBlocks(BlockRegistry& registry) {
  registry.Register(kMassBlock, Factory<MassBlock>());
  registry.Register(kCascadePController, Factory<CascadePController>());
  registry.Register(kIntegratorBlock, Factory<IntegratorBlock>(),
                    {{}, {{"input_unit", "m/s"}, {"output_unit", "m"}}});
  registry.Register(kFirstOrderHold, Factory<FirstOrderHoldBlock>(), {{}, {{"unit", "V"}}});
  registry.Register(kGainBlock, Factory<GainBlock>(),
                    {{}, {{"input_unit", "V"}, {"output_unit", "N"}}});
}

}  // namespace internal
}  // namespace graybox::models
