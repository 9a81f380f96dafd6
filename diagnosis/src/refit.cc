#include "screening_internal.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/QR>
#include <Eigen/Sparse>
#include <Eigen/SparseLU>

#include "graybox/estimators/integrators/integrator_factory.h"
#include "graybox/estimators/nlp/nlp.h"
#include "graybox/util/thread_user_time.h"

namespace graybox::diagnosis::internal {

namespace est = graybox::estimators;

void InformationCriteria(const est::FitResult& fit, double* aic, double* bic) {
  const double n = fit.num_residuals;
  const double rss = 2.0 * fit.solver_result.cost;
  int k = 0;
  for (const auto& p : fit.parameters) k += p.free ? 1 : 0;
  if (!(n > 0.0) || !(rss > 0.0)) {
    *aic = *bic = kNaN;
    return;
  }
  const double fit_term = n * std::log(rss / n);
  *aic = fit_term + 2.0 * k;
  *bic = fit_term + k * std::log(n);
}

RefitResult UnfittedResult(const CandidateScore& screened, double before) {
  RefitResult out;
  const Candidate& c = screened.candidate;
  out.candidate = c;
  out.effect = c.effect;
  out.detail = c.detail;
  out.attachment = c.attachment;
  out.score = screened.score;
  out.validation_nrmse_before = before;
  out.validation_nrmse_after = out.relative_gain = kNaN;
  out.aic = out.bic = kNaN;
  return out;
}

// The re-fit of one candidate, in two stages (see the header): (A) the screened parameters free,
// started from the score test's one-step estimate (from neutral again when that fails), the shape
// parameters held; (B) the shape parameters freed too, warm-started from A. B is kept only when
// it is usable, no freed shape parameter ends at a bound and its cost is not above A's.
RefitRun::RefitRun(const est::Problem& problem, const std::vector<est::SplitData>& splits,
                   const est::FitResult& nominal, const CandidateScore& screened,
                   const std::string& role, double before, double max_seconds)
    : problem_(problem),
      splits_(splits),
      nominal_(nominal),
      screened_(screened),
      role_(role),
      before_(before),
      max_seconds_(max_seconds),
      started_(std::chrono::steady_clock::now()),
      divergence_(nominal.solver_result.cost) {}

double RefitRun::CpuElapsed() const {
  return cpu_spent_ + (running_ ? util::ThreadUserSeconds() - cpu_mark_ : 0.0);
}

bool RefitRun::BudgetLeft() {
  if (!(max_seconds_ > 0.0)) return true;
  const double left = max_seconds_ - CpuElapsed();
  if (!(left > 0.0)) return false;
  session_->SetMaxSolveSeconds(left);
  return true;
}

est::FitResult RefitRun::TimedSolve(const est::FitResult* start) {
  const auto t0 = std::chrono::steady_clock::now();
  divergence_.Reset();
  est::FitResult r = session_->Solve(start);
  if (divergence_.fired() && r.solver_result.status_code == est::SolverStatus::kUserInterrupt) {
    char line[400];
    std::snprintf(line, sizeof(line),
                  "%s: in %d iterations Ipopt's dual infeasibility exceeded %.0e x its start "
                  "(%.3g) with the cost above %.0f x the nominal fit's (%.6g), or %.0e x at any "
                  "cost (largest %.3g x; stopped at iteration %d, cost %.4g)",
                  kDivergedPrefix, kDivergenceIterations, kDivergenceGrowth, divergence_.start(),
                  kDivergenceCost, divergence_.nominal_cost(), kRunawayGrowth,
                  divergence_.largest_growth(), divergence_.fired_at(), divergence_.cost_at_stop());
    r.solver_result.message = line;
    out_.stages.push_back("solve " + std::to_string(solves_ + 1) + " stopped: " + line);
  }
  solve_wall_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const auto& [what, seconds] : r.seconds) {
    if (what == "solve") solver_seconds_ += seconds;
  }
  ++solves_;
  iterations_ += (iterations_.empty() ? "" : "+") + std::to_string(r.solver_result.iterations);
  return r;
}

void RefitRun::Resume() {
  cpu_mark_ = util::ThreadUserSeconds();
  running_ = true;
}

void RefitRun::Pause() {
  cpu_spent_ += util::ThreadUserSeconds() - cpu_mark_;
  running_ = false;
}

