// Integrators at EQUAL ACCURACY: the fixed-step Runge-Kutta schemes of estimators/integrators.h
// (explicit RK4, implicit backward Euler and 2-stage Radau IIA) against CVODES BDF, on the
// pneumatic arm of seed 004 (stiff in stretches) and on Robertson's kinetics (stiff throughout).
//
// Sampled simulation (integrators.h): x_{k+1} = Phi(x_k, u_k, p), u_k held over [t_k, t_k + dt).
// A fixed-step Phi is n substeps of size h = dt / n of a scheme whose stability function R(z),
// z = h lambda, is what one step applies to x' = lambda x:
//   rk4             order 4, explicit, R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24: stable only for
//                   h |lambda| <= 2.785 on the negative real axis, whatever the accuracy asked;
//   backward_euler  order 1, L-stable, R(z) = 1 / (1 - z);
//   radau_iia       order 3, L-stable, R(z) = (1 + z/3) / (1 - 2z/3 + z^2/6).
// The implicit stage equations are solved by a fixed number of simplified-Newton iterations with
// the Jacobian frozen at the step's start (default 4; for Radau IIA 1, 2 and 4 are tried and the
// fastest one that reaches the accuracy is kept).
//
// Accuracy measure of a trajectory x (N x nx) against a reference x_ref:
//     e(x) = max_i  max_k |x_k,i - x_ref_k,i| / max_k |x_ref_k,i|
// (each state's worst error relative to that state's largest value, worst state). For the
// sensitivities S_k = d x_k / d theta, theta = (all parameters, x0), the same measure on the
// stacked S_k, column by column.
//
// Method, per problem and working tolerance rtol in {1e-6, 1e-8}:
//   1. reference: CVODES at rtol 1e-12 (absolute tolerances rtol x each state's typical size), with
//      its sensitivities where sensitivities are compared;
//   2. CVODES BDF (dense LU, analytic df/dx from libexpr) at rtol: its errors e_C and s_C (CVODES
//      with sensitivities: staggered corrector, error control on the sensitivities);
//   3. per fixed-step scheme, the smallest n with e <= e_C (with sensitivities: e <= e_C of the
//      plain CVODES run and s <= s_C; the forward recursion through the sparse Jacobians of the
//      step map), by doubling n from 1 and then bisecting (the error is not quite monotone in n
//      on the arm's non-smooth right-hand side, nor near RK4's stability limit); the bisection
//      stops within 1 % above 200 substeps, and the search gives up ("> cap") where a simulation
//      would take more than 1e7 steps (1e6 with sensitivities): 1e5 substeps on Robertson;
//   4. each integrator at its n timed by Google Benchmark (CPU time per simulation); a table of
//      the medians follows the benchmark output. The calibration (steps 1-3) takes minutes:
//      backward Euler needs ~1e4 substeps per sample on the arm.
//
// Problems:
//   pneumatic arm ("pneumatic.arm", models/pneumatics.h: joint angle, speed, two chamber
//   pressures; |lambda| up to ~600 /s where a chamber sits at supply or exhaust pressure with its
//   valve open), 3 s, arm hanging at rest with 300 kPa in both chambers, with sensitivities
//   (27 parameters + 4 initial states):
//     staircase_10ms  valve-1 command a new uniform level in [0, 10] V every 0.25 s (valve 2 gets
//                     10 V minus it), sampled at 100 Hz: CVODES restarts 11 times;
//     staircase_20ms  the same at 50 Hz, where RK4 at the sample time is far off;
//     sine_10ms       smooth commands 5 + 1.5 sin(pi t) + 0.5 sin(4.6 pi t) V at 100 Hz: the input
//                     changes at every sample, so CVODES restarts at every sample.
//   robertson: Robertson's chemical kinetics (Hairer & Wanner II, sec. IV.1), eigenvalues down to
//     ~-1e4 /s, sampled every 0.4 s from t = 0.01 s (after the initial layer, integrated by
//     CVODES from (1, 0, 0)) to 40.01 s, states only: RK4 needs h |lambda| <= 2.785, i.e.
//     hundreds of substeps per sample, while h |lambda| ~ 4e3 is nothing for an L-stable scheme.
//
// Counters: error, sens_error (as above), steps (internal steps per simulation), samples. The
// substeps (and Newton iterations) are in the benchmark's name.
//
// Run: build/bench/integrators_bench --benchmark_min_time=0.2 --benchmark_repetitions=5
//        --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "graybox/estimators/integrators/cvodes_integrator.h"
#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/models/model.h"

