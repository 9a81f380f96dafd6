// Integrators on the stiff pneumatic arm of seed 004 (models/pneumatics.h, "pneumatic.arm": joint
// angle, speed and two chamber pressures driven by two proportional valves), at EQUAL ACCURACY:
//
//   1. a reference trajectory from CVODES at rtol 1e-12;
//   2. CVODES BDF (dense) at a working tolerance rtol (1e-6, 1e-8), and its error
//        e = max_k,i |x_k,i - x_ref_k,i| / max_k |x_ref_k,i|      (relative to each state's range);
//   3. the smallest number of fixed RK4 substeps per sample whose error is <= e (doubling, then
//      bisection; RK4's error on this non-smooth model is not quite monotone in the substeps);
//   4. both timed for a simulation;
//   5. the same for a simulation with forward sensitivities with respect to all 27 parameters and
//      the 4 initial states (CVODES: staggered corrector with error control; RK4: forward
//      recursion through the sparse Jacobians of the step map), where equal accuracy means RK4
//      matches both CVODES's state error and its sensitivity error (the same measure on the
//      stacked d x_k / d theta columns against CVODES's rtol 1e-12 sensitivities). The arm's
//      right-hand side is only C1 (orifice branches and laminar band join with equal slope), so
//      RK4's sensitivities converge at second order while its states converge at fourth: RK4
//      needs many more substeps for equally accurate sensitivities.
// Scenarios (3 s of data each, arm hanging at rest with 300 kPa in both chambers):
//   staircase_10ms  valve-1 command a new uniform level in [0, 10] V every 0.25 s (valve 2 gets
//                   10 V minus it), sampled at 100 Hz: CVODES restarts 11 times;
//   staircase_20ms  the same at 50 Hz, where RK4 at the sample time is far off;
//   sine_10ms       smooth commands 5 + 1.5 sin(pi t) + 0.5 sin(4.6 pi t) V at 100 Hz: the input
//                   changes at every sample, so CVODES restarts at every sample.
// Counters: error (states, as above), sens_error (sensitivities, as above), steps (internal steps
// per simulation); the RK4 substeps are in the benchmark's name.
//
// Run: build/bench/integrators_bench --benchmark_min_time=0.2 --benchmark_repetitions=5
//        --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "graybox/estimators/cvodes_integrator.h"
#include "graybox/estimators/integrators.h"
#include "graybox/models/model.h"

namespace {

namespace est = graybox::estimators;
namespace models = graybox::models;

constexpr unsigned kSeed = 7;
constexpr double kDuration = 3.0;  // s
constexpr double kReferenceRtol = 1e-12;
const Eigen::Vector4d kX0(M_PI / 2.0, 0.0, 300.0, 300.0);
// Typical magnitudes of q [rad], qd [rad/s], p1, p2 [kPa]: absolute tolerance = rtol * these.
const Eigen::Vector4d kStateScale(1.0, 10.0, 300.0, 300.0);

models::StateSpaceModel ArmModel() {
  models::Model m("pneumatic_arm");
  m.AddInput("u1", "V", "valve 1 command", 0.0, 10.0);
  m.AddInput("u2", "V", "valve 2 command", 0.0, 10.0);
  m.AddBlock("arm", "pneumatic.arm", {}, {"u1", "u2"}, {"torque"});
  m.AddOutput("arm.q");
  m.AddOutput("torque");
  return m.Build();
}

struct Scenario {
  std::string name;
  double dt;
  Eigen::MatrixXd u;
};

std::vector<Scenario> Scenarios() {
  std::vector<Scenario> out;
  for (double dt : {0.01, 0.02}) {
    const int n = static_cast<int>(std::lround(kDuration / dt)) + 1;
    const int hold = static_cast<int>(std::lround(0.25 / dt));
    std::mt19937 rng(kSeed);
    std::uniform_real_distribution<double> level(0.0, 10.0);
    Eigen::MatrixXd u(n, 2);
    double v = 5.0;
    for (int k = 0; k < n; ++k) {
      if (k % hold == 0) v = level(rng);
      u(k, 0) = v;
      u(k, 1) = 10.0 - v;
    }
    out.push_back({dt == 0.01 ? "staircase_10ms" : "staircase_20ms", dt, u});
  }
  const double dt = 0.01;
  const int n = static_cast<int>(std::lround(kDuration / dt)) + 1;
  Eigen::MatrixXd u(n, 2);
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    u(k, 0) = 5.0 + 1.5 * std::sin(2.0 * M_PI * 0.5 * t) + 0.5 * std::sin(2.0 * M_PI * 2.3 * t);
    u(k, 1) = 10.0 - u(k, 0);
  }
  out.push_back({"sine_10ms", dt, u});
  return out;
}