void RefitRun::StageA() {
  const est::Problem& problem = problem_;
  const std::vector<est::SplitData>& splits = splits_;
  const est::FitResult& nominal = nominal_;
  const CandidateScore& screened = screened_;
  const std::string& role = role_;
  const double max_seconds = max_seconds_;
  const Candidate& c = screened.candidate;
  RefitResult& out = out_;
  Resume();
  out = UnfittedResult(screened, before_);
  try {
    // The option the screening chose (Candidate::option_grids), in the declarative form too.
    std::string option;
    const std::string option_prefix = c.instance + " option ";
    for (const auto& [key, value] : screened.shape_start) {
      if (key.rfind(option_prefix, 0) != 0) continue;
      option = key.substr(option_prefix.size());
      out.candidate.augmentation.options.numbers[option] = {value};
    }
    // Options the candidate reads from the model's parameters, at the re-fit's start values.
    for (const auto& [option, parameter] : c.options_from_parameters) {
      out.candidate.augmentation.options.numbers[option] = {
          nominal.values[problem.built.ParameterIndex(parameter)]};
    }
    aug_ = AugmentedProblem(problem, nominal, c, false);
    est::Problem& aug = aug_;
    est::FitOptions fo;
    fo.max_solve_seconds = max_seconds;
    // The budget is user CPU time of this thread (the re-fit's solves all run on it): waiting for
    // Ipopt's lock or for a core of a loaded machine does not spend it, nor do the page faults of
    // a re-fit's fresh process, so the outcome does not depend on the load or on where the re-fit
    // runs (a Dahl re-fit missed its grid on a loaded machine with a wall budget).
    fo.budget_clock = est::FitOptions::BudgetClock::kThreadUser;
    if (aug.estimation.solver == "ipopt") {
      fo.iteration_callback = [this](const est::IterationSummary& it) {
        return divergence_.Continue(it);
      };
    }
    session_ =
        std::make_unique<est::FitSession>(aug, AugmentedSplits(splits, aug.built.NumStates()), fo);
    auto& session = session_;
    auto budget_left = [this]() { return BudgetLeft(); };
    auto timed_solve = [this](const est::FitResult* start) { return TimedSolve(start); };
    std::vector<double> neutral;
    neutral.assign(c.screened.size(), 0.0);
    for (std::size_t i = 0; i < c.screened.size(); ++i) {
      for (const models::ModelParameter& p : aug.built.parameters) {
        if (p.name == c.screened[i]) neutral[i] = p.value;
      }
    }
    bool started_one_step = false;
    if (screened.one_step.size() == c.screened.size()) {
      for (std::size_t i = 0; i < c.screened.size(); ++i) {
        const double v = screened.one_step[i];
        if (!std::isfinite(v)) continue;
        for (const models::ModelParameter& p : aug.built.parameters) {
          if (p.name != c.screened[i]) continue;
          session->SetParameterValue(p.name, std::min(std::max(v, p.lower), p.upper));
          started_one_step = true;
        }
      }
    }
    budget_left();
    est::FitResult a = timed_solve(nullptr);
    if (started_one_step && (!a.IsSolutionUsable() || Diverged(a.solver_result)) && budget_left()) {
      const std::string first_status = a.solver_result.status;
      for (std::size_t i = 0; i < c.screened.size(); ++i) {
        session->SetParameterValue(c.screened[i], neutral[i]);
      }
      a = timed_solve(nullptr);
      out.stages.push_back("from the one-step estimate: " + first_status +
                           "; restarted from the neutral values: " + a.solver_result.status);
    }
    // A solve replaces the best so far when it converged and validates better (or the best so
    // far did not converge, or does not simulate on the validation splits).
    auto validates_better = [&role](const est::FitResult& trial, const est::FitResult& best) {
      if (!trial.IsSolutionUsable() || !trial.solver_result.success) return false;
      if (!best.solver_result.success) return true;
      const double t = ValidationNrmse(trial.evaluations, role);
      const double b = ValidationNrmse(best.evaluations, role);
      if (!std::isfinite(t)) return false;
      return !std::isfinite(b) || t < b;
    };
    // A second start of stage A from the problem's own start values of the nominal parameters
    // (the user's guesses in the first round) where the converged warm start may sit in the
    // nominal fit's corner: a nominal free parameter ends at a bound in the nominal fit or in it
    // (a nominal model that absorbs a missing effect runs into such corners, and a re-fit started
    // there stays: a series elastic joint fitted without its true inertia went to Ke = 0.057
    // against 8.459 N m/rad, and the true structure's re-fit from there to a damping of 0.52
    // against 0.004 N m s/rad, validating 5 times worse than from the guesses). A warm start that
    // did not converge is left to the grid and stage B, which start from it (a second start
    // there spent a Dahl re-fit's budget before its grid recovered it).
    {
      const bool converged = a.IsSolutionUsable() && a.solver_result.success;
      bool corner = false, differs = false;
      std::vector<int> nominal_free;
      for (int i = 0; converged && i < problem.built.NumParameters(); ++i) {
        const models::ModelParameter& p = problem.built.parameters[i];
        if (!p.free || std::find(c.refit.begin(), c.refit.end(), p.name) != c.refit.end()) {
          continue;
        }
        // A nominal parameter the candidate holds (the elastic split's body inertia) keeps the
        // value apply() gave it.
        if (!aug.built.parameters[aug.built.ParameterIndex(p.name)].free) continue;
        nominal_free.push_back(i);
        corner = corner || nominal.Parameter(p.name).at_bound || a.Parameter(p.name).at_bound;
        differs = differs || p.value != nominal.values[i];
      }
      if (corner && differs && budget_left()) {
        for (const int i : nominal_free) {
          const models::ModelParameter& p = problem.built.parameters[i];
          session->SetParameterValue(p.name, std::min(std::max(p.value, p.lower), p.upper));
        }
        for (std::size_t i = 0; i < c.screened.size(); ++i) {
          double v = neutral[i];
          if (started_one_step && std::isfinite(screened.one_step[i])) v = screened.one_step[i];
          const models::ModelParameter& p =
              aug.built.parameters[aug.built.ParameterIndex(c.screened[i])];
          session->SetParameterValue(p.name, std::min(std::max(v, p.lower), p.upper));
        }
        est::FitResult cold = timed_solve(nullptr);
        const bool better = validates_better(cold, a);
        char line[320];
        std::snprintf(line, sizeof(line),
                      "a second start from the problem's start values of the nominal parameters "
                      "(a nominal parameter at a bound): validation NRMSE %.6g against %.6g, %s",
                      ValidationNrmse(cold.evaluations, role), ValidationNrmse(a.evaluations, role),
                      better ? "kept" : "not kept");
        out.stages.push_back(line);
        if (better) {
          a = std::move(cold);
        } else {
          // Values set after `a` was solved win over a warm start from it (FitSession::Solve):
          // put a's back, so the grid and stage B start from it.
          for (const int i : nominal_free) {
            const std::string& name = problem.built.parameters[i].name;
            session->SetParameterValue(name, a.Parameter(name).value);
          }
          for (const auto& q : c.screened) session->SetParameterValue(q, a.Parameter(q).value);
        }
      }
    }
    // The profile over one shape grid on the current session: stage A at every other grid value
    // (a fixed value changes, so each solve is warm-started from the best so far), the converged
    // solve of lowest validation NRMSE kept in *fit and its value in *best_value, the session
    // left at it. Returns the number of values tried, the start's included.
    auto profile_shape = [&](const std::string& shape, const std::vector<double>& values,
                             est::FitResult* fit, double* best_value) {
      *best_value = fit->Parameter(shape).value;
      const double first = *best_value;
      std::size_t tried = 1;
      for (const double v : values) {
        if (v == first) continue;
        if (!budget_left()) break;
        ++tried;
        session->SetParameterValue(shape, v);
        est::FitResult trial = timed_solve(fit);
        if (validates_better(trial, *fit)) {
          *fit = std::move(trial);
          *best_value = v;
        }
      }
      session->SetParameterValue(shape, *best_value);
      return tried;
    };
    for (const auto& [shape, values] : screened.shape_grid_values) {
      if (!a.IsSolutionUsable()) break;
      const double first = a.Parameter(shape).value;
      double best_value = first;
      const std::size_t tried = profile_shape(shape, values, &a, &best_value);
      char line[160];
      std::snprintf(line, sizeof(line),
                    "%s profiled over %zu of %zu grid values%s: %.4g (score's %.4g)", shape.c_str(),
                    tried, values.size(),
                    tried < values.size() ? " (the re-fit's budget spent)" : "", best_value, first);
      out.stages.push_back(line);
    }
    // The profile over the option grid: the option is structure, so each other value is a new
    // session, started from the best fit's parameter values; the converged solve of lowest
    // validation NRMSE is kept with its session, as for the shape grids (the score picks the
    // option poorly: a Coulomb level's softest sign scored highest on a pendulum whose truth
    // had a hard one, and validated 20 times worse than the steepest).
    if (!option.empty() && c.apply_with_option && screened.option_grid_values.size() > 1 &&
        a.IsSolutionUsable()) {
      const double first = out.candidate.augmentation.options.numbers[option].front();
      double best_value = first;
      std::size_t tried = 1;
      for (const double v : screened.option_grid_values) {
        if (v == first) continue;
        if (!budget_left()) break;
        ++tried;
        Candidate variant = c;
        const auto apply_with_option = c.apply_with_option;
        variant.apply = [apply_with_option, v](models::Model* m) { apply_with_option(m, v); };
        est::Problem variant_problem = AugmentedProblem(problem, nominal, variant, false);
        auto variant_session = std::make_unique<est::FitSession>(
            variant_problem, AugmentedSplits(splits, variant_problem.built.NumStates()), fo);
        // A structural candidate's option sets its held parameters itself (the elastic split:
        // the body's inertia, J, K, c): only the free ones start from the best fit.
        for (const est::FitParameter& p : a.parameters) {
          if (c.structural &&
              !variant_problem.built.parameters[variant_problem.built.ParameterIndex(p.name)]
                   .free) {
            continue;
          }
          variant_session->SetParameterValue(p.name, p.value);
        }
        std::swap(session, variant_session);
        budget_left();
        est::FitResult trial = timed_solve(nullptr);
        // A structural candidate's shape grids are profiled again at each option (the mode a
        // stiffness gives depends on the split).
        for (const auto& [shape, values] : screened.shape_grid_values) {
          if (!c.structural || !trial.IsSolutionUsable()) break;
          double best_shape = 0.0;
          profile_shape(shape, values, &trial, &best_shape);
        }
        if (validates_better(trial, a)) {
          a = std::move(trial);
          best_value = v;
          aug = std::move(variant_problem);
          out.candidate.apply = variant.apply;
          out.candidate.augmentation.options.numbers[option] = {v};
          variant_option_ = v;
        } else {
          std::swap(session, variant_session);
        }
      }
      char line[200];
      std::snprintf(
          line, sizeof(line),
          "option %s profiled over %zu of %zu grid values%s: %.4g (score's %.4g)", option.c_str(),
          tried, screened.option_grid_values.size(),
          tried < screened.option_grid_values.size() ? " (the re-fit's budget spent)" : "",
          best_value, first);
      out.stages.push_back(line);
    }
    out.fit = std::move(a);
    for (const auto& q : c.refit) {
      if (std::find(c.screened.begin(), c.screened.end(), q) == c.screened.end()) {
        shapes_.push_back(q);
      }
    }
  } catch (const std::exception& e) {
    out.failure = e.what();
    failed_ = true;
  }
  Pause();
}