namespace {

namespace est = graybox::estimators;
namespace models = graybox::models;

constexpr unsigned kSeed = 7;
constexpr double kReferenceRtol = 1e-12;
constexpr double kWorkingRtols[] = {1e-6, 1e-8};
// Of the Newton iteration counts tried for an implicit scheme, the fastest that reaches the
// accuracy is kept, by the smallest CPU time of kChoiceRuns runs.
constexpr int kChoiceRuns = 3;

// ---- problems ---------------------------------------------------------------------------------

// A simulation to compare the integrators on.
struct Problem {
  std::string name;
  models::StateSpaceModel model;
  double dt;              // sample time [s]
  Eigen::MatrixXd u;      // N x nu, row k = u_k
  Eigen::VectorXd x0, p;  // initial state, parameters
  // Typical size of each state: CVODES's absolute tolerances are rtol times these.
  Eigen::VectorXd state_scale;
  // Also compare simulations with sensitivities to all parameters and x0.
  bool sensitivities;
};

est::CvodesOptions CvodesTolerances(const Problem& problem, double rtol) {
  est::CvodesOptions o;
  o.relative_tolerance = rtol;
  o.absolute_tolerances = rtol * problem.state_scale;
  return o;
}

constexpr double kArmDuration = 3.0;    // s
constexpr double kArmStairHold = 0.25;  // s between two levels of the staircase
constexpr double kArmValveMax = 10.0;   // V
const Eigen::Vector4d kArmX0(M_PI / 2.0, 0.0, 300.0, 300.0);  // hanging at rest, 300 kPa
// q [rad], qd [rad/s], p1, p2 [kPa].
const Eigen::Vector4d kArmStateScale(1.0, 10.0, 300.0, 300.0);

std::vector<Problem> ArmProblems() {
  models::Model m("pneumatic_arm");
  m.AddInput("u1", "V", "valve 1 command", 0.0, kArmValveMax);
  m.AddInput("u2", "V", "valve 2 command", 0.0, kArmValveMax);
  m.AddBlock("arm", "pneumatic.arm", {}, {"u1", "u2"}, {"torque"});
  m.AddOutput("arm.q");
  m.AddOutput("torque");
  const models::StateSpaceModel model = m.Build();
  auto problem = [&](const std::string& name, double dt, const Eigen::MatrixXd& u) {
    return Problem{name, model, dt, u, kArmX0, model.ParameterValues(), kArmStateScale, true};
  };
  std::vector<Problem> out;
  for (double dt : {0.01, 0.02}) {
    const int n = static_cast<int>(std::lround(kArmDuration / dt)) + 1;
    const int hold = static_cast<int>(std::lround(kArmStairHold / dt));
    std::mt19937 rng(kSeed);
    std::uniform_real_distribution<double> level(0.0, kArmValveMax);
    Eigen::MatrixXd u(n, 2);
    double v = kArmValveMax / 2.0;
    for (int k = 0; k < n; ++k) {
      if (k % hold == 0) v = level(rng);
      u(k, 0) = v;
      u(k, 1) = kArmValveMax - v;
    }
    out.push_back(problem(dt == 0.01 ? "staircase_10ms" : "staircase_20ms", dt, u));
  }
  const double dt = 0.01;
  const int n = static_cast<int>(std::lround(kArmDuration / dt)) + 1;
  Eigen::MatrixXd u(n, 2);
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    u(k, 0) = 5.0 + 1.5 * std::sin(2.0 * M_PI * 0.5 * t) + 0.5 * std::sin(2.0 * M_PI * 2.3 * t);
    u(k, 1) = kArmValveMax - u(k, 0);
  }
  out.push_back(problem("sine_10ms", dt, u));
  return out;
}

