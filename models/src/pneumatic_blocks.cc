// The pneumatic block family: metadata, options and registration. The equations, units and the
// meaning of every parameter are in graybox/models/pneumatics.h; each block's Compute only wires
// the templates defined there.
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "builtin_blocks.h"
#include "graybox/models/pneumatics.h"
#include "graybox/util/did_you_mean.h"

namespace graybox::models::internal {
namespace {

namespace pn = graybox::models::pneumatics;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNoNeutral = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;

// Typical operating ranges (test points, scaling): pressures between the atmosphere and the
// supply, valve commands over the full 0..10 V, joint angles away from the dead centres of the
// crank (q = 0, pi), speeds up to the seed's 10 rad/s limit.
constexpr double kPressureMin = pn::kAtmosphericPressure;
constexpr double kPressureMax = pn::kNominalSupplyPressure;
constexpr double kAreaMax = 2.0;          // mm^2, fully open valve port
constexpr double kMassFlowMax = 5e-3;     // kg/s; a 2 mm^2 port chokes at 2e-3 kg/s at 600 kPa
constexpr double kVolumeMin = 1.5e4;      // mm^3
constexpr double kVolumeMax = 5.0e4;      // mm^3
constexpr double kVolumeRateMax = 2.0e5;  // mm^3/s: 804 mm^2 * 20 mm * 10 rad/s ~ 1.6e5
constexpr double kAngleMin = 0.5;         // rad
constexpr double kAngleMax = 2.6;         // rad
constexpr double kSpeedMax = 10.0;        // rad/s
constexpr double kCommandMax = 10.0;      // V
constexpr double kLeverArmMax = 20.0;     // mm/rad; |h| <= r (1 + r / sqrt(l^2 - r^2)) ~ 21
constexpr double kTorqueMax = 10.0;       // N m

// Nominal valve-area parameters (FESTO MPYE-5-M5-class valve; see the header).
constexpr double kNominalLeak = 0.01;     // mm^2
constexpr double kNominalUSupply = 5.2;   // V
constexpr double kNominalUExhaust = 4.8;  // V
constexpr double kNominalGain = 0.4;      // mm^2/V
// Least-squares quadratic fit of the nominal smax curves on the seed's grid 0.2..10 V.
constexpr double kNominalSupplyTheta[3] = {0.165, -0.188, 0.0373};
constexpr double kNominalExhaustTheta[3] = {2.02, -0.559, 0.0371};

// Nominal mechanics of the arm (not in the seed).
constexpr double kNominalInertia = 0.02;       // kg m^2
constexpr double kNominalDamping = 0.05;       // N m s/rad
constexpr double kNominalGravityTorque = 0.5;  // N m
constexpr double kNominalGravityAngle = kPi / 2.0;

ParameterInfo Param(std::string name, std::string unit, std::string description, double nominal,
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

SignalInfo Signal(std::string name, std::string unit, std::string description, double lo, double hi,
                  SignalRole role = SignalRole::kNone) {
  SignalInfo s;
  s.name = std::move(name);
  s.unit = std::move(unit);
  s.description = std::move(description);
  s.typical_min = lo;
  s.typical_max = hi;
  s.role = role;
  return s;
}

std::string Str(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

std::string Join(const std::vector<std::string>& words) {
  std::string s;
  for (const auto& w : words) s += (s.empty() ? "" : ", ") + w;
  return s;
}

// ---- Options --------------------------------------------------------------------------------

/// The single number under `key`, or `fallback`; must lie in (lower, upper].
double NumberOption(const std::string& type, const BlockOptions& options, const std::string& key,
                    double fallback, double lower, double upper) {
  auto it = options.numbers.find(key);
  if (it == options.numbers.end()) return fallback;
  const std::vector<double>& v = it->second;
  if (v.size() != 1 || !(v[0] > lower && v[0] <= upper)) {
    std::string got = "{";
    for (std::size_t i = 0; i < v.size(); ++i) got += (i ? ", " : "") + Str(v[i]);
    got += "}";
    throw std::invalid_argument("block '" + type + "': option '" + key +
                                "' expected one number in (" + Str(lower) + ", " + Str(upper) +
                                "], got " + got);
  }
  return v[0];
}

/// The word under `key`, or `fallback`; must be one of `allowed`.
std::string WordOption(const std::string& type, const BlockOptions& options, const std::string& key,
                       const std::string& fallback, const std::vector<std::string>& allowed) {
  auto it = options.words.find(key);
  if (it == options.words.end()) return fallback;
  for (const auto& a : allowed) {
    if (a == it->second) return a;
  }
  const std::string hint = util::DidYouMean(it->second, allowed);
  throw std::invalid_argument("block '" + type + "': option '" + key + "' expected one of " +
                              Join(allowed) + ", got '" + it->second + "'" +
                              (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
}

/// `options` after CheckOptionKeys (for member initialisers).
const BlockOptions& Checked(const std::string& type, const BlockOptions& options,
                            const std::vector<std::string>& known) {
  CheckOptionKeys(type, options, known);
  return options;
}

double LaminarWidth(const std::string& type, const BlockOptions& options) {
  return NumberOption(type, options, "laminar_width", pn::kDefaultLaminarWidth, 0.0, 0.05);
}

double GasConstant(const std::string& type, const BlockOptions& options) {
  return NumberOption(type, options, "gas_constant", pn::kAirGasConstant, 0.0, kInf);
}

// ---- Shared parameter lists -----------------------------------------------------------------

void AppendOrificeParameters(bool alpha_neutral, std::vector<ParameterInfo>* out) {
  out->push_back(Param("alpha", "sqrt(K) s/m",
                       "flow constant of eq. 3.1 (discharge coefficient times "
                       "sqrt(2 kappa / (R (kappa - 1)))), table 3.2",
                       pn::kNominalAlpha, 0.0, kInf, alpha_neutral ? 0.0 : kNoNeutral));
  out->push_back(Param("kappa", "-", "isentropic exponent of the gas in the orifice flow",
                       pn::kNominalKappa, 1.1, 1.67));
  out->push_back(Param("temperature", "K", "gas temperature (upstream of the orifices, inflow)",
                       pn::kNominalTemperature, 200.0, 400.0));
}

void AppendSupplyParameters(std::vector<ParameterInfo>* out) {
  out->push_back(Param("p_supply", "kPa", "absolute supply (compressor) pressure",
                       pn::kNominalSupplyPressure, 100.0, 1200.0));
  out->push_back(Param("p_exhaust", "kPa", "absolute exhaust (atmospheric) pressure",
                       pn::kAtmosphericPressure, 50.0, 200.0));
}

ParameterInfo PolytropicExponent() {
  return Param("polytropic_exponent", "-",
               "exponent of the chamber process: 1 isothermal, 1.4 adiabatic (eq. 3.3)",
               pn::kNominalKappa, 1.0, 1.67);
}

// ---- Valve area models ----------------------------------------------------------------------

enum class AreaModel { kSmax, kQuadratic, kTable };

class ValveAreaModel {
 public:
  ValveAreaModel(const std::string& type, const BlockOptions& options,
                 const std::string& model_key) {
    const std::string name =
        WordOption(type, options, model_key, "smax", {"smax", "quadratic", "table"});
    model_ = name == "smax"        ? AreaModel::kSmax
             : name == "quadratic" ? AreaModel::kQuadratic
                                   : AreaModel::kTable;
    name_ = name;
    auto only_for = [&](const std::string& key, AreaModel m, const std::string& m_name) {
      if (model_ != m && options.numbers.count(key)) {
        throw std::invalid_argument("block '" + type + "': option '" + key + "' applies only to " +
                                    model_key + " '" + m_name + "', got " + model_key + " '" +
                                    name + "'");
      }
    };
    only_for("breakpoints", AreaModel::kTable, "table");
    only_for("smax_width", AreaModel::kSmax, "smax");
    smax_width_ = NumberOption(type, options, "smax_width", pn::kDefaultSmaxWidth, 0.0, kInf);
    if (model_ == AreaModel::kTable) {
      auto it = options.numbers.find("breakpoints");
      if (it != options.numbers.end()) {
        breakpoints_ = it->second;
      } else {
        for (int i = 1; i <= 50; ++i) breakpoints_.push_back(0.2 * i);  // seed: 0.2..10 V
      }
      bool ok = breakpoints_.size() >= 2;
      for (std::size_t i = 0; ok && i < breakpoints_.size(); ++i) {
        ok = std::isfinite(breakpoints_[i]) && (i == 0 || breakpoints_[i] > breakpoints_[i - 1]);
      }
      if (!ok) {
        throw std::invalid_argument("block '" + type +
                                    "': option 'breakpoints' expected at least two finite, "
                                    "strictly increasing voltages, got " +
                                    std::to_string(breakpoints_.size()) +
                                    " values that are not; hint: e.g. {0, 2.5, 5, 7.5, 10}");
      }
    }
  }

  const std::string& name() const { return name_; }

  int NumParameters() const {
    switch (model_) {
      case AreaModel::kSmax:
        return 5;
      case AreaModel::kQuadratic:
        return 6;
      case AreaModel::kTable:
        break;
    }
    return 2 * static_cast<int>(breakpoints_.size());
  }

  /// Appends the parameters with names prefixed by `prefix` and descriptions by `what`.
  void AppendParameters(const std::string& prefix, const std::string& what,
                        std::vector<ParameterInfo>* out) const {
    auto add = [&](const std::string& name, const std::string& unit, const std::string& d,
                   double nominal, double lower, double upper) {
      out->push_back(Param(prefix + name, unit, what + d, nominal, lower, upper));
    };
    switch (model_) {
      case AreaModel::kSmax:
        add("leak_supply", "mm^2", "supply leakage area L_c (eq. 3.15)", kNominalLeak, 0.0, kInf);
        add("leak_exhaust", "mm^2", "exhaust leakage area L_r (eq. 3.16)", kNominalLeak, 0.0, kInf);
        add("u_supply", "V", "command U_c above which the supply port opens (eq. 3.15)",
            kNominalUSupply, 0.0, kCommandMax);
        add("u_exhaust", "V", "command U_r below which the exhaust port opens (eq. 3.16)",
            kNominalUExhaust, 0.0, kCommandMax);
        add("gain", "mm^2/V", "area per volt B of both ports (eq. 3.15, 3.16)", kNominalGain, 0.0,
            kInf);
        return;
      case AreaModel::kQuadratic: {
        const char* units[3] = {"mm^2", "mm^2/V", "mm^2/V^2"};
        const char* terms[3] = {"constant", "linear", "quadratic"};
        for (int i = 0; i < 3; ++i) {
          add("supply_theta" + std::to_string(i + 1), units[i],
              std::string(terms[i]) + " coefficient of the supply area (eq. 3.12)",
              kNominalSupplyTheta[i], -kInf, kInf);
        }
        for (int i = 0; i < 3; ++i) {
          add("exhaust_theta" + std::to_string(i + 1), units[i],
              std::string(terms[i]) + " coefficient of the exhaust area (eq. 3.13)",
              kNominalExhaustTheta[i], -kInf, kInf);
        }
        return;
      }
      case AreaModel::kTable:
        break;
    }
    for (std::size_t i = 0; i < breakpoints_.size(); ++i) {
      add("supply_area_" + std::to_string(i), "mm^2",
          "supply area a_c at u = " + Str(breakpoints_[i]) + " V (area model 1)",
          NominalSmax(breakpoints_[i]).supply, 0.0, kInf);
    }
    for (std::size_t i = 0; i < breakpoints_.size(); ++i) {
      add("exhaust_area_" + std::to_string(i), "mm^2",
          "exhaust area a_r at u = " + Str(breakpoints_[i]) + " V (area model 1)",
          NominalSmax(breakpoints_[i]).exhaust, 0.0, kInf);
    }
  }

  template <typename Scalar>
  pn::ValveAreas<Scalar> Compute(const Scalar& u, const Scalar* p) const {
    switch (model_) {
      case AreaModel::kSmax:
        return pn::ValveAreaSmax(u, p[0], p[1], p[2], p[3], p[4], smax_width_);
      case AreaModel::kQuadratic:
        return pn::ValveAreaQuadratic(u, p, p + 3);
      case AreaModel::kTable:
        break;
    }
    const std::size_t n = breakpoints_.size();
    return {pn::PiecewiseLinear(u, breakpoints_, p), pn::PiecewiseLinear(u, breakpoints_, p + n)};
  }

 private:
  pn::ValveAreas<double> NominalSmax(double u) const {
    return pn::ValveAreaSmax<double>(u, kNominalLeak, kNominalLeak, kNominalUSupply,
                                     kNominalUExhaust, kNominalGain, pn::kDefaultSmaxWidth);
  }

  AreaModel model_ = AreaModel::kSmax;
  std::string name_;
  std::vector<double> breakpoints_;
  double smax_width_ = pn::kDefaultSmaxWidth;
};

// ---- Blocks ---------------------------------------------------------------------------------

class OrificeBlock : public BlockBase<OrificeBlock> {
 public:
  static constexpr const char* kType = "pneumatic.orifice";

  explicit OrificeBlock(const BlockOptions& options) {
    CheckOptionKeys(kType, options, {"laminar_width"});
    laminar_width_ = LaminarWidth(kType, options);
    info_.type = kType;
    info_.description =
        "Thin-plate orifice mass flow of an ideal gas, choked and unchoked regimes joined in C1 "
        "at the critical pressure ratio, reverse flow antisymmetric, laminar (C1 cubic) near "
        "equal pressures.";
    info_.reference = "seed 004 eq. 3.1, 3.2 (table 3.2)";
    info_.inputs = {Signal("p_up", "kPa", "absolute pressure on the nominal upstream side",
                           kPressureMin, kPressureMax, SignalRole::kPressure),
                    Signal("p_down", "kPa", "absolute pressure on the nominal downstream side",
                           kPressureMin, kPressureMax, SignalRole::kPressure),
                    Signal("area", "mm^2", "orifice (valve port) area", 0.05, kAreaMax)};
    info_.outputs = {Signal("mdot", "kg/s", "mass flow from the up to the down side", -kMassFlowMax,
                            kMassFlowMax)};
    AppendOrificeParameters(/*alpha_neutral=*/true, &info_.parameters);
  }

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const pn::OrificeConstants<Scalar> c{a.p[0], a.p[1], a.p[2], laminar_width_};
    a.y[0] = pn::OrificeMassFlow(a.u[0], a.u[1], a.u[2], c);
  }

 private:
  double laminar_width_ = pn::kDefaultLaminarWidth;
};

class ChamberBlock : public BlockBase<ChamberBlock> {
 public:
  static constexpr const char* kType = "pneumatic.chamber";

  explicit ChamberBlock(const BlockOptions& options) {
    CheckOptionKeys(kType, options, {"gas_constant"});
    gas_constant_ = GasConstant(kType, options);
    info_.type = kType;
    info_.description =
        "Pressure of an ideal gas in a chamber of varying volume: pdot = n (R T mdot - p Vdot) / "
        "V, n the polytropic exponent.";
    info_.reference = "seed 004 eq. 3.3 (sign of the volume term corrected), table 3.2";
    info_.states = {Signal("p", "kPa", "absolute chamber pressure", kPressureMin, kPressureMax,
                           SignalRole::kPressure)};
    info_.inputs = {
        Signal("mdot", "kg/s", "net mass flow into the chamber", -kMassFlowMax, kMassFlowMax),
        Signal("volume", "mm^3", "chamber volume", kVolumeMin, kVolumeMax),
        Signal("volume_rate", "mm^3/s", "rate of change of the chamber volume", -kVolumeRateMax,
               kVolumeRateMax)};
    info_.parameters = {PolytropicExponent(),
                        Param("temperature", "K", "gas temperature (of the inflowing gas)",
                              pn::kNominalTemperature, 200.0, 400.0)};
    info_.stiff = true;
  }

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.xdot[0] =
        pn::ChamberPressureRate(a.x[0], a.u[0], a.u[1], a.u[2], a.p[0], a.p[1], gas_constant_);
  }

 private:
  double gas_constant_ = pn::kAirGasConstant;
};

class PortsBlock : public BlockBase<PortsBlock> {
 public:
  static constexpr const char* kType = "pneumatic.ports";

  explicit PortsBlock(const BlockOptions& options) {
    CheckOptionKeys(kType, options, {"laminar_width"});
    laminar_width_ = LaminarWidth(kType, options);
    info_.type = kType;
    info_.description =
        "Mass flow into a chamber through the supply and exhaust ports of its valve: two "
        "orifices, supply to chamber and chamber to exhaust.";
    info_.reference = "seed 004 eq. 3.4 (without the k R T / V factor of eq. 3.3), 3.1, 3.2";
    info_.inputs = {Signal("p", "kPa", "absolute chamber pressure", kPressureMin, kPressureMax,
                           SignalRole::kPressure),
                    Signal("area_supply", "mm^2", "supply port area a_c", 0.0, kAreaMax),
                    Signal("area_exhaust", "mm^2", "exhaust port area a_r", 0.0, kAreaMax)};
    info_.outputs = {
        Signal("mdot", "kg/s", "net mass flow into the chamber", -kMassFlowMax, kMassFlowMax),
        Signal("mdot_supply", "kg/s", "mass flow from the supply into the chamber", -kMassFlowMax,
               kMassFlowMax),
        Signal("mdot_exhaust", "kg/s", "mass flow from the chamber to the exhaust", -kMassFlowMax,
               kMassFlowMax)};
    AppendOrificeParameters(/*alpha_neutral=*/true, &info_.parameters);
    AppendSupplyParameters(&info_.parameters);
  }

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const pn::OrificeConstants<Scalar> c{a.p[0], a.p[1], a.p[2], laminar_width_};
    const pn::PortFlows<Scalar> f = pn::PortMassFlows(a.u[0], a.u[1], a.u[2], a.p[3], a.p[4], c);
    a.y[0] = f.net;
    a.y[1] = f.supply;
    a.y[2] = f.exhaust;
  }

 private:
  double laminar_width_ = pn::kDefaultLaminarWidth;
};

class ValveAreaBlock : public BlockBase<ValveAreaBlock> {
 public:
  static constexpr const char* kType = "pneumatic.valve_area";

  explicit ValveAreaBlock(const BlockOptions& options)
      : model_(kType, Checked(kType, options, {"model", "breakpoints", "smax_width"}), "model") {
    info_.type = kType;
    info_.description =
        "Supply and exhaust port areas of a proportional valve versus its "
        "command, area model '" +
        model_.name() + "' (options: model = smax | quadratic | table).";
    info_.reference = "seed 004 section 3.3, eq. 3.12-3.16";
    info_.inputs = {Signal("u", "V", "valve command", 0.0, kCommandMax, SignalRole::kVoltage)};
    info_.outputs = {Signal("area_supply", "mm^2", "supply port area a_c", 0.0, kAreaMax),
                     Signal("area_exhaust", "mm^2", "exhaust port area a_r", 0.0, kAreaMax)};
    model_.AppendParameters("", "", &info_.parameters);
  }

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const pn::ValveAreas<Scalar> areas = model_.Compute(a.u[0], a.p);
    a.y[0] = areas.supply;
    a.y[1] = areas.exhaust;
  }

 private:
  ValveAreaModel model_;
};

void AppendGeometryParameters(std::vector<ParameterInfo>* out) {
  out->push_back(Param("bore_area_1", "mm^2", "bore area A1 of chamber 1 (table 3.3)",
                       pn::kNominalBoreArea1, 0.0, kInf));
  out->push_back(Param("bore_area_2", "mm^2", "annular bore area A2 of chamber 2 (table 3.3)",
                       pn::kNominalBoreArea2, 0.0, kInf));
  out->push_back(Param("dead_volume_1", "mm^3", "dead volume D1 of chamber 1 (table 3.3)",
                       pn::kNominalDeadVolume1, 0.0, kInf));
  out->push_back(Param("dead_volume_2", "mm^3", "dead volume D2 of chamber 2 (table 3.3)",
                       pn::kNominalDeadVolume2, 0.0, kInf));
  out->push_back(Param("crank_radius", "mm", "crank radius r (table 3.3)", pn::kNominalCrankRadius,
                       5.0, 25.0));
  out->push_back(Param("rod_length", "mm", "connecting-rod length l > r (table 3.3)",
                       pn::kNominalRodLength, 30.0, 60.0));
  out->push_back(Param("length", "mm",
                       "length L of eq. 3.10 (chamber 2 spans L - x; not in the seed: 2 l)",
                       pn::kNominalLength, 60.0, 160.0));
}

template <typename Scalar>
pn::SliderCrankGeometry<Scalar> Geometry(const Scalar* p) {
  return {p[0], p[1], p[2], p[3], p[4], p[5], p[6]};
}

class SliderCrankBlock : public BlockBase<SliderCrankBlock> {
 public:
  static constexpr const char* kType = "pneumatic.slider_crank";

