// The sensor and actuator error blocks; equations, units, parameters and choices are documented in
// include/graybox/models/sensors.h.
#include "graybox/models/sensors.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "builtin_blocks.h"
#include "mechanical_block_helpers.h"

namespace graybox::models::internal {
namespace {

// Options "unit" and "typical_range" shared by the three blocks.
struct Quantity {
  std::string unit = "1";
  double lo = -1.0, hi = 1.0;
  double Magnitude() const { return std::max(std::fabs(lo), std::fabs(hi)); }
};

Quantity ReadQuantity(const std::string& type, const BlockOptions& options) {
  Quantity q;
  if (auto it = options.words.find("unit"); it != options.words.end()) {
    if (it->second.empty()) {
      throw std::invalid_argument("block '" + type +
                                  "': option 'unit' expected a unit such as \"m\", got \"\"");
    }
    q.unit = it->second;
  }
  if (auto it = options.numbers.find("typical_range"); it != options.numbers.end()) {
    if (it->second.size() != 2 || !std::isfinite(it->second[0]) || !std::isfinite(it->second[1]) ||
        !(it->second[0] < it->second[1])) {
      throw std::invalid_argument("block '" + type +
                                  "': option 'typical_range' expected two finite numbers "
                                  "min < max, got " +
                                  std::to_string(it->second.size()) + " value(s)");
    }
    q.lo = it->second[0];
    q.hi = it->second[1];
  }
  return q;
}

// ---- sensor.offset ------------------------------------------------------------------------------
class SensorOffset : public BlockBase<SensorOffset> {
 public:
  explicit SensorOffset(const BlockOptions& options) {
    CheckOptionKeys(kSensorOffset, options, {"unit", "typical_range"});
    const Quantity q = ReadQuantity(kSensorOffset, options);
    info_.type = kSensorOffset;
    info_.description = "Additive sensor offset y = u + b.";
    info_.reference = "sensor error model (sensors.h)";
    info_.inputs = {{"u", q.unit, "true signal", q.lo, q.hi}};
    info_.outputs = {{"y", q.unit, "measured signal", q.lo, q.hi}};
    info_.parameters = {
        MakeParameter("b", q.unit, "offset of the sensor reading", 0.0, -kInf, kInf, 0.0)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = a.u[0] + a.p[0];
  }
};

// ---- sensor.scale -------------------------------------------------------------------------------
class SensorScale : public BlockBase<SensorScale> {
 public:
  explicit SensorScale(const BlockOptions& options) {
    CheckOptionKeys(kSensorScale, options, {"unit", "typical_range"});
    const Quantity q = ReadQuantity(kSensorScale, options);
    info_.type = kSensorScale;
    info_.description = "Sensor gain error y = (1 + s) u.";
    info_.reference = "sensor error model (sensors.h)";
    info_.inputs = {{"u", q.unit, "true signal", q.lo, q.hi}};
    info_.outputs = {{"y", q.unit, "measured signal", q.lo, q.hi}};
    info_.parameters = {
        MakeParameter("s", "1", "relative gain error of the sensor", 0.0, -0.5, 0.5, 0.0)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = (1.0 + a.p[0]) * a.u[0];
  }
};

// ---- actuator.deadzone --------------------------------------------------------------------------
class ActuatorDeadzone : public BlockBase<ActuatorDeadzone> {
 public:
  explicit ActuatorDeadzone(const BlockOptions& options) {
    CheckOptionKeys(kActuatorDeadzone, options, {"unit", "typical_range", "smoothing"});
    const Quantity q = ReadQuantity(kActuatorDeadzone, options);
    smoothing_ = PositiveOption(kActuatorDeadzone, options, "smoothing",
                                kDefaultDeadzoneSmoothing * q.Magnitude());
    info_.type = kActuatorDeadzone;
    info_.description =
        "Smooth actuator dead zone y = u - (sqrt((u + b)^2 + eps^2) - sqrt((u - b)^2 + eps^2))/2 "
        "(no output for |u| < b; exactly y = u at b = 0).";
    info_.reference = "smooth dead zone of drive.backlash (drives.h) on a command (sensors.h)";
    info_.inputs = {{"u", q.unit, "command", q.lo, q.hi}};
    info_.outputs = {{"y", q.unit, "command after the dead zone", q.lo, q.hi}};
    info_.parameters = {MakeParameter("b", q.unit, "half width of the dead zone",
                                      0.02 * q.Magnitude(), 0.0, kInf, 0.0)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = SmoothDeadZone(a.u[0], a.p[0], smoothing_);
  }

 private:
  double smoothing_ = kDefaultDeadzoneSmoothing;
};

template <typename T>
BlockFactory Factory() {
  return [](const BlockOptions& options) -> std::unique_ptr<Block> {
    return std::make_unique<T>(options);
  };
}

}  // namespace

void RegisterSensorBlocks(BlockRegistry& registry) {
  registry.Register(kSensorOffset, Factory<SensorOffset>());
  registry.Register(kSensorScale, Factory<SensorScale>());
  BlockOptions deadzone;
  deadzone.words["unit"] = "V";
  deadzone.numbers["typical_range"] = {-10.0, 10.0};
  registry.Register(kActuatorDeadzone, Factory<ActuatorDeadzone>(), deadzone);
}

}  // namespace graybox::models::internal