// Robertson's chemical kinetics (Robertson 1966; Hairer & Wanner, Solving ODEs II, sec. IV.1):
//   y1' = -k1 y1 + k3 y2 y3,  y2' = k1 y1 - k3 y2 y3 - k2 y2^2,  y3' = k2 y2^2,
// k1 = 0.04, k2 = 3e7, k3 = 1e4: eigenvalues down to ~-1e4 /s once y2 has risen (within 1e-3 s).
class Robertson : public models::BlockBase<Robertson> {
 public:
  Robertson() {
    info_.type = "bench.robertson";
    info_.description = "Robertson's stiff chemical kinetics";
    info_.reference = "Robertson 1966";
    info_.states = {{"y1", "1", "concentration 1", 0, 1},
                    {"y2", "1", "concentration 2", 0, 4e-5},
                    {"y3", "1", "concentration 3", 0, 1}};
    info_.parameters = {{"k1", "1/s", "rate 1", 0.04, 0.0, 1.0},
                        {"k2", "1/s", "rate 2", 3e7, 0.0, 1e9},
                        {"k3", "1/s", "rate 3", 1e4, 0.0, 1e6}};
    info_.stiff = true;
  }
  template <typename S>
  void Compute(const models::BlockArgs<S>& a) const {
    const S& y1 = a.x[0];
    const S& y2 = a.x[1];
    const S& y3 = a.x[2];
    a.xdot[0] = -a.p[0] * y1 + a.p[2] * y2 * y3;
    a.xdot[1] = a.p[0] * y1 - a.p[2] * y2 * y3 - a.p[1] * y2 * y2;
    a.xdot[2] = a.p[1] * y2 * y2;
  }
};

constexpr double kRobertsonStart = 0.01;  // s, past the initial layer
constexpr double kRobertsonDt = 0.4;      // s
constexpr int kRobertsonSamples = 101;    // t = 0.01 ... 40.01 s
// Typical sizes of the species (y2 stays below 4e-5).
const Eigen::Vector3d kRobertsonStateScale(1e-2, 1e-7, 1e-2);

Problem RobertsonProblem() {
  models::Model m("robertson");
  m.AddBlock("rob", std::make_shared<Robertson>(), {}, {});
  m.AddOutput("rob.y1");
  m.AddOutput("rob.y3");
  Problem problem{"robertson",
                  m.Build(),
                  kRobertsonDt,
                  Eigen::MatrixXd(kRobertsonSamples, 0),
                  Eigen::Vector3d(1.0, 0.0, 0.0),
                  Eigen::VectorXd(),
                  kRobertsonStateScale,
                  false};
  problem.p = problem.model.ParameterValues();
  // The initial layer (y2 rises from 0 to 3.6e-5 within ~1e-3 s) is CVODES's job: there the
  // Jacobian frozen at a step's start is no model of the step and the Newton iterations of the
  // fixed-step implicit schemes diverge (integrators.h).
  const est::Trajectory layer =
      est::SimulateCvodes(problem.model, problem.x0, Eigen::MatrixXd(2, 0), problem.p,
                          kRobertsonStart, CvodesTolerances(problem, kReferenceRtol));
  if (!layer.ok) throw std::runtime_error("robertson layer: " + layer.summary.BriefReport());
  problem.x0 = layer.x.row(1).transpose();
  return problem;
}

// ---- accuracy ---------------------------------------------------------------------------------

// e(a) against b, see the file comment; infinite when a is not finite.
double ScaledError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (!a.allFinite()) return INFINITY;
  double worst = 0.0;
  for (Eigen::Index j = 0; j < b.cols(); ++j) {
    const double scale = std::max(b.col(j).cwiseAbs().maxCoeff(), 1e-300);
    worst = std::max(worst, (a.col(j) - b.col(j)).cwiseAbs().maxCoeff() / scale);
  }
  return worst;
}

// The per-sample sensitivities [d x_k / d p, d x_k / d x0] stacked over k.
Eigen::MatrixXd Stack(const est::SensitivityTrajectory& t) {
  const Eigen::Index nx = t.x.cols(), np = t.dx_dp.at(0).cols();
  Eigen::MatrixXd out(static_cast<Eigen::Index>(t.dx_dp.size()) * nx, np + nx);
  for (std::size_t k = 0; k < t.dx_dp.size(); ++k) {
    out.block(static_cast<Eigen::Index>(k) * nx, 0, nx, np) = t.dx_dp[k];
    out.block(static_cast<Eigen::Index>(k) * nx, np, nx, nx) = t.dx_dx0[k];
  }
  return out;
}

struct Reference {
  Eigen::MatrixXd x;
  Eigen::MatrixXd sensitivities;  // stacked; empty unless the problem compares sensitivities
};

