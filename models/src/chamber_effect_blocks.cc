// The chamber effect blocks; equations, units, parameters and choices are documented in
// include/graybox/models/chamber_effects.h.
#include "graybox/models/chamber_effects.h"

#include <memory>
#include <string>

#include "builtin_blocks.h"
#include "graybox/models/pneumatics.h"
#include "mechanical_block_helpers.h"

namespace graybox::models::internal {
namespace {

namespace pn = graybox::models::pneumatics;

constexpr double kPressureMax = 600.0;    // kPa, the nominal supply
constexpr double kMassFlowMax = 5e-3;     // kg/s, as pneumatic.chamber
constexpr double kVolumeRateMax = 2.0e5;  // mm^3/s, as pneumatic.chamber
constexpr double kJoulePerKpaMm3 = 1e-6;  // 1 kPa mm^3 = 1e3 Pa * 1e-9 m^3

SignalInfo Pressure() {
  return {"p",
          "kPa",
          "absolute chamber pressure",
          pn::kAtmosphericPressure,
          kPressureMax,
          SignalRole::kPressure};
}
SignalInfo Flow(const char* name, const char* description) {
  return {name, "kg/s", description, -kMassFlowMax, kMassFlowMax};
}

// ---- pneumatic.leak -----------------------------------------------------------------------------
class ChamberLeak : public BlockBase<ChamberLeak> {
 public:
  explicit ChamberLeak(const BlockOptions& options) {
    CheckOptionKeys(kChamberLeak, options, {"exhaust_pressure"});
    exhaust_ = PositiveOption(kChamberLeak, options, "exhaust_pressure", pn::kAtmosphericPressure);
    info_.type = kChamberLeak;
    info_.description = "Laminar leak from a chamber to the atmosphere, mdot = G (p - p_ext).";
    info_.reference = "linear (laminar) leak through a seal (chamber_effects.h)";
    info_.inputs = {Pressure()};
    info_.outputs = {Flow("mdot", "mass flow leaving the chamber")};
    info_.parameters = {
        MakeParameter("G", "kg/(s kPa)", "leak conductance", 2.5e-8, 0.0, kInf, 0.0)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = a.p[0] * (a.u[0] - exhaust_);
  }

 private:
  double exhaust_ = pn::kAtmosphericPressure;
};

// ---- pneumatic.polytropic_correction ------------------------------------------------------------
class PolytropicCorrection : public BlockBase<PolytropicCorrection> {
 public:
  explicit PolytropicCorrection(const BlockOptions& options) {
    CheckOptionKeys(kPolytropicCorrection, options, {"temperature", "gas_constant"});
    const double t =
        PositiveOption(kPolytropicCorrection, options, "temperature", pn::kNominalTemperature);
    const double r =
        PositiveOption(kPolytropicCorrection, options, "gas_constant", pn::kAirGasConstant);
    volume_to_mass_ = kJoulePerKpaMm3 / (r * t);
    info_.type = kPolytropicCorrection;
    info_.description =
        "Relative change e of a chamber's polytropic exponent, applied to its net inflow: "
        "mdot_eff = (1 + e) mdot - e p Vdot / (R T).";
    info_.reference = "seed 004 eq. 3.3 with the exponent n (1 + e) (chamber_effects.h)";
    info_.inputs = {Flow("mdot", "net mass flow into the chamber"),
                    Pressure(),
                    {"volume_rate", "mm^3/s", "rate of change of the chamber volume",
                     -kVolumeRateMax, kVolumeRateMax}};
    info_.outputs = {Flow("mdot_eff", "net inflow giving the chamber the exponent n (1 + e)")};
    info_.parameters = {
        MakeParameter("e", "1", "relative change of the polytropic exponent", 0.0, -0.5, 1.0, 0.0)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = (1.0 + a.p[0]) * a.u[0] - a.p[0] * (a.u[1] * a.u[2] * volume_to_mass_);
  }

 private:
  double volume_to_mass_ = 1.0;
};

template <typename T>
BlockFactory Factory() {
  return [](const BlockOptions& options) -> std::unique_ptr<Block> {
    return std::make_unique<T>(options);
  };
}

}  // namespace

void RegisterChamberEffectBlocks(BlockRegistry& registry) {
  registry.Register(kChamberLeak, Factory<ChamberLeak>());
  registry.Register(kPolytropicCorrection, Factory<PolytropicCorrection>());
}

}  // namespace graybox::models::internal
