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
                                "': option 'axis_inertia' is required: expected the inertia M of "
                                "the body on the axis (a number > 0), got none");
  }
  return PositiveOption(type, options, "axis_inertia", 1.0);
}

bool IsPrismatic(const std::string& type, const BlockOptions& options) {
  return WordOption(type, options, "motion", "rotational", {"rotational", "prismatic"}) ==
         "prismatic";
}

// Typical magnitude of a net force [N m] or [N] (the range of F and F_eff in loads.h).
constexpr double kTypicalForce = 10.0;

SignalInfo NetForce(const char* name, const char* description) {
  SignalInfo s{name, "N m", description, -kTypicalForce, kTypicalForce};
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

// ---- mechanics.elastic_coupling -----------------------------------------------------------------
// Lower bounds of J and K relative to M and K_0 (loads.h).
constexpr double kMinInertiaFraction = 1e-6;
constexpr double kMinStiffnessFraction = 1e-6;

class ElasticCoupling : public BlockBase<ElasticCoupling> {
 public:
  explicit ElasticCoupling(const BlockOptions& options) {
    CheckOptionKeys(kElasticCoupling, options, {"axis_inertia", "motion", "frequency"});
    axis_inertia_ = AxisInertia(kElasticCoupling, options);
    const double f0 =
        PositiveOption(kElasticCoupling, options, "frequency", kDefaultCouplingFrequency);
    const double m = axis_inertia_;
    const double j = kDefaultCouplingInertiaRatio * m;
    const double j_eff = 1.0 / (1.0 / j + 1.0 / m);
    const double omega = 2.0 * kPi * f0;
    const double k = omega * omega * j_eff;
    const double c = 2.0 * kDefaultCouplingDamping * std::sqrt(k * j_eff);
    const double e_typical = kTypicalForce / k;
    info_.type = kElasticCoupling;
    info_.description =
        "Elastic coupling: a motor-side inertia J driven by the net force F, joined to the body "
        "(inertia M) by a spring K and damper c; the body reads F_c = K e + c ed.";
    info_.reference = "two-mass axis, Newton's second law on each side of the spring (loads.h)";
    info_.states = {
        {"e", "rad", "deflection q_m - q (motor side minus body)", -e_typical, e_typical},
        {"ed", "rad/s", "deflection rate qd_m - qd", -omega * e_typical, omega * e_typical}};
    info_.inputs = {NetForce("F", "net force on the axis, now acting on the motor side")};
    info_.outputs = {NetForce("F_c", "coupling force K e + c ed the body reads")};
    info_.parameters = {
        MakeParameter("J", "kg m^2", "motor-side inertia", j, kMinInertiaFraction * m, kInf),
        MakeParameter("K", "N m/rad", "coupling stiffness", k, kMinStiffnessFraction * k, kInf),
        MakeParameter("c", "N m s/rad", "coupling damping", c, 0.0, kInf)};
    ApplyMotionUnits(kElasticCoupling, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const Scalar& e = a.x[0];
    const Scalar& ed = a.x[1];
    const Scalar& j = a.p[0];
    const Scalar& k = a.p[1];
    const Scalar& c = a.p[2];
    const Scalar f_c = k * e + c * ed;
    a.xdot[0] = ed;
    a.xdot[1] = (a.u[0] - f_c) / j - f_c / axis_inertia_;
    a.y[0] = f_c;
  }

 private:
  double axis_inertia_ = 1.0;
};

// ---- mechanics.spring_damper --------------------------------------------------------------------
class SpringDamper : public BlockBase<SpringDamper> {
 public:
  explicit SpringDamper(const BlockOptions& options) {
    CheckOptionKeys(kSpringDamper, options, {"motion"});
    info_.type = kSpringDamper;
    info_.description =
        "Spring and damper between two positions: F = k (q_a - q_b) + c (qd_a - qd_b), F on end b, "
        "-F on end a.";
    info_.reference = "Hooke's law with linear damping (loads.h)";
    info_.inputs = {{"q_a", "rad", "position of end a", -1.0, 1.0, SignalRole::kPosition},
                    {"q_b", "rad", "position of end b", -1.0, 1.0, SignalRole::kPosition},
                    {"qd_a", "rad/s", "speed of end a", -10.0, 10.0, SignalRole::kVelocity},
                    {"qd_b", "rad/s", "speed of end b", -10.0, 10.0, SignalRole::kVelocity}};
    info_.outputs = {NetForce("F_b", "force on end b (towards a when stretched)"),
                     NetForce("F_a", "force on end a (equal and opposite)")};
    info_.parameters = {MakeParameter("k", "N m/rad", "stiffness", 1.0, 0.0, kInf, 0.0),
                        MakeParameter("c", "N m s/rad", "damping", 0.0, 0.0, kInf, 0.0)};
    ApplyMotionUnits(kSpringDamper, options, &info_);
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const Scalar f = a.p[0] * (a.u[0] - a.u[1]) + a.p[1] * (a.u[2] - a.u[3]);
    a.y[0] = f;
    a.y[1] = -f;
  }
};

// ---- mechanics.gravity --------------------------------------------------------------------------
class GravityLoad : public BlockBase<GravityLoad> {
 public:
  explicit GravityLoad(const BlockOptions& options) {
    CheckOptionKeys(kGravityLoad, options, {"motion", "gravity"});
    prismatic_ = IsPrismatic(kGravityLoad, options);
    if (!prismatic_ && HasNumber(options, "gravity")) {
      throw std::invalid_argument("block '" + std::string(kGravityLoad) +
                                  "': option 'gravity' applies to motion = \"prismatic\" only");
    }
    gravity_ = PositiveOption(kGravityLoad, options, "gravity", kStandardGravity);
    info_.type = kGravityLoad;
    info_.reference = "the weight of a body on its axis (loads.h)";
    if (prismatic_) {
      info_.description = "Gravity load on a vertical prismatic axis: F_g = m g.";
      info_.inputs = {{"q", "m", "axis position (not used)", -1.0, 1.0, SignalRole::kPosition}};
      SignalInfo f = NetForce("F_g", "weight of the moving mass along the axis");
      f.unit = "N";
      info_.outputs = {f};
      info_.parameters = {MakeParameter("m", "kg", "moving mass", 1.0, 0.0, kInf, 0.0)};
    } else {
      info_.description = "Gravity load on a rotary axis: tau_g = mgl sin(q - q_down).";
      info_.inputs = {{"q", "rad", "axis angle", -kPi, kPi, SignalRole::kPosition}};
      info_.outputs = {NetForce("tau_g", "gravity torque, pulling towards q_down")};
      info_.parameters = {
          MakeParameter("mgl", "N m", "m g l of the centre of mass", 1.0, -kInf, kInf, 0.0),
          MakeParameter("q_down", "rad", "angle of the hanging position", 0.0, -kPi, kPi)};
    }
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    using std::sin;
    if (prismatic_) {
      a.y[0] = a.p[0] * gravity_;
    } else {
      a.y[0] = a.p[0] * sin(a.u[0] - a.p[1]);
    }
  }

 private:
  bool prismatic_ = false;
  double gravity_ = kStandardGravity;
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
  registry.Register(kElasticCoupling, Factory<ElasticCoupling>(), test);
  registry.Register(kSpringDamper, Factory<SpringDamper>());
  registry.Register(kGravityLoad, Factory<GravityLoad>());
}

}  // namespace graybox::models::internal