Reference MakeReference(const Problem& problem) {
  const est::CvodesIntegrator cvodes(problem.model, problem.dt,
                                     CvodesTolerances(problem, kReferenceRtol));
  Reference r;
  if (problem.sensitivities) {
    const est::SensitivityTrajectory t =
        cvodes.SimulateWithSensitivities(problem.x0, problem.u, problem.p);
    if (!t.ok) throw std::runtime_error("reference: " + t.summary.BriefReport());
    r.x = t.x;
    r.sensitivities = Stack(t);
  } else {
    const est::Trajectory t = cvodes.Simulate(problem.x0, problem.u, problem.p);
    if (!t.ok) throw std::runtime_error("reference: " + t.summary.BriefReport());
    r.x = t.x;
  }
  return r;
}

// What one run achieved. A plain simulation has no sensitivity error (0); a failed run has
// infinite errors.
struct Accuracy {
  double error = INFINITY;
  double sens_error = INFINITY;
  long steps = 0;
  bool Meets(const Accuracy& target) const {
    return error <= target.error && sens_error <= target.sens_error;
  }
};

// One simulation (with sensitivities or not) of the problem, scored against the reference.
Accuracy Measure(const est::Integrator& integrator, const Problem& problem, const Reference& ref,
                 bool sensitivities) {
  Accuracy a;
  if (sensitivities) {
    const est::SensitivityTrajectory t =
        integrator.SimulateWithSensitivities(problem.x0, problem.u, problem.p);
    a.steps = t.summary.num_steps;
    if (t.ok) {
      a.error = ScaledError(t.x, ref.x);
      a.sens_error = ScaledError(Stack(t), ref.sensitivities);
    }
  } else {
    const est::Trajectory t = integrator.Simulate(problem.x0, problem.u, problem.p);
    a.steps = t.summary.num_steps;
    if (t.ok) {
      a.error = ScaledError(t.x, ref.x);
      a.sens_error = 0.0;
    }
  }
  return a;
}

// Smallest CPU time [s] of `runs` simulations.
double MinCpuSeconds(const est::Integrator& integrator, const Problem& problem, bool sensitivities,
                     int runs) {
  double best = INFINITY;
  for (int r = 0; r < runs; ++r) {
    const std::clock_t start = std::clock();
    if (sensitivities) {
      benchmark::DoNotOptimize(
          integrator.SimulateWithSensitivities(problem.x0, problem.u, problem.p).x.data());
    } else {
      benchmark::DoNotOptimize(integrator.Simulate(problem.x0, problem.u, problem.p).x.data());
    }
    best = std::min(best, static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC);
  }
  return best;
}

// ---- the substep search -----------------------------------------------------------------------

// The search gives up (reported as "> cap") where a simulation would take more steps than these:
// 1e5 substeps on Robertson's 100 intervals, 33333 on the arm's 300.
constexpr long kMaxSteps = 10000000;
constexpr long kMaxSensitivitySteps = 1000000;  // 31 sensitivities cost ~10 x the states per step
// The bisection stops at hi - lo <= max(1, hi / kBisectionResolution): exact up to 200 substeps,
// within 1 % above (backward Euler needs 1e4 substeps on the arm, seconds per trial).
constexpr int kBisectionResolution = 100;

int SubstepCap(const Problem& problem, bool sensitivities) {
  const long intervals = std::max<long>(1, problem.u.rows() - 1);
  return static_cast<int>((sensitivities ? kMaxSensitivitySteps : kMaxSteps) / intervals);
}

// Builds the integrator of one scheme with n substeps per sample.
using IntegratorFactory = std::function<std::shared_ptr<const est::Integrator>(int substeps)>;

IntegratorFactory FixedStepFactory(const Problem& problem, est::StepScheme scheme,
                                   int newton_iterations) {
  return [&problem, scheme, newton_iterations](int substeps) {
    est::IntegratorOptions o;
    o.method = est::IntegrationMethod::kFixedStep;
    o.fixed_step.scheme = scheme;
    o.fixed_step.substeps = substeps;
    o.fixed_step.newton_iterations = newton_iterations;
    return std::shared_ptr<const est::Integrator>(
        est::MakeIntegrator(problem.model, problem.dt, o));
  };
}

