// The transmission effect blocks; equations, units, parameters and choices are documented in
// include/graybox/models/transmission_effects.h.
#include "graybox/models/transmission_effects.h"

#include <memory>
#include <stdexcept>
#include <string>

#include "builtin_blocks.h"
#include "graybox/models/drives.h"
#include "mechanical_block_helpers.h"

namespace graybox::models::internal {
namespace {

class BacklashCorrection : public BlockBase<BacklashCorrection> {
 public:
  explicit BacklashCorrection(const BlockOptions& options) {
    CheckOptionKeys(kBacklashCorrection, options, {"stiffness", "damping", "smoothing"});
    if (!HasNumber(options, "stiffness")) {
      throw std::invalid_argument("block '" + std::string(kBacklashCorrection) +
                                  "': option 'stiffness' (the joint's Ke, > 0) is required");
    }
    stiffness_ = PositiveOption(kBacklashCorrection, options, "stiffness", 1.0);
    damping_ = NumberOption(kBacklashCorrection, options, "damping", 0.0);
    if (!(damping_ >= 0.0)) {
      throw std::invalid_argument("block '" + std::string(kBacklashCorrection) +
                                  "': option 'damping' expected a number >= 0, got " +
                                  FormatNumber(damping_));
    }
    smoothing_ =
        PositiveOption(kBacklashCorrection, options, "smoothing", kDefaultBacklashSmoothing);
    info_.type = kBacklashCorrection;
    info_.description =
        "Backlash added to an elastic joint: the change Ke (DZ(delta) - delta) + d (DZ'(delta) - "
        "1) d(delta)/dt of its joint torque, DZ a smooth dead zone of half width b.";
    info_.reference = "drive.two_mass with backlash (seed 002 eq. 6-1; transmission_effects.h)";
    constexpr SignalRole kPosition = SignalRole::kPosition, kVelocity = SignalRole::kVelocity,
                         kForce = SignalRole::kForce;
    info_.inputs = {{"q_m", "rad", "motor angle", -1.0, 1.0, kPosition},
                    {"q_l", "rad", "load angle", -1.0, 1.0, kPosition},
                    {"qd_m", "rad/s", "motor speed", -20.0, 20.0, kVelocity},
                    {"qd_l", "rad/s", "load speed", -20.0, 20.0, kVelocity}};
    info_.outputs = {
        {"tau_motor", "N m", "joint torque change (subtract from the motor torque)", -0.4, 0.4,
         kForce},
        {"tau_load", "N m", "joint torque change (add to the load torque)", -0.4, 0.4, kForce},
        {"tau_joint", "N m", "joint torque change (add to the joint's reported tau_s)", -0.4, 0.4,
         kForce}};
    info_.parameters = {
        MakeParameter("b", "rad", "backlash: half width of the dead zone", 2e-3, 0.0, 0.5, 0.0)};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const Scalar delta = a.u[0] - a.u[1];
    const Scalar delta_dot = a.u[2] - a.u[3];
    const Scalar& b = a.p[0];
    const Scalar change = stiffness_ * (SmoothDeadZone(delta, b, smoothing_) - delta) +
                          damping_ * (SmoothDeadZoneSlope(delta, b, smoothing_) - 1.0) * delta_dot;
    a.y[0] = change;
    a.y[1] = change;
    a.y[2] = change;
  }

 private:
  double stiffness_ = 1.0;
  double damping_ = 0.0;
  double smoothing_ = kDefaultBacklashSmoothing;
};

}  // namespace

void RegisterTransmissionEffectBlocks(BlockRegistry& registry) {
  BlockOptions test;
  test.numbers["stiffness"] = {8.459};
  test.numbers["damping"] = {0.01};
  registry.Register(
      kBacklashCorrection,
      [](const BlockOptions& options) -> std::unique_ptr<Block> {
        return std::make_unique<BacklashCorrection>(options);
      },
      test);
}

}  // namespace graybox::models::internal
