// The covariance on the EMPS closed loop (problems/emps/emps_closed_loop*.toml, data in
// ../shared/data/emps): one answer for one optimum, whichever form and solver found it.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include "graybox/estimators/analysis/covariance.h"
#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/problem/problem_file.h"
#include "graybox/estimators/solvers/solvers.h"

namespace graybox::estimators {
namespace {

// The repository root, from this file's place in it (tests/estimators/).
std::string SourceDir() {
  std::string f = __FILE__;
  for (int up = 0; up < 3; ++up) f = f.substr(0, f.find_last_of('/'));
  return f;
}

std::string EmpsProblem(const std::string& file) { return SourceDir() + "/problems/emps/" + file; }

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The whole estimation record (24841 samples): about 10 s of fitting on this 2-core machine
// (Ipopt 1.5 s, Ceres 7.4 s), and the figures of problems/emps/README.md.
constexpr int kSamples = 24841;

struct Fit {
  Problem problem;
  std::vector<Experiment> experiments;
  std::vector<ExperimentSetup> setups;
};

Fit Load(const std::string& file) {
  Fit f{LoadProblem(EmpsProblem(file)), {}, {}};
  for (const SplitData& s : LoadData(f.problem)) {
    if (s.role != SplitRole::kEstimation) continue;
    f.experiments.push_back(Slice(s.experiment, 0, std::min(kSamples, s.experiment.NumSamples())));
    f.setups.push_back(s.setup);
  }
  return f;
}

// Ipopt with continuity as constraints and Ceres with continuity residuals weighted 1e7 stop at
// the same optimum (problems/emps/README.md: six digits); the covariance is a property of that
// optimum, so both forms must give the same standard errors. Before the covariance treated the
// continuity conditions as exact constraints, the Ipopt form gave M 0.1069 kg and Fv 1.140 N s/m
// and the Ceres form 0.0327 and 0.387 (3.3 times smaller): the Ipopt form's constraints entered
// as residuals weighted with the default continuity_weight 100 (the Ceres file's 1e7 is not in
// the Ipopt file), so loose that the nodes absorbed most of what the data say about the
// parameters; the weight-1e7 rows of the Ceres form are constraints in all but name.
TEST(CovarianceEmps, IpoptAndCeresFormsGiveTheSameStandardErrors) {
  const Fit ipopt_fit = Load("emps_closed_loop.toml");
  const Fit ceres_fit = Load("emps_closed_loop_ceres.toml");
  const EstimationSpec& si = ipopt_fit.problem.estimation;
  const EstimationSpec& sc = ceres_fit.problem.estimation;
  ASSERT_TRUE(si.multiple_shooting.continuity_as_constraints);
  ASSERT_FALSE(sc.multiple_shooting.continuity_as_constraints);

  auto t0 = std::chrono::steady_clock::now();
  const ShootingProblem pi = BuildMultipleShooting(ipopt_fit.problem.built, ipopt_fit.experiments,
                                                   ipopt_fit.setups, si.multiple_shooting);
  const SolverResult ri = SolveWithIpopt(pi.nlp, si.ipopt);
  ASSERT_TRUE(ri.success) << ri.FullReport();
  std::cout << "[ ipopt    ] " << ri.BriefReport() << " (" << Seconds(t0) << " s with the build)\n";
  t0 = std::chrono::steady_clock::now();
  const ShootingProblem pc = BuildMultipleShooting(ceres_fit.problem.built, ceres_fit.experiments,
                                                   ceres_fit.setups, sc.multiple_shooting);
  const SolverResult rc = SolveWithCeres(pc.nlp, sc.ceres);
  ASSERT_TRUE(rc.success) << rc.FullReport();
  std::cout << "[ ceres    ] " << rc.BriefReport() << " (" << Seconds(t0) << " s with the build)\n";

  // The continuity rows of the Ceres form: the last 3 residuals of every segment but the last.
  const std::vector<int> rows = ContinuityResidualRows(pc);
  const int segments =
      (kSamples + si.multiple_shooting.segment_length - 1) / si.multiple_shooting.segment_length;
  EXPECT_EQ(static_cast<int>(rows.size()), 3 * (segments - 1));
  EXPECT_TRUE(ContinuityResidualRows(pi).empty());

  // What the command-line tool reports: one noise variance per output channel.
  CovarianceOptions options;
  options.channel_names = {"load.q", "nu"};
  options.channel_units = {"m", "V"};
  t0 = std::chrono::steady_clock::now();
  const UncertaintyReport ui = NlpCovariance(pi, ri.w, options);
  const double covariance_seconds = Seconds(t0);
  const UncertaintyReport uc = NlpCovariance(pc, rc.w, options);
  std::cout << "[ ipopt    ] " << ui.FullReport() << "[ ceres    ] " << uc.FullReport()
            << "             (" << covariance_seconds << " s per covariance)\n";
  // The generic form with the continuity rows given explicitly and one pooled variance.
  CovarianceOptions pooled;
  pooled.constraint_residual_rows = rows;
  const UncertaintyReport ui_pooled = NlpCovariance(pi.nlp, ri.w, pi.parameters);
  const UncertaintyReport uc_pooled = NlpCovariance(pc.nlp, rc.w, pc.parameters, pooled);
  std::cout << "[ pooled   ] ipopt " << ui_pooled.FullReport() << "             ceres "
            << uc_pooled.FullReport();
  ASSERT_TRUE(ui.ok && uc.ok && ui_pooled.ok && uc_pooled.ok)
      << ui.failure << uc.failure << ui_pooled.failure << uc_pooled.failure;

  // The two optima agree to ~6 digits, their cost to 3e-5 relative; the standard errors agree to
  // ~1e-4 (measured), and to much better than the factor 3.3 of before.
  constexpr double kSameOptimum = 0.01;
  for (const auto& [a, b] : {std::pair{&ui, &uc}, std::pair{&ui_pooled, &uc_pooled}}) {
    EXPECT_NEAR(a->residual_variance, b->residual_variance, kSameOptimum * a->residual_variance);
    EXPECT_EQ(a->num_residuals, b->num_residuals);  // continuity rows are no noise samples
    EXPECT_EQ(a->num_residuals, 2 * kSamples);
    for (int i : a->free_indices) {
      const ParameterEstimate& ei = a->parameters[static_cast<std::size_t>(i)];
      const ParameterEstimate& ec = b->parameters[static_cast<std::size_t>(i)];
      EXPECT_GT(ei.std_error, 0.0) << ei.name;
      EXPECT_NEAR(ei.std_error, ec.std_error, kSameOptimum * ei.std_error) << ei.name;
    }
  }
  // The pooled figures are the constrained problem's (measured on the whole record; the Ceres
  // form gave them before too, its weight 1e7 being close to exact): M 0.0327 kg, Fv 0.387 N s/m.
  constexpr double kReferenceFigure = 0.01;
  const auto std_of = [](const UncertaintyReport& u, const std::string& name) {
    for (const auto& e : u.parameters) {
      if (e.name == name) return e.std_error;
    }
    return -1.0;
  };
  EXPECT_NEAR(std_of(ui_pooled, "load.mass"), 0.0327, kReferenceFigure * 0.0327);
  EXPECT_NEAR(std_of(ui_pooled, "viscous.fv"), 0.387, kReferenceFigure * 0.387);
  // sigma per channel in the outputs' units: the position residual is 3 um, the command residual
  // 0.096 V (problems/emps/README.md: 0.002 % and 6 % relative errors of the simulation).
  ASSERT_EQ(ui.channels.size(), 2u);
  EXPECT_EQ(ui.channels[0].name, "load.q");
  EXPECT_EQ(ui.channels[0].unit, "m");
  EXPECT_GT(ui.channels[0].sigma, 1e-6);
  EXPECT_LT(ui.channels[0].sigma, 1e-5);
  EXPECT_GT(ui.channels[1].sigma, 0.05);
  EXPECT_LT(ui.channels[1].sigma, 0.2);
  constexpr double kRounding = 1e-12;
  for (const ChannelNoise& c : ui.channels) {
    EXPECT_NEAR(c.sigma * c.weight, c.weighted_sigma, kRounding * c.weighted_sigma) << c.name;
    EXPECT_EQ(c.num_residuals, kSamples);
  }
  EXPECT_NE(ui.BriefReport().find("load.q"), std::string::npos) << ui.BriefReport();
}

}  // namespace
}  // namespace graybox::estimators