// The accuracy of one integrator family and kind of run per number of substeps, each run once and
// shared by the searches at every working tolerance.
class Trials {
 public:
  Trials(IntegratorFactory make, const Problem& problem, const Reference& ref, bool sensitivities)
      : make_(std::move(make)), problem_(problem), ref_(ref), sensitivities_(sensitivities) {}
  const Accuracy& operator()(int n) {
    auto it = runs_.find(n);
    if (it == runs_.end()) {
      it = runs_.emplace(n, Measure(*make_(n), problem_, ref_, sensitivities_)).first;
    }
    return it->second;
  }
  // The integrator with n substeps, ready to be timed: a first run with sensitivities builds
  // their Functions, which the timings should not include.
  std::shared_ptr<const est::Integrator> Build(int n) const {
    std::shared_ptr<const est::Integrator> integrator = make_(n);
    if (sensitivities_) Measure(*integrator, problem_, ref_, true);
    return integrator;
  }
  bool sensitivities() const { return sensitivities_; }

 private:
  IntegratorFactory make_;
  const Problem& problem_;
  const Reference& ref_;
  bool sensitivities_;
  std::map<int, Accuracy> runs_;
};

// The outcome of a search: the smallest substeps reaching the target, or none up to the cap.
struct Calibration {
  int substeps = 0;  // 0: none up to `cap`
  int cap = 0;
  int newton_iterations = 0;
  Accuracy accuracy;  // at `substeps` (at the cap when none reached the target)
  std::shared_ptr<const est::Integrator> integrator;  // null when none reached the target
  double cpu_seconds = INFINITY;                      // of one run, smallest of kChoiceRuns
  std::string trials;                                 // " n:error[/sens_error]" per trial
  bool found() const { return substeps > 0; }
};

// The smallest n in [lower_bound, cap] whose run meets the target: doubling from 1 (values below
// lower_bound count as misses without running), then bisection to kBisectionResolution. Assumes
// the error decreases with n.
Calibration SmallestSubsteps(Trials& trials, const Accuracy& target, int lower_bound, int cap) {
  Calibration c;
  c.cap = cap;
  if (lower_bound > cap) return c;
  auto ok = [&](int n) {
    if (n < lower_bound) return false;
    const Accuracy& a = trials(n);
    char line[64];
    std::snprintf(line, sizeof(line), " %d:%.1e", n, a.error);
    c.trials += line;
    if (trials.sensitivities()) {
      std::snprintf(line, sizeof(line), "/%.1e", a.sens_error);
      c.trials += line;
    }
    return a.Meets(target);
  };
  int lo = 0, hi = 1;
  while (!ok(hi)) {
    if (hi == cap) {
      c.accuracy = trials(cap);
      return c;
    }
    lo = hi;
    hi = std::min(2 * hi, cap);
  }
  while (hi - lo > std::max(1, hi / kBisectionResolution)) {
    const int mid = (lo + hi) / 2;
    (ok(mid) ? hi : lo) = mid;
  }
  c.substeps = hi;
  c.accuracy = trials(hi);
  c.integrator = trials.Build(hi);
  return c;
}

// A fixed-step scheme and the Newton iteration counts to try.
struct Scheme {
  const char* label;  // in the benchmark names
  const char* title;  // in the tables
  est::StepScheme scheme;
  std::vector<int> newton_iterations;
};

const std::vector<Scheme>& Schemes() {
  static const int kDefaultNewton = est::FixedStepOptions().newton_iterations;
  static const std::vector<Scheme> schemes = {
      {"Rk4", "RK4", est::StepScheme::kRk4, {kDefaultNewton}},
      {"BackwardEuler", "BE", est::StepScheme::kBackwardEuler, {kDefaultNewton}},
      {"RadauIIA", "Radau", est::StepScheme::kRadauIIA, {1, 2, kDefaultNewton}},
  };
  return schemes;
}

bool IsImplicit(est::StepScheme scheme) { return scheme != est::StepScheme::kRk4; }

// What a scheme must reach at one working tolerance: CVODES's state error, and for the runs with
// sensitivities CVODES's state error (of the plain simulation) and its sensitivity error.
struct Targets {
  Accuracy simulate, sensitivities;
};

struct SchemeResult {
  Calibration simulate, sensitivities;
};

// The fastest of the calibrations that reached the target; the last one when none did.
Calibration Fastest(const std::vector<Calibration>& candidates) {
  const Calibration* best = &candidates.back();
  for (const Calibration& c : candidates) {
    if (c.found() && (!best->found() || c.cpu_seconds < best->cpu_seconds)) best = &c;
  }
  return *best;
}

