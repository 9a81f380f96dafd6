// estimators::Fit and FitSession on the EMPS problems shipped in problems/emps (real data from
// ../shared/data/emps): the library pipeline reproduces the published IDIM-LS estimates, fits run
// side by side give the results of fits run one after another, and a re-fit after changing a
// fixed parameter reuses the formulation and lands where a fresh fit does.
#include <cmath>
#include <iostream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/estimators/data/dataset.h"
#include "graybox/estimators/fit/fit.h"

namespace graybox::estimators {
namespace {

const std::string kProblems = std::string(GRAYBOX_SOURCE_DIR) + "/problems/emps/";

// The published IDIM-LS estimates agree with ours to the digits printed in the EMPS benchmark
// description (M 95.1089, Fv 203.5034, Fc 20.3935, offset -3.1648): five significant digits.
constexpr double kPublishedRelTol = 2e-5;
// Fits on the same data in threads and in sequence run the same arithmetic (Ipopt's own code under
// its lock with the evaluations of the other threads overlapping, Ceres on one thread each): the
// results agree to rounding.
constexpr double kSameArithmeticRelTol = 1e-12;
// A warm re-fit and a cold fit converge to the same optimum within the solver tolerance (Ipopt
// tol 1e-8 on the scaled problem): they differ by far less than a thousandth of a standard error
// (a parameter held near its bound, like a Coulomb level the short record cannot tell from the
// offset, differs by 1e-5 N against a standard error of 1.3 N).
constexpr double kSameOptimumStdFraction = 1e-3;
// Samples of the closed-loop record used by the multiple-shooting tests (2 s of 24.8 s, several
// reference moves) to keep each fit short.
constexpr int kClosedLoopSamples = 2000;
// Two solves of one linear least-squares problem from different starts (Ceres, function
// tolerance 1e-12) agree to eight digits.
constexpr double kLeastSquaresRelTol = 1e-8;

double RelDiff(double a, double b) { return std::fabs(a - b) / std::max(std::fabs(b), 1e-300); }

// Equal to `tolerance` relative, or both NaN (a standard error that is not available).
bool SameOrBothNaN(double a, double b, double tolerance) {
  return (std::isnan(a) && std::isnan(b)) || RelDiff(a, b) <= tolerance;
}

// The closed-loop EMPS problem with its estimation split cut to the first samples and the test
// split dropped.
std::vector<SplitData> ShortEstimation(const std::vector<SplitData>& splits) {
  std::vector<SplitData> out;
  for (const SplitData& s : splits) {
    if (s.role != SplitRole::kEstimation) continue;
    SplitData cut = s;
    cut.experiment = Slice(s.experiment, 0, kClosedLoopSamples);
    cut.experiment.name = s.name;
    out.push_back(cut);
  }
  return out;
}

FitOptions Quiet() {
  FitOptions options;
  options.evaluate_splits = false;
  return options;
}

TEST(Fit, ReproducesThePublishedEmpsIdimEstimates) {
  const Problem problem = LoadProblem(kProblems + "emps_idim.toml");
  const FitResult fit = Fit(problem, LoadData(problem));
  ASSERT_TRUE(fit.IsSolutionUsable()) << fit.FullReport();
  EXPECT_EQ(fit.solver_result.status_code, SolverStatus::kConverged);
  EXPECT_LT(RelDiff(fit.Parameter("load.mass").value, 95.1089), kPublishedRelTol);
  EXPECT_LT(RelDiff(fit.Parameter("viscous.fv").value, 203.5034), kPublishedRelTol);
  EXPECT_LT(RelDiff(fit.Parameter("coulomb.fc").value, 20.3935), kPublishedRelTol);
  EXPECT_LT(RelDiff(fit.Parameter("offset.f_asym").value, -3.1648), kPublishedRelTol);
  ASSERT_TRUE(fit.has_uncertainty) << fit.uncertainty_error;
  EXPECT_GT(fit.Parameter("load.mass").std_error, 0.0);
  for (const FitParameter& p : fit.parameters) {
    if (!p.free) {
      EXPECT_EQ(p.std_error, 0.0) << p.name;
    }
  }
  // Every split is evaluated; the test split's relative command error is the README's 5.98 %.
  ASSERT_EQ(fit.evaluations.size(), 2u);
  const SplitEvaluation& test = fit.Evaluation("test_pulses");
  EXPECT_TRUE(test.has_equation);
  EXPECT_NEAR(100.0 * std::sqrt(test.equation.overall.nmse), 5.98, 0.01);
  EXPECT_NE(fit.BriefReport().find("equation_error/ceres: converged"), std::string::npos)
      << fit.BriefReport();
  EXPECT_NE(fit.FullReport().find("load.mass"), std::string::npos);
}

TEST(Fit, UnknownNamesAreErrorsWithSuggestions) {
  const Problem problem = LoadProblem(kProblems + "emps_idim.toml");
  FitSession session(problem, LoadData(problem), Quiet());
  try {
    session.SetParameterValue("load.mas", 90.0);
    FAIL() << "expected an exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'load.mass'"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(session.SetParameterValue("load.mass", std::nan("")), std::invalid_argument);
  EXPECT_THROW(session.SetParameterValue("load.mass", 1e9), std::invalid_argument);  // > upper
  const FitResult fit = session.Solve();
  EXPECT_THROW(fit.Parameter("coulomb.f"), std::invalid_argument);
  EXPECT_THROW(fit.Evaluation("test"), std::invalid_argument);
}

// A one-sample estimation split under multiple shooting cannot determine the closed loop's free
// parameters: the session refuses it before solving (it used to "succeed" at mass 216 kg).
TEST(Fit, AnEstimationSplitTooShortForTheFreeParametersIsRefused) {
  const Problem problem = LoadProblem(kProblems + "emps_closed_loop.toml");
  std::vector<SplitData> one;
  for (const SplitData& s : LoadData(problem)) {
    if (s.role != SplitRole::kEstimation) continue;
    SplitData cut = s;
    cut.experiment = Slice(s.experiment, 0, 1);
    cut.experiment.name = s.name;
    one.push_back(cut);
  }
  ASSERT_FALSE(one.empty());
  try {
    FitSession session(problem, one, Quiet());
    FAIL() << "expected an exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("expected at least as many residuals"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("(1 samples)"), std::string::npos) << e.what();
  }
}

TEST(Fit, FourFitsAtOnceGiveTheResultsOfFourInARow) {
  // Two Ipopt fits (serialised by the backend's lock) and two Ceres fits (parallel), each on its
  // own problem copy, with different fixed drive gains so that the four results differ.
  struct Case {
    std::string file;
    double drive_gain;
  };
  const std::vector<Case> cases = {{"emps_closed_loop.toml", 35.15065188248547},
                                   {"emps_closed_loop.toml", 36.0},
                                   {"emps_closed_loop_ceres.toml", 35.15065188248547},
                                   {"emps_closed_loop_ceres.toml", 36.0}};
  const Problem ipopt = LoadProblem(kProblems + "emps_closed_loop.toml");
  const std::vector<SplitData> splits = ShortEstimation(LoadData(ipopt));
  auto run = [&](const Case& c) {
    Problem problem = LoadProblem(kProblems + c.file);
    problem.model.SetParameter("drive.k", c.drive_gain);
    problem.built = problem.model.Build();
    return Fit(problem, splits, Quiet());
  };
  std::vector<FitResult> in_a_row;
  for (const Case& c : cases) in_a_row.push_back(run(c));
  std::vector<FitResult> at_once(cases.size());
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    threads.emplace_back([&, i] { at_once[i] = run(cases[i]); });
  }
  for (auto& t : threads) t.join();
  for (std::size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE(cases[i].file + " drive.k " + std::to_string(cases[i].drive_gain));
    ASSERT_TRUE(in_a_row[i].IsSolutionUsable()) << in_a_row[i].FullReport();
    ASSERT_TRUE(at_once[i].IsSolutionUsable()) << at_once[i].FullReport();
    EXPECT_EQ(at_once[i].solver_result.iterations, in_a_row[i].solver_result.iterations);
    for (Eigen::Index k = 0; k < in_a_row[i].values.size(); ++k) {
      EXPECT_LE(RelDiff(at_once[i].values[k], in_a_row[i].values[k]), kSameArithmeticRelTol)
          << in_a_row[i].parameters[k].name;
    }
    for (std::size_t k = 0; k < in_a_row[i].parameters.size(); ++k) {
      if (!in_a_row[i].parameters[k].free) continue;
      EXPECT_LE(RelDiff(at_once[i].parameters[k].std_error, in_a_row[i].parameters[k].std_error),
                kSameArithmeticRelTol)
          << in_a_row[i].parameters[k].name;
    }
  }
  // The two gains give different masses: the cases did not collapse into one.
  EXPECT_GT(
      RelDiff(in_a_row[1].Parameter("load.mass").value, in_a_row[0].Parameter("load.mass").value),
      1e-3);
}

TEST(Fit, WarmRefitAfterChangingAFixedValueReusesTheFormulation) {
  const Problem problem = LoadProblem(kProblems + "emps_closed_loop.toml");
  const std::vector<SplitData> splits = ShortEstimation(LoadData(problem));
  FitSession session(problem, splits, Quiet());
  const FitResult first = session.Solve();
  ASSERT_TRUE(first.IsSolutionUsable()) << first.FullReport();
  constexpr double kNewGain = 36.0;  // N/V, the drive gain 2.4 % higher
  session.SetParameterValue("drive.k", kNewGain);
  const FitResult warm = session.Solve(&first);
  EXPECT_EQ(session.num_formulations(), 1);  // no symbolic work for the new value
  ASSERT_TRUE(warm.IsSolutionUsable()) << warm.FullReport();
  EXPECT_EQ(warm.Parameter("drive.k").value, kNewGain);
  // A fresh fit with the new value from the file's starting point reaches the same optimum.
  Problem changed = problem;
  changed.model.SetParameter("drive.k", kNewGain);
  changed.built = changed.model.Build();
  const FitResult cold = Fit(changed, splits, Quiet());
  ASSERT_TRUE(cold.IsSolutionUsable()) << cold.FullReport();
  for (const char* name : {"load.mass", "viscous.fv", "coulomb.fc", "offset.f_asym"}) {
    const FitParameter& w = warm.Parameter(name);
    const FitParameter& c = cold.Parameter(name);
    EXPECT_LE(std::fabs(w.value - c.value), kSameOptimumStdFraction * c.std_error)
        << name << "\nwarm: " << warm.FullReport() << "\ncold: " << cold.FullReport();
  }
  // The gain moves the mass: the re-fit did change the estimate (it used the new value).
  EXPECT_GT(RelDiff(warm.Parameter("load.mass").value, first.Parameter("load.mass").value), 1e-3);
  EXPECT_LE(warm.solver_result.iterations, cold.solver_result.iterations);
}

// FitOptions::iteration_callback sees every iteration of both solvers and stops the solve where
// it returns false: the result is usable, not converged, with the status of an interrupt.
TEST(Fit, TheCallersIterationCallbackStopsTheSolve) {
  constexpr int kStopAfter = 2;  // iterations (the full fits take more: checked below)
  for (const char* file : {"emps_closed_loop.toml", "emps_closed_loop_ceres.toml"}) {
    const Problem problem = LoadProblem(kProblems + file);
    const std::vector<SplitData> splits = ShortEstimation(LoadData(problem));
    const FitResult full = Fit(problem, splits, Quiet());
    ASSERT_TRUE(full.IsSolutionUsable()) << file << "\n" << full.FullReport();
    ASSERT_GT(full.solver_result.iterations, kStopAfter) << file;
    FitOptions options = Quiet();
    std::vector<int> seen;
    options.iteration_callback = [&seen](const IterationSummary& it) {
      seen.push_back(it.iteration);
      return it.iteration < kStopAfter;
    };
    const FitResult stopped = Fit(problem, splits, options);
    EXPECT_EQ(stopped.solver_result.status_code, SolverStatus::kUserInterrupt) << file;
    EXPECT_FALSE(stopped.solver_result.success) << file;
    EXPECT_TRUE(stopped.IsSolutionUsable()) << file;
    ASSERT_FALSE(seen.empty()) << file;
    EXPECT_EQ(seen.front(), 0) << file;  // the starting point is reported too
    EXPECT_EQ(seen.back(), kStopAfter) << file;
    EXPECT_EQ(stopped.solver_result.iterations, kStopAfter) << file;
    // The result is the iterate where it stopped: moved from the start, at the cost reported.
    ASSERT_FALSE(stopped.solver_result.history.empty()) << file;
    EXPECT_LT(stopped.solver_result.cost, stopped.solver_result.history.front().cost) << file;
    bool moved = false;
    for (const FitParameter& p : stopped.parameters)
      moved = moved || (p.free && p.value != p.initial);
    EXPECT_TRUE(moved) << file << "\n" << stopped.FullReport();
  }
}

// FitResult::solve_thread_user_seconds is the solving thread's user CPU time during the solve: more
// than nothing, never more than the solve's wall time (one thread cannot use more); a budget on
// that clock (FitOptions::BudgetClock::kThreadUser) of a quarter of it stops the same solve early,
// with a usable iterate.
TEST(Fit, TheSolvesThreadCpuTimeIsMeasuredAndABudgetOnItStopsTheSolve) {
  // getrusage's thread times advance in steps of at most a scheduler tick (4 ms at HZ=250).
  constexpr double kClockStep = 0.004;
  constexpr double kBudgetShare = 0.25;
  for (const char* file : {"emps_closed_loop.toml", "emps_closed_loop_ceres.toml"}) {
    const Problem problem = LoadProblem(kProblems + file);
    const std::vector<SplitData> splits = ShortEstimation(LoadData(problem));
    const FitResult full = Fit(problem, splits, Quiet());
    ASSERT_TRUE(full.IsSolutionUsable()) << file;
    double wall = 0.0;
    for (const auto& [phase, seconds] : full.seconds) {
      if (phase == "solve") wall = seconds;
    }
    EXPECT_GT(full.solve_thread_user_seconds, 0.0) << file;
    EXPECT_LE(full.solve_thread_user_seconds, wall + kClockStep) << file;
    std::cout << file << ": solve " << wall << " s wall, " << full.solve_thread_user_seconds
              << " s user CPU of its thread, " << full.solver_result.iterations << " iterations\n";
    FitOptions options = Quiet();
    options.budget_clock = FitOptions::BudgetClock::kThreadUser;
    options.max_solve_seconds = kBudgetShare * full.solve_thread_user_seconds;
    const FitResult stopped = Fit(problem, splits, options);
    EXPECT_EQ(stopped.solver_result.status_code, SolverStatus::kUserInterrupt) << file;
    EXPECT_TRUE(stopped.IsSolutionUsable()) << file;
    EXPECT_LT(stopped.solver_result.iterations, full.solver_result.iterations) << file;
  }
}

// ResultOf builds the result of a solve made by another session of the same problem (the
// diagnosis' re-fits in child processes): from the solver result alone, the parameter table,
// covariance, initial states and evaluations of the session that solved.
TEST(Fit, TheResultOfASolverPointMadeElsewhereEqualsTheSolvesResult) {
  const Problem problem = LoadProblem(kProblems + "emps_closed_loop.toml");
  const std::vector<SplitData> splits = ShortEstimation(LoadData(problem));
  FitSession solver(problem, splits);
  const FitResult solved = solver.Solve();
  ASSERT_TRUE(solved.IsSolutionUsable()) << solved.FullReport();
  FitSession other(problem, splits);
  const FitResult built = other.ResultOf(solved.solver_result);
  EXPECT_EQ(built.solver_result.iterations, solved.solver_result.iterations);
  EXPECT_EQ(built.num_variables, solved.num_variables);
  ASSERT_EQ(built.parameters.size(), solved.parameters.size());
  for (std::size_t i = 0; i < solved.parameters.size(); ++i) {
    const FitParameter& a = built.parameters[i];
    const FitParameter& b = solved.parameters[i];
    EXPECT_EQ(a.value, b.value) << b.name;
    EXPECT_EQ(a.initial, b.initial) << b.name;
    EXPECT_EQ(a.free, b.free) << b.name;
    EXPECT_TRUE(SameOrBothNaN(a.std_error, b.std_error, kSameArithmeticRelTol)) << b.name;
  }
  ASSERT_EQ(built.initial_states.size(), solved.initial_states.size());
  for (const auto& [name, x0] : solved.initial_states) {
    EXPECT_EQ(built.initial_states.at(name), x0) << name;
  }
  ASSERT_EQ(built.evaluations.size(), solved.evaluations.size());
  for (std::size_t i = 0; i < solved.evaluations.size(); ++i) {
    EXPECT_LE(RelDiff(built.evaluations[i].simulation.overall.nrmse,
                      solved.evaluations[i].simulation.overall.nrmse),
              kSameArithmeticRelTol);
  }
  // A session whose fixed value and free starting value were set after it formulated, warm-started
  // from an earlier solve (as the diagnosis' re-fits are): a session built with those start values
  // and that free set gives the same result from the solver point.
  FitSession moved(problem, splits);
  moved.FixParameter("offset.f_asym");
  moved.SetParameterValue("offset.f_asym", 0.5 * solved.Parameter("offset.f_asym").value);
  moved.SetParameterValue("load.mass", 1.1 * solved.Parameter("load.mass").value);
  const FitResult first = moved.Solve();
  moved.SetParameterValue("coulomb.fc", 0.9 * first.Parameter("coulomb.fc").value);
  const FitResult warm = moved.Solve(&first);
  ASSERT_TRUE(warm.IsSolutionUsable()) << warm.FullReport();
  Problem same = problem;
  for (const FitParameter& p : warm.parameters) {
    models::ModelParameter& mp = same.built.parameters[same.built.ParameterIndex(p.name)];
    mp.value = p.initial;
    mp.free = p.free;
    same.model.SetParameter(p.name, p.initial);
    if (p.free) {
      same.model.Free(p.name);
    } else {
      same.model.Fix(p.name);
    }
  }
  const FitResult rebuilt = FitSession(same, splits).ResultOf(warm.solver_result);
  for (std::size_t i = 0; i < warm.parameters.size(); ++i) {
    EXPECT_EQ(rebuilt.parameters[i].value, warm.parameters[i].value) << warm.parameters[i].name;
    EXPECT_EQ(rebuilt.parameters[i].initial, warm.parameters[i].initial);
    EXPECT_TRUE(SameOrBothNaN(rebuilt.parameters[i].std_error, warm.parameters[i].std_error,
                              kSameArithmeticRelTol))
        << warm.parameters[i].name;
  }
  // A point of another size is refused, naming both sizes.
  SolverResult wrong = solved.solver_result;
  wrong.w.conservativeResize(wrong.w.size() - 1);
  try {
    other.ResultOf(wrong);
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    const std::string expected = "a solver point of " + std::to_string(wrong.w.size()) +
                                 " variables, expected " + std::to_string(solved.num_variables);
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

TEST(Fit, FixingAndFreeingReformulates) {
  const Problem problem = LoadProblem(kProblems + "emps_idim.toml");
  FitSession session(problem, LoadData(problem), Quiet());
  const FitResult all = session.Solve();
  session.FixParameter("offset.f_asym");
  const FitResult fixed = session.Solve(&all);
  EXPECT_EQ(session.num_formulations(), 2);
  EXPECT_FALSE(fixed.Parameter("offset.f_asym").free);
  // Held at the session's value of the parameter: the file's 0 (SetParameterValue changes it).
  EXPECT_EQ(fixed.Parameter("offset.f_asym").value, 0.0);
  EXPECT_GT(RelDiff(fixed.Parameter("load.mass").value, all.Parameter("load.mass").value), 1e-6);
  session.FreeParameter("offset.f_asym");
  const FitResult again = session.Solve(&fixed);
  EXPECT_LE(RelDiff(again.Parameter("load.mass").value, all.Parameter("load.mass").value),
            kLeastSquaresRelTol);
}

TEST(Fit, EveryResidualRowCarriesItsExperimentSampleAndChannel) {
  const Problem problem = LoadProblem(kProblems + "emps_closed_loop_ceres.toml");
  const std::vector<SplitData> splits = ShortEstimation(LoadData(problem));
  FitSession session(problem, splits, Quiet());
  const Nlp& nlp = session.nlp();
  ASSERT_EQ(nlp.residual_labels().size(), static_cast<std::size_t>(nlp.NumResiduals()));
  const std::vector<std::string>& channels = nlp.residual_channels();
  std::map<std::string, int> rows_per_channel;
  std::vector<int> output_rows_per_sample(kClosedLoopSamples, 0);
  for (const ResidualLabel& l : nlp.residual_labels()) {
    ASSERT_EQ(l.experiment, 0);
    ASSERT_GE(l.channel, 0);
    ASSERT_LT(l.channel, static_cast<int>(channels.size()));
    ++rows_per_channel[channels[l.channel]];
    if (channels[l.channel].rfind("continuity.", 0) == 0) continue;
    ASSERT_GE(l.sample, 0);
    ASSERT_LT(l.sample, kClosedLoopSamples);
    ++output_rows_per_sample[l.sample];
  }
  // One row per sample and measured output; continuity rows (Ceres form) per state and segment
  // boundary (segments of 20 samples: 99 boundaries).
  EXPECT_EQ(rows_per_channel["load.q"], kClosedLoopSamples);
  EXPECT_EQ(rows_per_channel["nu"], kClosedLoopSamples);
  EXPECT_EQ(rows_per_channel["continuity.load.qd"], kClosedLoopSamples / 20 - 1);
  for (int k = 0; k < kClosedLoopSamples; ++k) ASSERT_EQ(output_rows_per_sample[k], 2) << k;
  EXPECT_EQ(session.EstimationSplitNames(), std::vector<std::string>{"estimation"});
}

}  // namespace
}  // namespace graybox::estimators