est::CvodesOptions Options(double rtol) {
  est::CvodesOptions o;
  o.relative_tolerance = rtol;
  o.absolute_tolerances = rtol * kStateScale;
  return o;
}

double ScaledError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (!a.allFinite()) return INFINITY;
  double worst = 0.0;
  for (Eigen::Index j = 0; j < b.cols(); ++j) {
    const double scale = std::max(b.col(j).cwiseAbs().maxCoeff(), 1e-300);
    worst = std::max(worst, (a.col(j) - b.col(j)).cwiseAbs().maxCoeff() / scale);
  }
  return worst;
}

Eigen::MatrixXd Stack(const est::SensitivityTrajectory& t) {
  const Eigen::Index nx = t.x.cols(), np = t.dx_dp.at(0).cols();
  Eigen::MatrixXd out(static_cast<Eigen::Index>(t.dx_dp.size()) * nx, np + nx);
  for (std::size_t k = 0; k < t.dx_dp.size(); ++k) {
    out.block(static_cast<Eigen::Index>(k) * nx, 0, nx, np) = t.dx_dp[k];
    out.block(static_cast<Eigen::Index>(k) * nx, np, nx, nx) = t.dx_dx0[k];
  }
  return out;
}

// One calibrated comparison: a CVODES tolerance and the RK4 substeps of equal error, for the
// simulation and for the simulation with sensitivities.
struct Case {
  const Scenario* scenario;
  double rtol;
  double cvodes_error, cvodes_sens_error;
  int substeps, sens_substeps;
  double rk4_error, rk4_sens_state_error, rk4_sens_error;
  std::shared_ptr<est::CvodesIntegrator> cvodes;
  std::shared_ptr<est::FixedStepIntegrator> rk4, rk4_sens;
};

est::FixedStepOptions Rk4(int substeps) {
  est::FixedStepOptions o;
  o.substeps = substeps;
  return o;
}

// The smallest n >= 1 with ok(n), by doubling and then bisection (assumes ok is monotone).
template <typename Ok>
int SmallestSubsteps(const Ok& ok) {
  int hi = 1;
  while (!ok(hi) && hi < (1 << 14)) hi *= 2;
  int lo = hi / 2;
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    (ok(mid) ? hi : lo) = mid;
  }
  return hi;
}