void PrintCalibration(const Scheme& scheme, double rtol, bool sensitivities, const Calibration& c) {
  char result[64];
  if (c.found() && std::isfinite(c.cpu_seconds)) {
    std::snprintf(result, sizeof(result), "n = %d (%.4g ms)", c.substeps, 1e3 * c.cpu_seconds);
  } else if (c.found()) {
    std::snprintf(result, sizeof(result), "n = %d", c.substeps);
  } else {
    std::snprintf(result, sizeof(result), "n > %d", c.cap);
  }
  std::printf("  rtol %.0e %-13s %-13s", rtol, scheme.label,
              sensitivities ? "sensitivities" : "simulate");
  if (IsImplicit(scheme.scheme)) std::printf(" newton %d", c.newton_iterations);
  std::printf(": %s; trials n:error%s%s\n", result, sensitivities ? "/sens_error" : "",
              c.trials.c_str());
  std::fflush(stdout);
}

// Per Newton iteration count: the plain search, then the sensitivity search from its substeps
// (the states of a run with sensitivities are the plain run's, so fewer substeps cannot do);
// then, per working tolerance, the fastest iteration count of each kind (timed only when there is
// a choice).
std::vector<SchemeResult> Calibrate(const Scheme& scheme, const Problem& problem,
                                    const Reference& ref, const std::vector<double>& rtols,
                                    const std::vector<Targets>& targets) {
  std::vector<std::vector<Calibration>> simulate(targets.size()), sensitivities(targets.size());
  for (int newton : scheme.newton_iterations) {
    const IntegratorFactory make = FixedStepFactory(problem, scheme.scheme, newton);
    Trials plain(make, problem, ref, false), sens(make, problem, ref, true);
    auto finish = [&](Calibration& c, std::size_t t, bool with_sensitivities) {
      c.newton_iterations = newton;
      if (c.found() && scheme.newton_iterations.size() > 1) {
        c.cpu_seconds = MinCpuSeconds(*c.integrator, problem, with_sensitivities, kChoiceRuns);
      }
      PrintCalibration(scheme, rtols[t], with_sensitivities, c);
    };
    for (std::size_t t = 0; t < targets.size(); ++t) {
      Calibration c = SmallestSubsteps(plain, targets[t].simulate, 1, SubstepCap(problem, false));
      finish(c, t, false);
      simulate[t].push_back(c);
      if (!problem.sensitivities) continue;
      const int lower_bound = c.found() ? c.substeps : c.cap + 1;
      Calibration s =
          SmallestSubsteps(sens, targets[t].sensitivities, lower_bound, SubstepCap(problem, true));
      finish(s, t, true);
      sensitivities[t].push_back(s);
    }
  }
  std::vector<SchemeResult> out(targets.size());
  for (std::size_t t = 0; t < targets.size(); ++t) {
    out[t].simulate = Fastest(simulate[t]);
    if (problem.sensitivities) out[t].sensitivities = Fastest(sensitivities[t]);
  }
  return out;
}

// ---- benchmarks and the summary tables --------------------------------------------------------

// One problem at one working tolerance: CVODES and every scheme at its accuracy.
struct Case {
  const Problem* problem;
  double rtol;
  std::shared_ptr<const est::Integrator> cvodes;
  Accuracy cvodes_simulate, cvodes_sensitivities;  // of CVODES's own runs
  std::vector<SchemeResult> schemes;               // in Schemes() order
};

std::vector<Case> MakeCases(const Problem& problem, const Reference& ref) {
  const std::vector<double> rtols(std::begin(kWorkingRtols), std::end(kWorkingRtols));
  std::vector<Case> cases;
  std::vector<Targets> targets;
  for (double rtol : rtols) {
    Case c{&problem,
           rtol,
           std::make_shared<est::CvodesIntegrator>(problem.model, problem.dt,
                                                   CvodesTolerances(problem, rtol)),
           {},
           {},
           {}};
    c.cvodes_simulate = Measure(*c.cvodes, problem, ref, false);
    std::printf("%s rtol %.0e: cvodes error %.2e (%ld steps)", problem.name.c_str(), rtol,
                c.cvodes_simulate.error, c.cvodes_simulate.steps);
    Targets t{c.cvodes_simulate, {}};
    if (problem.sensitivities) {
      c.cvodes_sensitivities = Measure(*c.cvodes, problem, ref, true);
      t.sensitivities.error = c.cvodes_simulate.error;
      t.sensitivities.sens_error = c.cvodes_sensitivities.sens_error;
      std::printf("; with sensitivities error %.2e, sens_error %.2e (%ld steps)",
                  c.cvodes_sensitivities.error, c.cvodes_sensitivities.sens_error,
                  c.cvodes_sensitivities.steps);
    }
    std::printf("\n");
    cases.push_back(c);
    targets.push_back(t);
  }
  for (const Scheme& scheme : Schemes()) {
    const std::vector<SchemeResult> results = Calibrate(scheme, problem, ref, rtols, targets);
    for (std::size_t t = 0; t < cases.size(); ++t) cases[t].schemes.push_back(results[t]);
  }
  return cases;
}

