// The robot block family; equations, signals, parameters and options are documented in
// include/graybox/models/robot_blocks.h. One generic block class evaluates every variant (state
// space, acceleration, inverse dynamics; plain chain or roblue KUKA) from the templates of
// rigid_body_dynamics.h, regressor.h and kuka_kr300.h.
#include "graybox/models/robot_blocks.h"
#include "graybox/util/did_you_mean.h"

#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "builtin_blocks.h"
#include "graybox/models/rigid_body_dynamics.h"

namespace graybox::models {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNoNeutral = std::numeric_limits<double>::quiet_NaN();

// KUKA typical ranges: the roblue data sets (SOURCE.md) have |q| < 1.8 rad, |qd| < 2.05 rad/s and
// motor torques in [-20.5, 12.8] N m.
constexpr double kKukaPositionRange = 1.5;        // [rad]
constexpr double kKukaVelocityRange = 2.0;        // [rad/s]
constexpr double kKukaMotorTorqueRange = 20.0;    // [N m]
constexpr double kKukaJointTorqueRange = 5000.0;  // [N m], u tau_m ~ 250 * 20
constexpr double kKukaAccelerationRange = 5.0;    // [rad/s^2]

enum class Form { kStateSpace, kAcceleration, kInverse };

struct Config {
  explicit Config(SerialChain c) : chain(std::move(c)) {}
  std::string type;
  std::string description;
  std::string reference;
  SerialChain chain;
  Form form = Form::kStateSpace;
  bool inertial_parameters = true;
  InertialParameterSet set = InertialParameterSet::kWithRotorInertia;
  bool kuka = false;  // motor-torque inputs through the gears, friction parameters, HWC
  bool joint_torque_inputs = false;
  JointOutputs outputs = JointOutputs::kNone;
  DynamicsParts parts = DynamicsParts::kNone;
  bool feature_outputs = false;
};

std::string Joint(const char* prefix, int i) { return prefix + std::to_string(i + 1); }

bool Revolute(const SerialChain& chain, int i) {
  return chain.link(i).joint_type == JointType::kRevolute;
}

// An upper estimate of the static gravity torque of a chain: |g| sum_i m_i (reach up to link i +
// |c_i|) [N m]; used as the typical torque range (plus 1, so a massless test chain has a range).
double TorqueScale(const SerialChain& chain) {
  double reach = 0.0, torque = 0.0;
  for (int i = 0; i < chain.dof(); ++i) {
    const Link& l = chain.link(i);
    reach += std::fabs(l.a) + std::fabs(l.d);
    torque += l.mass * (reach + l.center_of_mass.norm());
  }
  return chain.gravity().norm() * torque + 1.0;
}

class RobotDynamicsBlock : public BlockBase<RobotDynamicsBlock> {
 public:
  explicit RobotDynamicsBlock(Config config) : c_(std::move(config)) {
    const SerialChain& chain = c_.chain;
    const int n = chain.dof();
    info_.type = c_.type;
    info_.description = c_.description;
    info_.reference = c_.reference;
    const double q_range = c_.kuka ? kKukaPositionRange : 3.14159;
    const double qd_range = c_.kuka ? kKukaVelocityRange : 2.0;
    const double qdd_range = c_.kuka ? kKukaAccelerationRange : 5.0;
    const double tau_range = c_.kuka ? kKukaJointTorqueRange : TorqueScale(chain);
    auto unit = [&](int i, const char* revolute, const char* prismatic) {
      return std::string(Revolute(chain, i) ? revolute : prismatic);
    };
    std::vector<SignalInfo> q, qd, qdd, tau;
    for (int i = 0; i < n; ++i) {
      const std::string j = std::to_string(i + 1);
      // Prismatic positions: +-0.5 m around the offset.
      const double qr = Revolute(chain, i) ? q_range : 0.5;
      q.push_back({"q" + j, unit(i, "rad", "m"), "position of joint " + j, -qr, qr});
      qd.push_back(
          {"qd" + j, unit(i, "rad/s", "m/s"), "velocity of joint " + j, -qd_range, qd_range});
      qdd.push_back({"qdd" + j, unit(i, "rad/s^2", "m/s^2"), "acceleration of joint " + j,
                     -qdd_range, qdd_range});
      tau.push_back({"tau" + j, unit(i, "N m", "N"),
                     "torque (force) of the drive of joint " + j + " on link " + j, -tau_range,
                     tau_range});
    }
    // Inputs.
    if (c_.form == Form::kStateSpace) {
      info_.states = q;
      info_.states.insert(info_.states.end(), qd.begin(), qd.end());
    } else {
      info_.inputs = q;
      info_.inputs.insert(info_.inputs.end(), qd.begin(), qd.end());
    }
    if (c_.form == Form::kInverse) {
      info_.inputs.insert(info_.inputs.end(), qdd.begin(), qdd.end());
    } else if (c_.kuka) {
      for (int i = 0; i < n; ++i) {
        info_.inputs.push_back({Joint("tau_m", i), "N m",
                                "motor torque of joint " + std::to_string(i + 1) +
                                    " (motor side; the joint receives u tau_m)",
                                -kKukaMotorTorqueRange, kKukaMotorTorqueRange});
      }
      if (c_.joint_torque_inputs) {
        for (int i = 0; i < n; ++i) {
          info_.inputs.push_back({Joint("tau_j", i), "N m",
                                  "additional torque at joint " + std::to_string(i + 1) +
                                      " (joint side, e.g. from a friction model or a network)",
                                  -1000.0, 1000.0});
        }
      }
    } else {
      info_.inputs.insert(info_.inputs.end(), tau.begin(), tau.end());
    }
    // Outputs.
    if (c_.form == Form::kStateSpace) {
      if (c_.outputs != JointOutputs::kNone) info_.outputs = q;
      if (c_.outputs == JointOutputs::kPositionsAndVelocities) {
        info_.outputs.insert(info_.outputs.end(), qd.begin(), qd.end());
      }
    } else if (c_.form == Form::kAcceleration) {
      info_.outputs = qdd;
      if (c_.feature_outputs) {
        for (SignalInfo s : qdd) {
          s.description = "copy of " + s.name + " (physics acceleration as a network feature)";
          s.name = "qdd_p" + s.name.substr(3);
          info_.outputs.push_back(s);
        }
      }
      AddPartOutputs(qdd_range, tau_range);
    } else {
      info_.outputs = tau;
      if (c_.feature_outputs) {
        for (SignalInfo s : tau) {
          s.description = "copy of " + s.name + " (physics torque as a network feature)";
          s.name = "tau_p" + s.name.substr(3);
          info_.outputs.push_back(s);
        }
      }
    }
    // Parameters.
    if (c_.inertial_parameters) {
      const std::vector<std::string> names = InertialParameterNames(chain, c_.set);
      const std::vector<std::string> units = InertialParameterUnits(chain, c_.set);
      const Eigen::VectorXd nominal = InertialParameters(chain, c_.set);
      const int per_link = ParametersPerLink(c_.set);
      static const char* const kMeaning[] = {
          "mass",
          "first moment of mass m c_x in the link frame",
          "first moment of mass m c_y in the link frame",
          "first moment of mass m c_z in the link frame",
          "inertia tensor entry xx about the link-frame origin",
          "inertia tensor entry xy about the link-frame origin (tensor entry, -sum m x y)",
          "inertia tensor entry xz about the link-frame origin (tensor entry, -sum m x z)",
          "inertia tensor entry yy about the link-frame origin",
          "inertia tensor entry yz about the link-frame origin (tensor entry, -sum m y z)",
          "inertia tensor entry zz about the link-frame origin",
          "reflected rotor inertia J_m u^2 of the drive"};
      for (int k = 0; k < static_cast<int>(names.size()); ++k) {
        const int entry = k % per_link;
        const bool nonnegative = entry == kMass || entry == kInertiaXX || entry == kInertiaYY ||
                                 entry == kInertiaZZ || entry == kRotorInertia;
        ParameterInfo p;
        p.name = names[k];
        p.unit = units[k];
        p.description =
            std::string(kMeaning[entry]) + " of link " + std::to_string(k / per_link + 1);
        p.nominal = nominal[k];
        p.lower = nonnegative ? 0.0 : -kInf;
        p.upper = kInf;
        p.neutral = kNoNeutral;
        info_.parameters.push_back(p);
      }
    }
    if (c_.kuka && c_.form != Form::kInverse) {
      const KukaFrictionParameters f = KukaRoblueFriction();
      for (int i = 0; i < n; ++i) {
        info_.parameters.push_back(
            {Joint("f_asym", i), "N m",
             "asymmetric (constant) friction torque of joint " + std::to_string(i + 1),
             f.f_asym[static_cast<std::size_t>(i)], -kInf, kInf, 0.0});
      }
      for (int i = 0; i < n; ++i) {
        info_.parameters.push_back({Joint("f_coul", i), "N m",
                                    "Coulomb friction level of joint " + std::to_string(i + 1) +
                                        " (tanh-smoothed, 1 s/rad)",
                                    f.f_coul[static_cast<std::size_t>(i)], 0.0, kInf, 0.0});
      }
      for (int i = 0; i < n; ++i) {
        info_.parameters.push_back(
            {Joint("f_vis", i), "N m s/rad",
             "viscous friction coefficient of joint " + std::to_string(i + 1),
             f.f_vis[static_cast<std::size_t>(i)], 0.0, kInf, 0.0});
      }
    }
    bodies_ = internal::ChainBodies<double>::Get(chain);
  }

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const;