  explicit SliderCrankBlock(const BlockOptions& options) {
    CheckOptionKeys(kType, options, {});
    info_.type = kType;
    info_.description =
        "Slider-crank coupling of a joint to a double-acting cylinder: both chamber volumes, "
        "their rates and the lever arm dx/dq of the piston force.";
    info_.reference = "seed 004 eq. 3.7-3.10 (eq. 3.10 as implied by eq. 3.8), table 3.3";
    info_.inputs = {
        Signal("q", "rad", "joint (crank) angle", kAngleMin, kAngleMax, SignalRole::kPosition),
        Signal("qd", "rad/s", "joint speed", -kSpeedMax, kSpeedMax, SignalRole::kVelocity)};
    info_.outputs = {
        Signal("volume_1", "mm^3", "volume V1 of chamber 1", kVolumeMin, kVolumeMax),
        Signal("volume_2", "mm^3", "volume V2 of chamber 2", kVolumeMin, kVolumeMax),
        Signal("volume_rate_1", "mm^3/s", "dV1/dt", -kVolumeRateMax, kVolumeRateMax),
        Signal("volume_rate_2", "mm^3/s", "dV2/dt", -kVolumeRateMax, kVolumeRateMax),
        Signal("lever_arm", "mm/rad",
               "dx/dq: joint torque per piston force towards larger x (1e-3 N m per N)",
               -kLeverArmMax, kLeverArmMax)};
    AppendGeometryParameters(&info_.parameters);
  }

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const pn::SliderCrankState<Scalar> k = pn::SliderCrank(a.u[0], a.u[1], Geometry(a.p));
    a.y[0] = k.volume_1;
    a.y[1] = k.volume_2;
    a.y[2] = k.volume_rate_1;
    a.y[3] = k.volume_rate_2;
    a.y[4] = k.lever_arm;
  }
};

class PistonTorqueBlock : public BlockBase<PistonTorqueBlock> {
 public:
  static constexpr const char* kType = "pneumatic.piston_torque";