// "BM_<label>_<Simulate|SimulateWithSensitivities>/<problem>/rtol<rtol>[/substeps<n>[/newton<k>]]"
std::string BenchmarkName(const char* label, bool sensitivities, const Case& c,
                          const Calibration* fixed_step, bool implicit) {
  char name[160];
  int len = std::snprintf(name, sizeof(name), "BM_%s_%s/%s/rtol%.0e", label,
                          sensitivities ? "SimulateWithSensitivities" : "Simulate",
                          c.problem->name.c_str(), c.rtol);
  if (fixed_step) {
    len += std::snprintf(name + len, sizeof(name) - len, "/substeps%d", fixed_step->substeps);
    if (implicit) {
      std::snprintf(name + len, sizeof(name) - len, "/newton%d", fixed_step->newton_iterations);
    }
  }
  return name;
}

void Time(benchmark::State& state, const est::Integrator& integrator, const Problem& problem,
          bool sensitivities, const Accuracy& accuracy) {
  long steps = 0;
  for (auto _ : state) {
    if (sensitivities) {
      const est::SensitivityTrajectory t =
          integrator.SimulateWithSensitivities(problem.x0, problem.u, problem.p);
      steps = t.summary.num_steps;
      if (!t.ok) state.SkipWithError(t.summary.BriefReport().c_str());
      benchmark::DoNotOptimize(t.x.data());
    } else {
      const est::Trajectory t = integrator.Simulate(problem.x0, problem.u, problem.p);
      steps = t.summary.num_steps;
      if (!t.ok) state.SkipWithError(t.summary.BriefReport().c_str());
      benchmark::DoNotOptimize(t.x.data());
    }
  }
  state.counters["error"] = accuracy.error;
  if (sensitivities) state.counters["sens_error"] = accuracy.sens_error;
  state.counters["steps"] = static_cast<double>(steps);
  state.counters["samples"] = static_cast<double>(problem.u.rows());
}

void Register(const std::string& name, const est::Integrator* integrator, const Problem* problem,
              bool sensitivities, const Accuracy* accuracy) {
  static const auto min = [](const std::vector<double>& v) {
    return *std::min_element(v.begin(), v.end());
  };
  benchmark::RegisterBenchmark(name.c_str(),
                               [=](benchmark::State& state) {
                                 Time(state, *integrator, *problem, sensitivities, *accuracy);
                               })
      ->Unit(benchmark::kMillisecond)
      ->ComputeStatistics("min", min);
}

void RegisterCase(const Case& c) {
  for (bool sens : {false, true}) {
    if (sens && !c.problem->sensitivities) continue;
    Register(BenchmarkName("Cvodes", sens, c, nullptr, false), c.cvodes.get(), c.problem, sens,
             sens ? &c.cvodes_sensitivities : &c.cvodes_simulate);
    for (std::size_t s = 0; s < Schemes().size(); ++s) {
      const Calibration& f = sens ? c.schemes[s].sensitivities : c.schemes[s].simulate;
      if (!f.found()) continue;
      Register(BenchmarkName(Schemes()[s].label, sens, c, &f, IsImplicit(Schemes()[s].scheme)),
               f.integrator.get(), c.problem, sens, &f.accuracy);
    }
  }
}

