// A user's own block as a plugin of the `graybox` command (graybox/models/block_plugin.h): a
// cubic spring-damper force on an axis, tau = k q + k3 q^3 + c qd, registered as
// "user.cubic_spring". Built as a MODULE library that does not link the graybox libraries
// (CMakeLists.txt beside it).
#include <memory>

#include "graybox/models/block_plugin.h"

namespace {

using graybox::models::BlockArgs;
using graybox::models::BlockOptions;
using graybox::models::ParameterInfo;
using graybox::models::SignalInfo;
using graybox::models::SignalRole;

class CubicSpring : public graybox::models::BlockBase<CubicSpring> {
 public:
  explicit CubicSpring(const BlockOptions& /*options*/) {
    info_.type = "user.cubic_spring";
    info_.description = "Cubic spring and linear damper on an axis: tau = k q + k3 q^3 + c qd.";
    info_.reference = "tests/consumer/user_blocks.cc";
    info_.inputs = {{"q", "m", "axis position", -0.5, 0.5, SignalRole::kPosition},
                    {"qd", "m/s", "axis velocity", -2.0, 2.0, SignalRole::kVelocity}};
    info_.outputs = {{"tau", "N", "spring and damper force", -50.0, 50.0, SignalRole::kForce}};
    ParameterInfo k{"k", "N/m", "linear stiffness", 40.0, 0.0, 1e6};
    ParameterInfo k3{"k3", "N/m^3", "cubic stiffness", 0.0, -1e6, 1e6};
    k3.neutral = 0.0;
    ParameterInfo c{"c", "N s/m", "damping", 1.0, 0.0, 1e4};
    info_.parameters = {k, k3, c};
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = a.p[0] * a.u[0] + a.p[1] * a.u[0] * a.u[0] * a.u[0] + a.p[2] * a.u[1];
  }
};

}  // namespace

GRAYBOX_BLOCK_PLUGIN(registry) {
  registry.Register("user.cubic_spring", [](const BlockOptions& o) {
    return std::unique_ptr<graybox::models::Block>(new CubicSpring(o));
  });
}
