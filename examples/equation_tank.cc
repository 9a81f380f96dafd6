// equation_tank: a user's own system written as equations in a problem file, fitted on data.
//
// Model. problems/equations/tank.toml: a water tank of cross-section A with a square-root
// (Torricelli) outflow through an outlet of area a, fed by a pump of gain kp with a flow limit
// q_max, as one block of type "equations" (no registered block expresses a square-root outflow or
// a flow limit):
//     A dh/dt = smooth_min(kp u, q_max, 1) - a sqrt(2 g smooth_max(h, 0, 0.01)),
// state h [cm], input the pump voltage u [V], output h. The problem file states the equations as
// text; graybox parses them into libexpr expressions, so Ipopt gets exact derivatives as for
// every registered block.
//
// Data. problems/equations/tank.csv is SYNTHETIC, made by this program with --generate: the truth
// kp = 30 cm^3/(s V), a = 0.5 cm^2 (A = 154 cm^2, g = 981 cm/s^2, q_max = 160 cm^3/s, the
// problem's constants), from h = 0, driven by a pump voltage held at random levels in [1.5, 6] V
// for 60 to 240 s (seed 7), simulated by RK4 with 20 steps per 1 s sample, the level measured
// with white noise of 0.1 cm. 2000 samples; the voltages above 5.33 V hit the flow limit.
//
//   build/examples/equation_tank --generate    # rewrites problems/equations/tank.csv
//   build/examples/equation_tank               # fits the shipped problem and checks it
//
// Check. The problem file's fit (estimators::Fit, multiple shooting on Ipopt, from kp = 25,
// a = 0.3) recovers kp and a within kTolerance (2 %) of the truth, and the validation split's
// NRMSE is below kMaxValidationNrmse. Exit code 0 when both hold.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <random>
#include <string>

#include <Eigen/Core>

#include "graybox/estimators/fit/fit.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/problem/problem_file.h"

namespace est = graybox::estimators;

namespace {

constexpr char kProblem[] = "problems/equations/tank.toml";
constexpr char kData[] = "problems/equations/tank.csv";
constexpr double kTrueKp = 30.0;  // cm^3/(s V)
constexpr double kTrueA = 0.5;    // cm^2
constexpr double kTolerance = 0.02;
// The noise is 0.1 cm on a level of about 10 cm standard deviation: ~0.01 at the truth.
constexpr double kMaxValidationNrmse = 0.02;

int Generate() {
  est::Problem problem = est::LoadProblem(kProblem);
  problem.model.SetParameter("tank.kp", kTrueKp);
  problem.model.SetParameter("tank.a", kTrueA);
  const graybox::models::StateSpaceModel m = problem.model.Build();
  constexpr int kSamples = 2000;
  constexpr double kDt = 1.0;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> level(1.5, 6.0), hold(60.0, 240.0);
  std::normal_distribution<double> noise(0.0, 0.1);
  Eigen::MatrixXd u(kSamples, 1);
  double next_change = 0.0, value = 0.0;
  for (int k = 0; k < kSamples; ++k) {
    if (k * kDt >= next_change) {
      value = level(rng);
      next_change += hold(rng);
    }
    u(k, 0) = value;
  }
  const est::Trajectory t =
      est::SimulateRk4(m, Eigen::VectorXd::Zero(1), u, m.ParameterValues(), kDt, 20);
  if (!t.ok) {
    std::cerr << "equation_tank: the truth's simulation failed\n";
    return 1;
  }
  std::ofstream out(kData);
  out << "time,u,h\n";
  char line[128];
  for (int k = 0; k < kSamples; ++k) {
    std::snprintf(line, sizeof(line), "%.1f,%.6f,%.6f\n", k * kDt, u(k, 0), t.y(k, 0) + noise(rng));
    out << line;
  }
  std::cout << "wrote " << kData << " (" << kSamples << " samples)\n";
  return out ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::strcmp(argv[1], "--generate") == 0) return Generate();
  const est::Problem problem = est::LoadProblem(kProblem);
  const est::FitResult fit = est::Fit(problem, est::LoadData(problem));
  std::cout << fit.FullReport() << "\n";
  bool ok = fit.IsSolutionUsable();
  for (const auto& [name, truth] : {std::pair<const char*, double>{"tank.kp", kTrueKp},
                                    std::pair<const char*, double>{"tank.a", kTrueA}}) {
    const double value = fit.Parameter(name).value;
    const double error = std::fabs(value / truth - 1.0);
    std::printf("%-8s %10.5g  truth %8.5g  relative error %.2e %s\n", name, value, truth, error,
                error <= kTolerance ? "" : "(TOO LARGE)");
    ok = ok && error <= kTolerance;
  }
  for (const est::SplitEvaluation& e : fit.evaluations) {
    if (e.role != est::SplitRole::kValidation) continue;
    const double nrmse = e.simulation.overall.nrmse;
    std::printf("validation NRMSE %.4f (at most %.3f)\n", nrmse, kMaxValidationNrmse);
    ok = ok && nrmse <= kMaxValidationNrmse;
  }
  std::cout << (ok ? "OK" : "FAILED") << "\n";
  return ok ? 0 : 1;
}