bool RefitRun::HasShapeStage() const {
  return !failed_ && !shapes_.empty() && out_.fit.IsSolutionUsable();
}

void RefitRun::StageB() {
  if (!HasShapeStage()) return;
  RefitResult& out = out_;
  const std::string& role = role_;
  const std::vector<std::string>& shapes = shapes_;
  auto& session = session_;
  auto budget_left = [this]() { return BudgetLeft(); };
  auto timed_solve = [this](const est::FitResult* start) { return TimedSolve(start); };
  Resume();
  try {
    if (!shapes.empty() && out.fit.IsSolutionUsable() && !budget_left()) {
      out.stages.push_back(
          "shape parameters held (at the nominal or profiled values): the "
          "re-fit's budget was spent");
    } else if (!shapes.empty() && out.fit.IsSolutionUsable()) {
      for (const auto& q : shapes) session->FreeParameter(q);
      est::FitResult b = timed_solve(&out.fit);
      std::string held;
      if (!b.IsSolutionUsable() || !b.solver_result.success) {
        held = "the re-fit with them free stopped with " + b.solver_result.status;
        if (Diverged(b.solver_result)) {
          held += " (" + b.solver_result.message + ")";
        }
      } else if (b.solver_result.cost > out.fit.solver_result.cost * (1.0 + 1e-6)) {
        char line[200];
        std::snprintf(line, sizeof(line),
                      "the re-fit with them free ended at a higher cost (%.6g > %.6g, %s after "
                      "%d iterations)",
                      b.solver_result.cost, out.fit.solver_result.cost,
                      b.solver_result.status.c_str(), b.solver_result.iterations);
        held = line;
      } else {
        for (const auto& q : shapes) {
          if (b.Parameter(q).at_bound && held.empty()) {
            held = "the re-fit with them free put " + q + " at a bound";
          }
        }
      }
      const double a_validation = ValidationNrmse(out.fit.evaluations, role);
      const double b_validation = ValidationNrmse(b.evaluations, role);
      if (held.empty() && !(b_validation <= a_validation)) {
        char line[200];
        std::snprintf(line, sizeof(line),
                      "with them free the validation NRMSE is higher (%.4g > %.4g): the freed "
                      "shape fits the estimation data only",
                      b_validation, a_validation);
        held = line;
      }
      if (held.empty()) {
        out.fit = std::move(b);
        out.stages.push_back("shape parameters freed");
      } else {
        out.stages.push_back("shape parameters held (at the nominal or profiled values): " + held);
      }
    }
  } catch (const std::exception& e) {
    out.failure = e.what();
    failed_ = true;
  }
  Pause();
}