 private:
  void AddPartOutputs(double qdd_range, double tau_range) {
    if (c_.parts == DynamicsParts::kNone) return;
    const bool acc = c_.parts == DynamicsParts::kAccelerations;
    const double range = acc ? qdd_range : tau_range;
    const std::string unit = acc ? "rad/s^2" : "N m";
    const std::string pre = acc ? "qdd_" : "tau_";
    const std::string m_inv = acc ? "M^-1 " : "";
    const int n = c_.chain.dof();
    struct Part {
      const char* name;
      const char* what;
    };
    for (const Part& part :
         {Part{"u", "u o tau_m (drive torque)"},
          Part{"c", "C(q, qd) qd (Coriolis and centrifugal)"}, Part{"g", "g(q) (gravity)"}}) {
      for (int i = 0; i < n; ++i) {
        info_.outputs.push_back({pre + part.name + std::to_string(i + 1), unit,
                                 "entry " + std::to_string(i + 1) + " of " + m_inv + part.what,
                                 -range, range});
      }
    }
    if (acc) {
      for (int i = 0; i < n; ++i) {
        info_.outputs.push_back(
            {"qdd_hwc" + std::to_string(i + 1), unit,
             "entry " + std::to_string(i + 1) + " of M^-1 e_2 tau_HWC (counterbalance)", -range,
             range});
      }
    } else {
      info_.outputs.push_back(
          {"tau_hwc2", unit, "counterbalance torque tau_HWC on joint 2", -range, range});
    }
  }