void Time(benchmark::State& state, const est::Integrator& integrator, const Scenario& s,
          const Eigen::VectorXd& p, bool sensitivities, double error, double sens_error) {
  long steps = 0;
  for (auto _ : state) {
    if (sensitivities) {
      est::SensitivityTrajectory t = integrator.SimulateWithSensitivities(kX0, s.u, p);
      steps = t.summary.num_steps;
      if (!t.ok) state.SkipWithError(t.summary.BriefReport().c_str());
      benchmark::DoNotOptimize(t.x.data());
    } else {
      est::Trajectory t = integrator.Simulate(kX0, s.u, p);
      steps = t.summary.num_steps;
      if (!t.ok) state.SkipWithError(t.summary.BriefReport().c_str());
      benchmark::DoNotOptimize(t.x.data());
    }
  }
  state.counters["error"] = error;
  if (sensitivities) state.counters["sens_error"] = sens_error;
  state.counters["steps"] = static_cast<double>(steps);
  state.counters["samples"] = static_cast<double>(s.u.rows());
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;

  static const models::StateSpaceModel model = ArmModel();
  static const Eigen::VectorXd p = model.ParameterValues();
  static const std::vector<Scenario> scenarios = Scenarios();
  static std::vector<Case> cases;
  for (const Scenario& s : scenarios) {
    const est::CvodesIntegrator reference(model, s.dt, Options(kReferenceRtol));
    const est::SensitivityTrajectory ref = reference.SimulateWithSensitivities(kX0, s.u, p);
    if (!ref.ok) {
      std::fprintf(stderr, "reference failed: %s\n", ref.summary.BriefReport().c_str());
      return 1;
    }
    const Eigen::MatrixXd ref_sens = Stack(ref);
    auto rk4_error = [&](int substeps) {
      return ScaledError(est::SimulateRk4(model, kX0, s.u, p, s.dt, substeps).x, ref.x);
    };
    for (double rtol : {1e-6, 1e-8}) {
      Case c;
      c.scenario = &s;
      c.rtol = rtol;
      c.cvodes = std::make_shared<est::CvodesIntegrator>(model, s.dt, Options(rtol));
      const est::SensitivityTrajectory cs = c.cvodes->SimulateWithSensitivities(kX0, s.u, p);
      c.cvodes_error = ScaledError(c.cvodes->Simulate(kX0, s.u, p).x, ref.x);
      c.cvodes_sens_error = ScaledError(Stack(cs), ref_sens);
      c.substeps = SmallestSubsteps([&](int n) { return rk4_error(n) <= c.cvodes_error; });
      c.rk4 = std::make_shared<est::FixedStepIntegrator>(model, s.dt, Rk4(c.substeps));
      c.rk4_error = rk4_error(c.substeps);
      c.sens_substeps = SmallestSubsteps([&](int n) {
        if (n < c.substeps) return false;
        const est::SensitivityTrajectory t =
            est::FixedStepIntegrator(model, s.dt, Rk4(n)).SimulateWithSensitivities(kX0, s.u, p);
        return ScaledError(t.x, ref.x) <= c.cvodes_error &&
               ScaledError(Stack(t), ref_sens) <= c.cvodes_sens_error;
      });
      c.rk4_sens = std::make_shared<est::FixedStepIntegrator>(model, s.dt, Rk4(c.sens_substeps));
      const est::SensitivityTrajectory rs = c.rk4_sens->SimulateWithSensitivities(kX0, s.u, p);
      c.rk4_sens_state_error = ScaledError(rs.x, ref.x);
      c.rk4_sens_error = ScaledError(Stack(rs), ref_sens);
      std::printf(
          "%-15s rtol %.0e: cvodes error %.2e, sens %.2e (%ld steps, %ld with sensitivities); "
          "rk4: %d substeps for the states (error %.2e; 1 substep: %.2e), %d substeps for "
          "states and sensitivities (sens error %.2e)\n",
          s.name.c_str(), rtol, c.cvodes_error, c.cvodes_sens_error,
          c.cvodes->Simulate(kX0, s.u, p).summary.num_steps, cs.summary.num_steps, c.substeps,
          c.rk4_error, rk4_error(1), c.sens_substeps, c.rk4_sens_error);
      cases.push_back(c);
    }
  }
  auto min = [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); };
  for (const Case& c : cases) {
    char tag[64];
    std::snprintf(tag, sizeof(tag), "%s/rtol%.0e", c.scenario->name.c_str(), c.rtol);
    const Case* cp = &c;
    benchmark::RegisterBenchmark(("BM_Cvodes_Simulate/" + std::string(tag)).c_str(),
                                 [cp](benchmark::State& st) {
                                   Time(st, *cp->cvodes, *cp->scenario, p, false, cp->cvodes_error,
                                        0.0);
                                 })
        ->Unit(benchmark::kMillisecond)
        ->ComputeStatistics("min", min);
    benchmark::RegisterBenchmark(
        ("BM_Rk4_Simulate/" + std::string(tag) + "/substeps" + std::to_string(c.substeps)).c_str(),
        [cp](benchmark::State& st) {
          Time(st, *cp->rk4, *cp->scenario, p, false, cp->rk4_error, 0.0);
        })
        ->Unit(benchmark::kMillisecond)
        ->ComputeStatistics("min", min);
    benchmark::RegisterBenchmark(
        ("BM_Cvodes_SimulateWithSensitivities/" + std::string(tag)).c_str(),
        [cp](benchmark::State& st) {
          Time(st, *cp->cvodes, *cp->scenario, p, true, cp->cvodes_error, cp->cvodes_sens_error);
        })
        ->Unit(benchmark::kMillisecond)
        ->ComputeStatistics("min", min);
    benchmark::RegisterBenchmark(("BM_Rk4_SimulateWithSensitivities/" + std::string(tag) +
                                  "/substeps" + std::to_string(c.sens_substeps))
                                     .c_str(),
                                 [cp](benchmark::State& st) {
                                   Time(st, *cp->rk4_sens, *cp->scenario, p, true,
                                        cp->rk4_sens_state_error, cp->rk4_sens_error);
                                 })
        ->Unit(benchmark::kMillisecond)
        ->ComputeStatistics("min", min);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
