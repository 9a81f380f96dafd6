// The added-load blocks; equations, units, parameters and choices are documented in
// include/graybox/models/loads.h.
#include "graybox/models/loads.h"

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "builtin_blocks.h"
#include "mechanical_block_helpers.h"

namespace graybox::models::internal {
namespace {

double AxisInertia(const std::string& type, const BlockOptions& options) {
  if (!HasNumber(options, "axis_inertia")) {
    throw std::invalid_argument("block '" + type +
                                "': option 'axis_inertia' (the inertia of the body the load is "
                                "added to, > 0) is required");
  }
  return PositiveOption(type, options, "axis_inertia", 1.0);
}

bool IsPrismatic(const std::string& type, const BlockOptions& options) {
  return WordOption(type, options, "motion", "rotational", {"rotational", "prismatic"}) ==
         "prismatic";
}

SignalInfo NetForce(const char* name, const char* description) {
  SignalInfo s{name, "N m", description, -10.0, 10.0};
  s.role = SignalRole::kForce;
  return s;
}

// ---- mechanics.added_inertia --------------------------------------------------------------------
class AddedInertia : public BlockBase<AddedInertia> {
 public:
  explicit AddedInertia(const BlockOptions& options) {
    CheckOptionKeys(kAddedInertia, options, {"axis_inertia", "motion"});
    axis_inertia_ = AxisInertia(kAddedInertia, options);
    info_.type = kAddedInertia;
    info_.description =
        "Added inertia dM on a rigid axis of inertia M: the body reads F / (1 + dM / M).";
    info_.reference = "Newton's second law with the inertia M + dM (loads.h)";
    info_.inputs = {NetForce("F", "net force on the axis")};
    info_.outputs = {NetForce("F_eff", "net force scaled to the body's own inertia")};
    info_.parameters = {MakeParameter("dM", "kg m^2", "added inertia", 0.0, 0.0, kInf, 0.0)};
    ApplyMotionUnits(kAddedInertia, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    a.y[0] = a.u[0] / (1.0 + a.p[0] / axis_inertia_);
  }

 private:
  double axis_inertia_ = 1.0;
};

// ---- mechanics.payload --------------------------------------------------------------------------
class Payload : public BlockBase<Payload> {
 public:
  explicit Payload(const BlockOptions& options) {
    CheckOptionKeys(kPayload, options, {"axis_inertia", "motion", "gravity"});
    axis_inertia_ = AxisInertia(kPayload, options);
    prismatic_ = IsPrismatic(kPayload, options);
    gravity_ = NumberOption(kPayload, options, "gravity", -kStandardGravity);
    if (!prismatic_ && HasNumber(options, "gravity")) {
      throw std::invalid_argument("block '" + std::string(kPayload) +
                                  "': option 'gravity' applies to motion = \"prismatic\" only");
    }
    info_.type = kPayload;
    info_.description =
        prismatic_ ? "Payload of mass m on a prismatic axis: (F + m g_q) / (1 + m / M)."
                   : "Payload on a rotational axis: (F - g_s sin q - g_c cos q) / (1 + dM / M).";
    info_.reference = "Newton's second law with the payload's inertia and weight (loads.h)";
    SignalInfo q{"q", "rad", "axis position", -kPi, kPi, SignalRole::kPosition};
    if (prismatic_) {
      q.typical_min = 0.0;
      q.typical_max = 0.25;
    }
    info_.inputs = {NetForce("F", "net force on the axis"), q};
    info_.outputs = {NetForce("F_eff", "net force with the weight, scaled to the body's inertia")};
    if (prismatic_) {
      info_.parameters = {MakeParameter("m", "kg", "payload mass", 0.0, 0.0, kInf, 0.0)};
    } else {
      info_.parameters = {
          MakeParameter("g_s", "N m", "gravity torque amplitude on sin q", 0.0, -kInf, kInf, 0.0),
          MakeParameter("g_c", "N m", "gravity torque amplitude on cos q", 0.0, -kInf, kInf, 0.0),
          MakeParameter("dM", "kg m^2", "payload inertia about the axis", 0.0, 0.0, kInf, 0.0)};
    }
    ApplyMotionUnits(kPayload, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    using std::cos;
    using std::sin;
    if (prismatic_) {
      a.y[0] = (a.u[0] + a.p[0] * gravity_) / (1.0 + a.p[0] / axis_inertia_);
    } else {
      a.y[0] =
          (a.u[0] - a.p[0] * sin(a.u[1]) - a.p[1] * cos(a.u[1])) / (1.0 + a.p[2] / axis_inertia_);
    }
  }

 private:
  double axis_inertia_ = 1.0;
  double gravity_ = -kStandardGravity;
  bool prismatic_ = false;
};

template <typename T>
BlockFactory Factory() {
  return [](const BlockOptions& options) -> std::unique_ptr<Block> {
    return std::make_unique<T>(options);
  };
}

}  // namespace

void RegisterLoadBlocks(BlockRegistry& registry) {
  BlockOptions test;
  test.numbers["axis_inertia"] = {0.5};
  registry.Register(kAddedInertia, Factory<AddedInertia>(), test);
  registry.Register(kPayload, Factory<Payload>(), test);
}

}  // namespace graybox::models::internal