  int NumInertialParameters() const {
    return c_.inertial_parameters ? models::NumInertialParameters(c_.chain, c_.set) : 0;
  }

  Config c_;
  BodyParameterArray<double> bodies_;  // the chain's, when the inertia is not a parameter
};

template <typename Scalar>
void RobotDynamicsBlock::Compute(const BlockArgs<Scalar>& a) const {
  using std::tanh;
  const SerialChain& chain = c_.chain;
  const int n = chain.dof();
  JointVector<Scalar> q(n), qd(n);
  const Scalar* state = c_.form == Form::kStateSpace ? a.x : a.u;
  for (int i = 0; i < n; ++i) {
    q[i] = state[i];
    qd[i] = state[n + i];
  }
  const int input_offset = c_.form == Form::kStateSpace ? 0 : 2 * n;  // first torque/qdd input
  BodyParameterArray<Scalar> bodies;
  if (c_.inertial_parameters) {
    bodies = BodiesFromInertialParameters(chain, a.p, c_.set);
  } else {
    for (int i = 0; i < n; ++i) bodies[i] = bodies_[i].template Cast<Scalar>();
  }
  if (c_.form == Form::kInverse) {
    JointVector<Scalar> qdd(n);
    for (int i = 0; i < n; ++i) qdd[i] = a.u[input_offset + i];
    const JointVector<Scalar> tau = InverseDynamics(chain, bodies, q, qd, qdd);
    for (int i = 0; i < n; ++i) {
      a.y[i] = tau[i];
      if (c_.feature_outputs) a.y[n + i] = tau[i];
    }
    return;
  }
  // Joint torques.
  JointVector<Scalar> tau(n);
  JointVector<Scalar> drive(n);  // u o tau_m (KUKA) or tau
  for (int i = 0; i < n; ++i) {
    const Scalar& in = a.u[input_offset + i];
    drive[i] = c_.kuka ? kKukaGearRatios[static_cast<std::size_t>(i)] * in : in;
  }
  Scalar hwc(0.0);
  if (c_.kuka) {
    // tau = u o tau_m (+ tau_j) - (tau_f(qd) + tau_HWC e_2), in the order of KukaForwardDynamics
    // (so the block with nominal parameters reproduces it to rounding).
    const Scalar* f = a.p + NumInertialParameters();  // f_asym1..n, f_coul1..n, f_vis1..n
    JointVector<Scalar> non_rigid(n);
    for (int i = 0; i < n; ++i) {
      non_rigid[i] = f[i] + f[2 * n + i] * qd[i] + f[n + i] * tanh(qd[i]);
    }
    hwc = KukaHwcTorque(Scalar(q[1] + kKukaJointOffsets[1]));
    non_rigid[1] += hwc;
    tau = -non_rigid;
    for (int i = 0; i < n; ++i) tau[i] += drive[i];
    if (c_.joint_torque_inputs) {
      for (int i = 0; i < n; ++i) tau[i] += a.u[input_offset + n + i];
    }
  } else {
    tau = drive;
  }
  const JointVector<Scalar> qdd = ForwardDynamics(chain, bodies, q, qd, tau);
  if (c_.form == Form::kStateSpace) {
    for (int i = 0; i < n; ++i) {
      a.xdot[i] = qd[i];
      a.xdot[n + i] = qdd[i];
    }
    if (c_.outputs != JointOutputs::kNone) {
      for (int i = 0; i < n; ++i) a.y[i] = q[i];
    }
    if (c_.outputs == JointOutputs::kPositionsAndVelocities) {
      for (int i = 0; i < n; ++i) a.y[n + i] = qd[i];
    }
    return;
  }
  for (int i = 0; i < n; ++i) a.y[i] = qdd[i];
  Scalar* out = a.y + n;
  if (c_.feature_outputs) {
    for (int i = 0; i < n; ++i) out[i] = qdd[i];
    out += n;
  }
  if (c_.parts == DynamicsParts::kNone) return;
  const JointVector<Scalar> coriolis = CoriolisForces(chain, bodies, q, qd);
  const JointVector<Scalar> gravity = GravityTorques(chain, bodies, q);
  if (c_.parts == DynamicsParts::kTorques) {
    for (int i = 0; i < n; ++i) {
      out[i] = drive[i];
      out[n + i] = coriolis[i];
      out[2 * n + i] = gravity[i];
    }
    out[3 * n] = hwc;
    return;
  }
  const JointMatrix<Scalar> m = MassMatrix(chain, bodies, q);
  JointVector<Scalar> e2 = JointVector<Scalar>::Constant(n, Scalar(0.0));
  e2[1] = hwc;
  const JointVector<Scalar> parts[4] = {SolveSpd(m, drive), SolveSpd(m, coriolis),
                                        SolveSpd(m, gravity), SolveSpd(m, e2)};
  for (int k = 0; k < 4; ++k) {
    for (int i = 0; i < n; ++i) out[k * n + i] = parts[k][i];
  }
}

// d/dt q = qd, d/dt qd = qdd.
class JointIntegrator : public BlockBase<JointIntegrator> {
 public:
  explicit JointIntegrator(int dof) : dof_(dof) {
    if (dof < 1) {
      throw std::invalid_argument(std::string("block '") + kJointIntegratorBlock +
                                  "': expected dof >= 1, got " + std::to_string(dof));
    }
    info_.type = kJointIntegratorBlock;
    info_.description =
        "Joint kinematics d/dt q = qd, d/dt qd = qdd: turns joint accelerations (a signal that "
        "physics and learned blocks add to) into position and velocity states.";
    info_.reference = "seed 000 eq. 1";
    for (int i = 0; i < dof; ++i) {
      const std::string j = std::to_string(i + 1);
      info_.states.push_back({"q" + j, "rad", "position of joint " + j, -1.5, 1.5});
    }
    for (int i = 0; i < dof; ++i) {
      const std::string j = std::to_string(i + 1);
      info_.states.push_back({"qd" + j, "rad/s", "velocity of joint " + j, -2.0, 2.0});
    }
    for (int i = 0; i < dof; ++i) {
      const std::string j = std::to_string(i + 1);
      info_.inputs.push_back({"qdd" + j, "rad/s^2", "acceleration of joint " + j, -5.0, 5.0});
    }
  }
  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    for (int i = 0; i < dof_; ++i) {
      a.xdot[i] = a.x[dof_ + i];
      a.xdot[dof_ + i] = a.u[i];
    }
  }