void RefitRun::HoldShapes(const std::string& reason) {
  if (HasShapeStage()) {
    out_.stages.push_back("shape parameters held (at the nominal or profiled values): " + reason);
  }
}

void RefitRun::Evaluate() {
  RefitResult& out = out_;
  const Candidate& c = screened_.candidate;
  if (failed_) return;
  Resume();
  try {
    out.parameters.clear();
    out.at_bound = false;
    out.ok = false;
    out.failure.clear();
    out.relative_gain = kNaN;
    for (const auto& q : c.parameters) out.parameters.push_back(out.fit.Parameter(q));
    for (const auto& q : c.refit) {
      const est::FitParameter& p = out.fit.Parameter(q);
      const bool family_end =
          std::find(c.family_ends.begin(), c.family_ends.end(), q) != c.family_ends.end();
      out.at_bound = out.at_bound || (p.free && p.at_bound && !family_end);
    }
    InformationCriteria(out.fit, &out.aic, &out.bic);
    out.validation_nrmse_after = ValidationNrmse(out.fit.evaluations, role_);
    if (!out.fit.IsSolutionUsable()) {
      out.failure = "solver: " + out.fit.solver_result.status + " " + out.fit.solver_result.message;
    } else if (!out.fit.solver_result.success) {
      const est::SolverResult& sr = out.fit.solver_result;
      out.failure = "the solver stopped before converging (" + sr.status + " after " +
                    std::to_string(sr.iterations) + " iterations" +
                    (Diverged(sr) ? "; " + sr.message : std::string()) + ")";
    } else if (!std::isfinite(out.validation_nrmse_after)) {
      out.failure = "the validation simulation did not finish";
    } else {
      out.failure = IntegrationCheck(aug_, splits_, out.fit, role_, out.validation_nrmse_after);
      out.ok = out.failure.empty();
      if (out.ok) out.relative_gain = (before_ - out.validation_nrmse_after) / before_;
    }
  } catch (const std::exception& e) {
    out.failure = e.what();
    out.ok = false;
  }
  Pause();
}

RefitResult RefitRun::Finish() {
  if (solves_ > 0) {
    char line[320];
    std::snprintf(
        line, sizeof(line),
        "%d solve(s) of %s iterations: %.3g s wall, %.3g s in the solver, re-fit %.3g s so far "
        "(%.3g s user CPU of its budget)",
        solves_, iterations_.c_str(), solve_wall_, solver_seconds_,
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count(),
        CpuElapsed());
    out_.stages.push_back(line);
  }
  session_.reset();
  return std::move(out_);
}

RefitResult Refit(const est::Problem& problem, const std::vector<est::SplitData>& splits,
                  const est::FitResult& nominal, const CandidateScore& screened,
                  const std::string& role, double before, double max_seconds) {
  RefitRun run(problem, splits, nominal, screened, role, before, max_seconds);
  run.StageA();
  run.StageB();
  run.Evaluate();
  return run.Finish();
}

}  // namespace graybox::diagnosis::internal