  explicit PistonTorqueBlock(const BlockOptions& options) {
    CheckOptionKeys(kType, options, {});
    info_.type = kType;
    info_.description =
        "Joint torque of a double-acting cylinder: the piston force A1 (p1 - p_exhaust) - A2 (p2 - "
        "p_exhaust) through the slider-crank's lever arm.";
    info_.reference = "seed 004 eq. 3.6 (with both bore areas), table 3.3";
    info_.inputs = {
        Signal("p1", "kPa", "absolute pressure in chamber 1", kPressureMin, kPressureMax,
               SignalRole::kPressure),
        Signal("p2", "kPa", "absolute pressure in chamber 2", kPressureMin, kPressureMax,
               SignalRole::kPressure),
        Signal("lever_arm", "mm/rad", "dx/dq of the slider-crank", -kLeverArmMax, kLeverArmMax)};
    info_.outputs = {Signal("torque", "N m", "pneumatic joint torque", -kTorqueMax, kTorqueMax,
                            SignalRole::kForce)};
    info_.parameters = {
        Param("bore_area_1", "mm^2", "bore area A1 of chamber 1 (table 3.3)", pn::kNominalBoreArea1,
              0.0, kInf),
        Param("bore_area_2", "mm^2", "annular bore area A2 of chamber 2 (table 3.3)",
              pn::kNominalBoreArea2, 0.0, kInf),
        Param("p_exhaust", "kPa", "ambient pressure on the rod cross-section A1 - A2",
              pn::kAtmosphericPressure, 50.0, 200.0)};
  }

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = pn::PneumaticTorque(a.u[2], a.u[0], a.u[1], a.p[0], a.p[1], a.p[2]);
  }
};