 private:
  int dof_;
};

const char* const kChainReference =
    "rigid_body_dynamics.h (recursive Newton-Euler, composite rigid body, LDL^T); inertial "
    "parameters as regressor.h";
const char* const kKukaReference =
    "seed 000 eq. 1, 4, 5; roblue (kuka_kr300.h, ../shared/data/roblue_elabee/SOURCE.md)";

Config SerialChainConfig(const SerialChain& chain, const SerialChainBlockOptions& options) {
  Config c(chain);
  c.form = Form::kStateSpace;
  c.set = options.parameters;
  c.type = kSerialChainBlock;
  c.description = "Forward dynamics of the serial chain '" + chain.name() +
                  "': d/dt q = qd, d/dt qd = M^-1 (tau - C qd - g), with the inertial parameters "
                  "of every link as parameters.";
  c.reference = kChainReference;
  c.outputs = options.outputs;
  return c;
}

Config InverseDynamicsConfig(const SerialChain& chain, const InverseDynamicsBlockOptions& options) {
  Config c(chain);
  c.form = Form::kInverse;
  c.set = options.parameters;
  c.type = kInverseDynamicsBlock;
  c.description = "Inverse dynamics of the serial chain '" + chain.name() +
                  "': tau = M qdd + C qd + g = Y(q, qd, qdd) theta, with the inertial parameters "
                  "theta of every link as parameters.";
  c.reference = kChainReference;
  c.feature_outputs = options.feature_outputs;
  return c;
}