// The console output, recording the median CPU time [ms] of every benchmark (of the single run
// without repetitions) for the tables.
class MedianRecorder : public benchmark::ConsoleReporter {
 public:
  MedianRecorder() : ConsoleReporter(OO_None) {}
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      if (r.error_occurred) continue;
      const std::string name = r.run_name.str();
      if (r.run_type == Run::RT_Aggregate ? r.aggregate_name == "median" : !ms_.count(name)) {
        ms_[name] = r.GetAdjustedCPUTime();
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
  // NaN when the benchmark did not run (filtered out, failed).
  double Milliseconds(const std::string& name) const {
    const auto it = ms_.find(name);
    return it == ms_.end() ? NAN : it->second;
  }

 private:
  std::map<std::string, double> ms_;
};

// "0.123 ms", "12.3 ms", "4850 ms", or "-" when not measured.
std::string Milliseconds(double ms) {
  if (std::isnan(ms)) return "-";
  char s[32];
  std::snprintf(s, sizeof(s), ms < 100.0 ? "%.3g ms" : "%.0f ms", ms);
  return s;
}

// Markdown tables of the medians: one row per problem and tolerance, the CVODES columns, then
// substeps, error (sensitivity error for the sensitivity runs) and time of each scheme, and which
// integrator was fastest by how much over the next.
void PrintTable(const std::vector<Case>& cases, bool sensitivities, const MedianRecorder& times) {
  const char* error = sensitivities ? "sens. error" : "error";
  std::printf("\n%s:\n\n| problem | rtol | CVODES %s | CVODES steps | CVODES |",
              sensitivities ? "Simulation with sensitivities" : "Simulation", error);
  for (const Scheme& s : Schemes())
    std::printf(" %s n | %s %s | %s |", s.title, s.title, error, s.title);
  std::printf(" fastest (x the next) |\n|---|---|---:|---:|---:|");
  for (std::size_t s = 0; s < Schemes().size(); ++s) std::printf("---:|---:|---:|");
  std::printf("---|\n");
  for (const Case& c : cases) {
    if (sensitivities && !c.problem->sensitivities) continue;
    const Accuracy& cv = sensitivities ? c.cvodes_sensitivities : c.cvodes_simulate;
    std::vector<std::pair<double, std::string>> ranking;
    const double cv_ms =
        times.Milliseconds(BenchmarkName("Cvodes", sensitivities, c, nullptr, false));
    ranking.emplace_back(cv_ms, "CVODES");
    std::printf("| %s | %.0e | %.1e | %ld | %s |", c.problem->name.c_str(), c.rtol,
                sensitivities ? cv.sens_error : cv.error, cv.steps, Milliseconds(cv_ms).c_str());
    for (std::size_t s = 0; s < Schemes().size(); ++s) {
      const Scheme& scheme = Schemes()[s];
      const Calibration& f = sensitivities ? c.schemes[s].sensitivities : c.schemes[s].simulate;
      if (!f.found()) {
        std::printf(" > %d | - | - |", f.cap);
        continue;
      }
      const double ms = times.Milliseconds(
          BenchmarkName(scheme.label, sensitivities, c, &f, IsImplicit(scheme.scheme)));
      ranking.emplace_back(ms, scheme.title);
      std::string n = std::to_string(f.substeps);
      if (scheme.newton_iterations.size() > 1)
        n += " (" + std::to_string(f.newton_iterations) + " it.)";
      std::printf(" %s | %.1e | %s |", n.c_str(),
                  sensitivities ? f.accuracy.sens_error : f.accuracy.error,
                  Milliseconds(ms).c_str());
    }
    ranking.erase(std::remove_if(ranking.begin(), ranking.end(),
                                 [](const auto& r) { return std::isnan(r.first); }),
                  ranking.end());
    std::sort(ranking.begin(), ranking.end());
    if (ranking.size() >= 2) {
      std::printf(" %s %.2f |\n", ranking[0].second.c_str(), ranking[1].first / ranking[0].first);
    } else {
      std::printf(" - |\n");
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  try {
    static std::vector<Problem> problems = ArmProblems();
    problems.push_back(RobertsonProblem());
    static std::vector<Case> cases;
    for (const Problem& problem : problems) {
      const Reference ref = MakeReference(problem);
      for (Case& c : MakeCases(problem, ref)) cases.push_back(std::move(c));
    }
    for (const Case& c : cases) RegisterCase(c);
    MedianRecorder reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);
    PrintTable(cases, false, reporter);
    PrintTable(cases, true, reporter);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "integrators_bench: %s\n", e.what());
    return 1;
  }
  benchmark::Shutdown();
  return 0;
}