class ArmBlock : public BlockBase<ArmBlock> {
 public:
  static constexpr const char* kType = "pneumatic.arm";

  // Parameter layout: fixed part, then valve 1 and valve 2.
  enum Index {
    kAlpha,
    kKappa,
    kTemperature,
    kPolytropic,
    kSupply,
    kExhaust,
    kGeometry,  // seven slider-crank parameters
    kInertia = kGeometry + 7,
    kDamping,
    kGravityTorque,
    kGravityAngle,
    kValves,
  };

  explicit ArmBlock(const BlockOptions& options)
      : valve_(
            kType,
            Checked(kType, options,
                    {"valve_model", "breakpoints", "smax_width", "laminar_width", "gas_constant"}),
            "valve_model") {
    laminar_width_ = LaminarWidth(kType, options);
    gas_constant_ = GasConstant(kType, options);
    info_.type = kType;
    info_.description =
        "One joint driven by a double-acting cylinder through a slider-crank, each chamber fed "
        "by its own proportional valve (area model '" +
        valve_.name() + "'): joint angle, speed and both chamber pressures.";
    info_.reference = "seed 004 chapter 3: eq. 3.1-3.4, 3.6-3.10, 3.12-3.16, tables 3.2, 3.3";
    info_.states = {
        Signal("q", "rad", "joint (crank) angle", kAngleMin, kAngleMax, SignalRole::kPosition),
        Signal("qd", "rad/s", "joint speed", -kSpeedMax, kSpeedMax, SignalRole::kVelocity),
        Signal("p1", "kPa", "absolute pressure in chamber 1", kPressureMin, kPressureMax,
               SignalRole::kPressure),
        Signal("p2", "kPa", "absolute pressure in chamber 2", kPressureMin, kPressureMax,
               SignalRole::kPressure)};
    info_.inputs = {Signal("u1", "V", "command of the valve of chamber 1", 0.0, kCommandMax,
                           SignalRole::kVoltage),
                    Signal("u2", "V", "command of the valve of chamber 2", 0.0, kCommandMax,
                           SignalRole::kVoltage)};
    info_.outputs = {Signal("torque", "N m", "pneumatic joint torque", -kTorqueMax, kTorqueMax,
                            SignalRole::kForce)};
    std::vector<ParameterInfo>& p = info_.parameters;
    AppendOrificeParameters(/*alpha_neutral=*/false, &p);
    p.push_back(PolytropicExponent());
    AppendSupplyParameters(&p);
    p.back().description += "; also acts on the rod cross-section A1 - A2";
    AppendGeometryParameters(&p);
    p.push_back(Param("inertia", "kg m^2", "inertia of the link about the joint axis",
                      kNominalInertia, 1e-6, kInf));
    p.push_back(
        Param("damping", "N m s/rad", "viscous damping of the joint", kNominalDamping, 0.0, kInf));
    p.push_back(Param("gravity_torque", "N m", "m g l_c of the link (gravity torque amplitude)",
                      kNominalGravityTorque, -kInf, kInf));
    p.push_back(Param("gravity_angle", "rad", "joint angle of the stable hanging position",
                      kNominalGravityAngle, -kPi, 2.0 * kPi));
    valve_.AppendParameters("valve1_", "valve 1: ", &p);
    valve_.AppendParameters("valve2_", "valve 2: ", &p);
    info_.stiff = true;
  }

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    using std::sin;
    const Scalar* p = a.p;
    const Scalar& q = a.x[0];
    const Scalar& qd = a.x[1];
    const Scalar& p1 = a.x[2];
    const Scalar& p2 = a.x[3];
    const pn::OrificeConstants<Scalar> c{p[kAlpha], p[kKappa], p[kTemperature], laminar_width_};
    const pn::SliderCrankGeometry<Scalar> g = Geometry(p + kGeometry);
    const pn::SliderCrankState<Scalar> k = pn::SliderCrank(q, qd, g);
    const pn::ValveAreas<Scalar> area_1 = valve_.Compute(a.u[0], p + kValves);
    const pn::ValveAreas<Scalar> area_2 = valve_.Compute(a.u[1], p + kValves + NumValveParams());
    const pn::PortFlows<Scalar> flow_1 =
        pn::PortMassFlows(p1, area_1.supply, area_1.exhaust, p[kSupply], p[kExhaust], c);
    const pn::PortFlows<Scalar> flow_2 =
        pn::PortMassFlows(p2, area_2.supply, area_2.exhaust, p[kSupply], p[kExhaust], c);
    const Scalar torque =
        pn::PneumaticTorque(k.lever_arm, p1, p2, g.bore_area_1, g.bore_area_2, p[kExhaust]);
    a.xdot[0] = qd;
    a.xdot[1] =
        (torque - p[kDamping] * qd - p[kGravityTorque] * sin(q - p[kGravityAngle])) / p[kInertia];
    a.xdot[2] = pn::ChamberPressureRate(p1, flow_1.net, k.volume_1, k.volume_rate_1, p[kPolytropic],
                                        p[kTemperature], gas_constant_);
    a.xdot[3] = pn::ChamberPressureRate(p2, flow_2.net, k.volume_2, k.volume_rate_2, p[kPolytropic],
                                        p[kTemperature], gas_constant_);
    a.y[0] = torque;
  }

 private:
  int NumValveParams() const { return valve_.NumParameters(); }

  ValveAreaModel valve_;
  double laminar_width_ = pn::kDefaultLaminarWidth;
  double gas_constant_ = pn::kAirGasConstant;
};

}  // namespace