Config KukaConfig(const KukaBlockOptions& options, Form form) {
  Config c(KukaKr300R2500(options.payload_kg, options.inertia_reference));
  c.form = form;
  c.kuka = true;
  c.inertial_parameters = options.inertial_parameters;
  c.joint_torque_inputs = options.joint_torque_inputs;
  c.reference = kKukaReference;
  if (form == Form::kStateSpace) {
    c.type = kKukaKr300Block;
    c.description =
        "KUKA KR300 R2500 forward dynamics as roblue models it: d/dt qd = M^-1 (u o tau_m - "
        "tau_f(qd) - g - tau_HWC e_2 - C qd), with the inertial and friction parameters as block "
        "parameters.";
    c.outputs = options.outputs;
  } else {
    c.type = kKukaKr300AccelerationBlock;
    c.description =
        "KUKA KR300 R2500 joint accelerations f_phy(q, qd, tau_m) of roblue's model, without "
        "states (with the option 'parts', also the terms of seed 000 eq. 4 for hybrid models).";
    c.parts = options.parts;
    c.feature_outputs = options.feature_outputs;
  }
  return c;
}

// ---- Option parsing for the registry factories ----------------------------------------------

double Number(const std::string& type, const BlockOptions& options, const std::string& key,
              double fallback) {
  auto it = options.numbers.find(key);
  if (it == options.numbers.end()) return fallback;
  if (it->second.size() != 1 || !std::isfinite(it->second[0])) {
    throw std::invalid_argument("block '" + type + "': option '" + key +
                                "': expected one finite number, got " +
                                std::to_string(it->second.size()) + " values");
  }
  return it->second[0];
}

bool Flag(const std::string& type, const BlockOptions& options, const std::string& key,
          bool fallback) {
  const double v = Number(type, options, key, fallback ? 1.0 : 0.0);
  if (v != 0.0 && v != 1.0) {
    throw std::invalid_argument("block '" + type + "': option '" + key +
                                "': expected 0 or 1, got " + std::to_string(v));
  }
  return v == 1.0;
}

