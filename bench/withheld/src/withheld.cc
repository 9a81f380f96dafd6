#include "graybox/bench/withheld.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <stdexcept>

#include "bases.h"
#include "excitation.h"
#include "graybox/estimators/analysis/metrics.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/util/did_you_mean.h"

namespace graybox::bench {
namespace {

namespace est = graybox::estimators;
using internal::BaseBuild;
using internal::Rng;

const std::vector<std::string> kBases = {"drive_closed_loop", "sea", "pendulum", "pneumatic"};

// Truth integration: CVODES, BDF with tight tolerances.
constexpr double kTruthRelTol = 1e-9;
constexpr double kTruthAbsTol = 1e-11;
// A delayed truth is simulated on a grid this many times finer than the sample time (the delays
// are whole multiples of the fine step).
constexpr int kFineFactor = 10;
// Start values of the nominal free parameters: the truth times a factor in [1 - x, 1 + x].
constexpr double kStartPerturbation = 0.25;

struct CaseSpec {
  std::string base;
  std::string label;
  std::vector<std::string> withheld;
  bool fast = false;
};

std::string ShortBase(const std::string& base) {
  if (base == "drive_closed_loop") return "drive_cl";
  return base;
}

std::string CaseName(const CaseSpec& s) { return ShortBase(s.base) + "/" + s.label + "/s1"; }

const std::vector<CaseSpec>& Catalog() {
  static const std::vector<CaseSpec> kCatalog = [] {
    std::vector<CaseSpec> c;
    const std::string d = "drive_closed_loop";
    c.push_back({d, "coulomb_atan", {"coulomb"}, true});
    c.push_back({d, "asymmetric_levels", {"asymmetric_friction"}});
    c.push_back({d, "stribeck_exp1.4", {"stribeck"}, true});
    c.push_back({d, "viscous", {"viscous"}});
    c.push_back({d, "power_law_k0.4", {"power_law_viscous"}});
    c.push_back({d, "ripple_2harmonics", {"ripple"}});
    c.push_back({d, "deadzone_hard", {"deadzone"}});
    c.push_back({d, "elasticity_two_mass", {"elasticity"}});
    c.push_back({d, "payload_35kg", {"payload"}});
    c.push_back({d, "friction_drift", {"friction_drift"}});
    c.push_back({d, "periodic_disturbance_3.7Hz", {"periodic_disturbance"}, true});
    c.push_back({d, "stribeck+ripple", {"stribeck", "ripple"}});
    c.push_back({d, "payload+asymmetric_friction", {"payload", "asymmetric_friction"}});
    const std::string s = "sea";
    c.push_back({s, "coulomb_atan", {"coulomb"}});
    c.push_back({s, "asymmetric_levels", {"asymmetric_friction"}});
    c.push_back({s, "stribeck_exp1.4", {"stribeck"}});
    c.push_back({s, "viscous", {"viscous"}});
    c.push_back({s, "power_law_k1.6", {"power_law_viscous"}});
    c.push_back({s, "presliding_lugre", {"presliding"}});
    c.push_back({s, "backlash_hard", {"backlash"}, true});
    c.push_back({s, "deadzone_hard", {"deadzone"}});
    c.push_back({s, "input_delay_5ms", {"input_delay"}, true});
    c.push_back({s, "ripple_2harmonics", {"ripple"}});
    c.push_back({s, "rotor_inertia", {"rotor_inertia"}});
    c.push_back({s, "payload_inertia", {"payload"}});
    c.push_back({s, "sensor_scale_1.06", {"sensor_scale"}});
    c.push_back({s, "friction_drift", {"friction_drift"}});
    c.push_back({s, "periodic_disturbance_6.3Hz", {"periodic_disturbance"}});
    c.push_back({s, "backlash+coulomb", {"backlash", "coulomb"}});
    c.push_back({s, "input_delay+viscous", {"input_delay", "viscous"}});
    const std::string p = "pendulum";
    c.push_back({p, "coulomb_atan", {"coulomb"}});
    c.push_back({p, "asymmetric_levels", {"asymmetric_friction"}});
    c.push_back({p, "stribeck_exp1.4", {"stribeck"}});
    c.push_back({p, "viscous", {"viscous"}});
    c.push_back({p, "power_law_k0.5", {"power_law_viscous"}});
    c.push_back({p, "presliding_lugre", {"presliding"}});
    c.push_back({p, "deadzone_hard", {"deadzone"}});
    c.push_back({p, "input_delay_17.5ms", {"input_delay"}});
    c.push_back({p, "payload_0.5kg", {"payload"}, true});
    c.push_back({p, "rotor_inertia", {"rotor_inertia"}});
    c.push_back({p, "sensor_offset_0.06rad", {"sensor_offset"}});
    c.push_back({p, "sensor_scale_1.05", {"sensor_scale"}});
    c.push_back({p, "ripple_2harmonics", {"ripple"}});
    c.push_back({p, "friction_drift", {"friction_drift"}, true});
    c.push_back({p, "periodic_disturbance_2.7Hz", {"periodic_disturbance"}});
    c.push_back({p, "payload+coulomb", {"payload", "coulomb"}});
    c.push_back({p, "sensor_offset+stribeck", {"sensor_offset", "stribeck"}, true});
    const std::string a = "pneumatic";
    c.push_back({a, "leakage_orifice", {"leakage"}});
    c.push_back({a, "heat_transfer", {"polytropic_index"}});
    c.push_back({a, "coulomb_atan", {"coulomb"}});
    c.push_back({a, "viscous", {"viscous"}});
    c.push_back({a, "friction_drift", {"friction_drift"}});
    c.push_back({a, "leakage+coulomb", {"leakage", "coulomb"}});
    return c;
  }();
  return kCatalog;
}

bool Selected(const CaseSpec& s, const WithheldOptions& o) {
  if (o.fast_subset && !s.fast) return false;
  return o.bases.empty() || std::find(o.bases.begin(), o.bases.end(), s.base) != o.bases.end();
}

// x0 of `model` from the truth's initial states by name (0 elsewhere).
Eigen::VectorXd InitialState(const models::StateSpaceModel& model,
                             const std::map<std::string, double>& values) {
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(model.NumStates());
  for (int i = 0; i < model.NumStates(); ++i) {
    const auto it = values.find(model.states[i].name);
    if (it != values.end()) x0(i) = it->second;
  }
  return x0;
}

est::Experiment MakeExperiment(const models::StateSpaceModel& model, double dt,
                               const Eigen::MatrixXd& u, const Eigen::MatrixXd& y) {
  est::Experiment e;
  e.dt = dt;
  e.u = u;
  e.y = y;
  for (const models::SignalInfo& s : model.inputs) {
    e.u_names.push_back(s.name);
    e.u_units.push_back(s.unit);
  }
  for (const models::SignalInfo& s : model.outputs) {
    e.y_names.push_back(s.name);
    e.y_units.push_back(s.unit);
  }
  return e;
}

WithheldCase Generate(const CaseSpec& spec, unsigned seed) {
  const auto start = std::chrono::steady_clock::now();
  WithheldCase c;
  c.name = CaseName(spec);
  c.base = spec.base;
  c.withheld = spec.withheld;
  for (const std::string& e : spec.withheld) {
    const auto& lib = LibraryEffectNames();
    c.in_library = c.in_library && std::find(lib.begin(), lib.end(), e) != lib.end();
  }
  BaseBuild b = internal::BuildBase(spec.base, spec.withheld);
  c.truth_detail = b.detail;
  c.truth_parameters = b.truth_values;
  Rng rng(internal::CaseSeed(c.name, seed));

  // The nominal problem, free parameters started away from the truth.
  for (const models::ModelParameter& p :
       std::vector<models::ModelParameter>(b.nominal.parameters())) {
    if (!p.free) continue;
    const double factor = 1.0 + rng.Uniform(-kStartPerturbation, kStartPerturbation);
    double v = p.value * factor;
    if (p.value == 0.0) v = 0.1 * p.scale * factor;
    b.nominal.Parameter(p.name).value = std::clamp(v, p.lower, p.upper);
  }
  c.nominal = est::MakeProblem(b.nominal.name(), b.nominal, b.spec);
  est::EstimationSpec truth_spec = b.spec;
  truth_spec.integrator.method = est::IntegrationMethod::kCvodes;
  truth_spec.integrator.cvodes.relative_tolerance = kTruthRelTol;
  truth_spec.integrator.cvodes.absolute_tolerance = kTruthAbsTol;
  truth_spec.integrator.cvodes.max_steps = 50000;
  c.truth = est::MakeProblem(b.truth.name(), b.truth, truth_spec);
  const models::StateSpaceModel& truth = c.truth.built;
  const models::StateSpaceModel& nominal = c.nominal.built;
  if (truth.NumOutputs() != nominal.NumOutputs() || truth.NumInputs() != nominal.NumInputs()) {
    throw std::logic_error("withheld case '" + c.name + "': truth and nominal differ in size");
  }
  // Without a delay the truth runs at the sample time; with one, on the fine grid, where the
  // held command shifted by the delay is exact (zero before the record, where the faded-in
  // excitation is zero too).
  const int fine = b.delay_seconds > 0.0 ? kFineFactor : 1;
  const double dt_fine = b.dt / fine;
  const int delay = static_cast<int>(std::lround(b.delay_seconds / dt_fine));
  if (std::fabs(delay * dt_fine - b.delay_seconds) > 1e-9 * b.dt) {
    throw std::logic_error("withheld case '" + c.name + "': the delay is not a whole fine step");
  }
  const std::unique_ptr<est::Integrator> integrator =
      est::MakeIntegrator(truth, dt_fine, truth_spec.integrator);
  const Eigen::VectorXd p_truth = truth.ParameterValues();
  const Eigen::VectorXd x0_truth = InitialState(truth, b.x0);
  const Eigen::VectorXd x0_nominal = InitialState(nominal, b.x0);

  for (const bool validation : {false, true}) {
    const Eigen::MatrixXd u = b.excite(validation, b.dt, b.samples, &rng);
    const int n = static_cast<int>(u.rows());
    Eigen::MatrixXd u_truth = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n) * fine, u.cols());
    for (int k = 0; k + delay < u_truth.rows(); ++k) u_truth.row(k + delay) = u.row(k / fine);
    const est::Trajectory traj = integrator->Simulate(x0_truth, u_truth, p_truth);
    if (!traj.ok) {
      throw std::runtime_error("withheld case '" + c.name +
                               "': the truth simulation failed: " + traj.summary.BriefReport());
    }
    Eigen::MatrixXd clean(n, traj.y.cols());
    for (int k = 0; k < n; ++k) clean.row(k) = traj.y.row(static_cast<Eigen::Index>(k) * fine);
    Eigen::MatrixXd y = clean;
    for (int j = 0; j < y.cols(); ++j) {
      for (int k = 0; k < y.rows(); ++k) {
        double v = clean(k, j) + b.noise_std[j] * rng.Normal();
        if (b.quantum[j] > 0.0) v = b.quantum[j] * std::round(v / b.quantum[j]);
        y(k, j) = v;
      }
    }
    const std::string name = validation ? "validation" : "estimation";
    const est::SplitRole role =
        validation ? est::SplitRole::kValidation : est::SplitRole::kEstimation;
    c.splits.push_back(est::MakeSplit(name, role, MakeExperiment(nominal, b.dt, u, y), x0_nominal));
    c.truth_splits.push_back(
        est::MakeSplit(name, role, MakeExperiment(truth, dt_fine, u_truth, traj.y), x0_truth));
    if (validation) c.oracle_validation_nrmse = est::ComputeMetrics(y, clean).overall.nrmse;
  }
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return c;
}

}  // namespace