void RegisterPneumaticBlocks(BlockRegistry& registry) {
  registry.Register(OrificeBlock::kType,
                    [](const BlockOptions& o) { return std::make_unique<OrificeBlock>(o); });
  registry.Register(ChamberBlock::kType,
                    [](const BlockOptions& o) { return std::make_unique<ChamberBlock>(o); });
  registry.Register(PortsBlock::kType,
                    [](const BlockOptions& o) { return std::make_unique<PortsBlock>(o); });
  // The shared suite checks the table model (the one with breakpoints and if_else); the smax
  // model is checked through "pneumatic.arm" and all three by tests/models/pneumatics_test.cc.
  // Few interior breakpoints: a test point within one finite-difference step (6e-5 V) of one
  // sees the derivative jump (probability ~1e-4 per seed with four).
  BlockOptions table;
  table.words["model"] = "table";
  table.numbers["breakpoints"] = {0.0, 3.0, 4.8, 5.2, 7.0, 10.0};
  registry.Register(
      ValveAreaBlock::kType,
      [](const BlockOptions& o) { return std::make_unique<ValveAreaBlock>(o); }, table);
  registry.Register(SliderCrankBlock::kType,
                    [](const BlockOptions& o) { return std::make_unique<SliderCrankBlock>(o); });
  registry.Register(PistonTorqueBlock::kType,
                    [](const BlockOptions& o) { return std::make_unique<PistonTorqueBlock>(o); });
  registry.Register(ArmBlock::kType,
                    [](const BlockOptions& o) { return std::make_unique<ArmBlock>(o); });
}

}  // namespace graybox::models::internal