std::string Word(const std::string& type, const BlockOptions& options, const std::string& key,
                 const std::string& fallback, const std::vector<std::string>& allowed) {
  auto it = options.words.find(key);
  if (it == options.words.end()) return fallback;
  for (const auto& a : allowed) {
    if (a == it->second) return a;
  }
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  const std::string hint = util::DidYouMean(it->second, allowed);
  throw std::invalid_argument("block '" + type + "': option '" + key + "': expected one of " +
                              list + ", got '" + it->second + "'" +
                              (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
}

JointOutputs ParseOutputs(const std::string& type, const BlockOptions& options) {
  const std::string w = Word(type, options, "outputs", "none", {"none", "q", "q_qd"});
  return w == "none"
             ? JointOutputs::kNone
             : (w == "q" ? JointOutputs::kPositions : JointOutputs::kPositionsAndVelocities);
}

SerialChain ParseChain(const std::string& type, const BlockOptions& options) {
  const std::string w = Word(type, options, "chain", "test_arm", {"test_arm", "kuka_kr300"});
  return w == "test_arm" ? RobotBlockTestArm() : KukaKr300R2500();
}

InertialParameterSet ParseSet(const std::string& type, const BlockOptions& options) {
  return Flag(type, options, "rotor_inertia", true) ? InertialParameterSet::kWithRotorInertia
                                                    : InertialParameterSet::kRigidBody;
}

KukaBlockOptions ParseKuka(const std::string& type, const BlockOptions& options) {
  KukaBlockOptions k;
  k.payload_kg = Number(type, options, "payload", 150.0);
  k.inertial_parameters = Flag(type, options, "inertial_parameters", true);
  k.joint_torque_inputs = Flag(type, options, "joint_torque_inputs", false);
  k.inertia_reference =
      Word(type, options, "inertia_reference", "origin", {"origin", "center_of_mass"}) == "origin"
          ? InertiaReference::kLinkOrigin
          : InertiaReference::kCenterOfMass;
  return k;
}

}  // namespace

SerialChain RobotBlockTestArm() {
  constexpr double kPi = 3.14159265358979323846;
  std::vector<Link> links(3);
  links[0].alpha = kPi / 2;
  links[0].a = 0.1;
  links[0].d = 0.4;
  links[0].mass = 5.0;
  links[0].center_of_mass = Eigen::Vector3d(-0.05, -0.1, 0.02);
  links[0].inertia << 0.05, 0.004, -0.003, 0.004, 0.04, 0.002, -0.003, 0.002, 0.03;
  links[0].rotor_inertia = 0.2;
  links[1].a = 0.5;
  links[1].theta = 0.3;
  links[1].mass = 3.0;
  links[1].center_of_mass = Eigen::Vector3d(-0.25, 0.01, 0.02);
  links[1].inertia << 0.01, -0.001, 0.002, -0.001, 0.06, 0.001, 0.002, 0.001, 0.06;
  links[1].rotor_inertia = 0.1;
  links[2].joint_type = JointType::kPrismatic;
  links[2].d = 0.1;
  links[2].mass = 1.0;
  links[2].center_of_mass = Eigen::Vector3d(0.01, 0.02, -0.1);
  links[2].inertia << 0.005, 0.0002, 0.0001, 0.0002, 0.005, -0.0003, 0.0001, -0.0003, 0.002;
  links[2].rotor_inertia = 0.5;
  for (Link& l : links) {
    l.inertia_reference = InertiaReference::kCenterOfMass;
    l.gear_ratio = 50.0;
  }
  return SerialChain("robot block test arm", DhConvention::kStandard, std::move(links),
                     Eigen::Vector3d(0.0, 0.0, -9.81));
}

std::shared_ptr<const Block> MakeSerialChainBlock(const SerialChain& chain,
                                                  const SerialChainBlockOptions& options) {
  return std::make_shared<RobotDynamicsBlock>(SerialChainConfig(chain, options));
}

std::shared_ptr<const Block> MakeInverseDynamicsBlock(const SerialChain& chain,
                                                      const InverseDynamicsBlockOptions& options) {
  return std::make_shared<RobotDynamicsBlock>(InverseDynamicsConfig(chain, options));
}

std::shared_ptr<const Block> MakeJointIntegratorBlock(int dof) {
  return std::make_shared<JointIntegrator>(dof);
}

std::shared_ptr<const Block> MakeKukaKr300Block(const KukaBlockOptions& options) {
  return std::make_shared<RobotDynamicsBlock>(KukaConfig(options, Form::kStateSpace));
}

std::shared_ptr<const Block> MakeKukaKr300AccelerationBlock(const KukaBlockOptions& options) {
  return std::make_shared<RobotDynamicsBlock>(KukaConfig(options, Form::kAcceleration));
}

namespace internal {

void RegisterRobotBlocks(BlockRegistry& registry) {
  registry.Register(kSerialChainBlock, [](const BlockOptions& o) -> std::unique_ptr<Block> {
    CheckOptionKeys(kSerialChainBlock, o, {"chain", "outputs", "rotor_inertia"});
    SerialChainBlockOptions options;
    options.outputs = ParseOutputs(kSerialChainBlock, o);
    options.parameters = ParseSet(kSerialChainBlock, o);
    return std::make_unique<RobotDynamicsBlock>(
        SerialChainConfig(ParseChain(kSerialChainBlock, o), options));
  });
  registry.Register(
      kInverseDynamicsBlock,
      [](const BlockOptions& o) -> std::unique_ptr<Block> {
        CheckOptionKeys(kInverseDynamicsBlock, o, {"chain", "rotor_inertia", "feature_outputs"});
        InverseDynamicsBlockOptions options;
        options.parameters = ParseSet(kInverseDynamicsBlock, o);
        options.feature_outputs = Flag(kInverseDynamicsBlock, o, "feature_outputs", false);
        return std::make_unique<RobotDynamicsBlock>(
            InverseDynamicsConfig(ParseChain(kInverseDynamicsBlock, o), options));
      },
      BlockOptions{{{"feature_outputs", {1.0}}}, {}});
  registry.Register(
      kJointIntegratorBlock,
      [](const BlockOptions& o) -> std::unique_ptr<Block> {
        CheckOptionKeys(kJointIntegratorBlock, o, {"dof"});
        const double dof = Number(kJointIntegratorBlock, o, "dof", 6.0);
        if (dof != std::floor(dof) || dof < 1.0 || dof > 1000.0) {
          throw std::invalid_argument(std::string("block '") + kJointIntegratorBlock +
                                      "': option 'dof': expected an integer in [1, 1000], got " +
                                      std::to_string(dof));
        }
        return std::make_unique<JointIntegrator>(static_cast<int>(dof));
      },
      BlockOptions{{{"dof", {2.0}}}, {}});
  // The shared suite checks every partial derivative by finite differences at three points: the
  // state-space KUKA block with all 84 parameters (~0.35 s in Release, ~0.7 s under ASan), the
  // acceleration block, whose parts triple the work, with the inertia as constants (its 84-
  // parameter form is checked in tests/models/robot_blocks_test.cc).
  const BlockOptions kuka_test_options{{{"inertial_parameters", {0.0}}}, {}};
  registry.Register(kKukaKr300Block, [](const BlockOptions& o) -> std::unique_ptr<Block> {
    CheckOptionKeys(
        kKukaKr300Block, o,
        {"payload", "inertial_parameters", "joint_torque_inputs", "outputs", "inertia_reference"});
    KukaBlockOptions options = ParseKuka(kKukaKr300Block, o);
    options.outputs = ParseOutputs(kKukaKr300Block, o);
    return std::make_unique<RobotDynamicsBlock>(KukaConfig(options, Form::kStateSpace));
  });
  BlockOptions kuka_acceleration_test_options = kuka_test_options;
  kuka_acceleration_test_options.words["parts"] = "accelerations";
  kuka_acceleration_test_options.numbers["feature_outputs"] = {1.0};
  registry.Register(
      kKukaKr300AccelerationBlock,
      [](const BlockOptions& o) -> std::unique_ptr<Block> {
        CheckOptionKeys(kKukaKr300AccelerationBlock, o,
                        {"payload", "inertial_parameters", "joint_torque_inputs", "parts",
                         "feature_outputs", "inertia_reference"});
        KukaBlockOptions options = ParseKuka(kKukaKr300AccelerationBlock, o);
        options.feature_outputs = Flag(kKukaKr300AccelerationBlock, o, "feature_outputs", false);
        const std::string parts = Word(kKukaKr300AccelerationBlock, o, "parts", "none",
                                       {"none", "torques", "accelerations"});
        options.parts = parts == "none"      ? DynamicsParts::kNone
                        : parts == "torques" ? DynamicsParts::kTorques
                                             : DynamicsParts::kAccelerations;
        return std::make_unique<RobotDynamicsBlock>(KukaConfig(options, Form::kAcceleration));
      },
      kuka_acceleration_test_options);
}

}  // namespace internal

}  // namespace graybox::models