const std::vector<std::string>& LibraryEffectNames() {
  static const std::vector<std::string> kNames = {"coulomb",           "asymmetric_friction",
                                                  "stribeck",          "viscous",
                                                  "power_law_viscous", "presliding",
                                                  "backlash",          "deadzone",
                                                  "elasticity",        "ripple",
                                                  "input_delay",       "payload",
                                                  "rotor_inertia",     "sensor_offset",
                                                  "sensor_scale",      "leakage",
                                                  "polytropic_index"};
  return kNames;
}

void WithheldOptions::Validate() const {
  for (const std::string& b : bases) {
    if (std::find(kBases.begin(), kBases.end(), b) == kBases.end()) {
      throw std::invalid_argument(
          "WithheldOptions.bases: expected one of drive_closed_loop, sea, "
          "pendulum, pneumatic, got '" +
          b + "'" + util::DidYouMeanHint(b, kBases));
    }
  }
}

std::vector<std::string> WithheldCaseNames(const WithheldOptions& options) {
  options.Validate();
  std::vector<std::string> names;
  for (const CaseSpec& s : Catalog()) {
    if (Selected(s, options)) names.push_back(CaseName(s));
  }
  return names;
}

std::vector<WithheldCase> MakeWithheldCases(const WithheldOptions& options) {
  options.Validate();
  std::vector<WithheldCase> cases;
  for (const CaseSpec& s : Catalog()) {
    if (Selected(s, options)) cases.push_back(Generate(s, options.seed));
  }
  return cases;
}

WithheldCase MakeWithheldCase(const std::string& name, unsigned seed) {
  std::vector<std::string> names;
  for (const CaseSpec& s : Catalog()) {
    if (CaseName(s) == name) return Generate(s, seed);
    names.push_back(CaseName(s));
  }
  throw std::invalid_argument("MakeWithheldCase: unknown case '" + name + "'" +
                              util::DidYouMeanHint(name, names));
}

}  // namespace graybox::bench
