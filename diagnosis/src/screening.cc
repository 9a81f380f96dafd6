#include "graybox/diagnosis/screening.h"

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

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;
using internal::InformationCriteria;
using internal::kNaN;
using internal::Refit;
using internal::Score;

std::string Format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

// The automatic re-fit budget (ScreeningOptions::refit_max_seconds = 0).
constexpr double kAutoBudgetFactor = 25.0;
constexpr double kAutoBudgetFloor = 10.0;

// Regularised lower incomplete gamma P(a, x) by its series (x < a + 1) and upper Q(a, x) by the
// Lentz continued fraction (otherwise); Numerical Recipes 6.2.
double GammaQ(double a, double x) {
  constexpr int kMaxIterations = 1000;
  constexpr double kEpsilon = 1e-15;
  const double log_prefactor = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1.0) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < kMaxIterations; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::fabs(term) < std::fabs(sum) * kEpsilon) break;
    }
    return std::max(0.0, 1.0 - sum * std::exp(log_prefactor));
  }
  constexpr double kTiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int i = 1; i < kMaxIterations; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::fabs(delta - 1.0) < kEpsilon) break;
  }
  return std::exp(log_prefactor) * h;
}

// `threads`, or one per hardware thread for 0.
int ResolvedThreads(int threads) {
  return threads > 0 ? threads
                     : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

// Runs fn(i) for i = 0 .. n-1 on `threads` threads (0: one per hardware thread), each index once.
// An exception escaping fn is rethrown on the calling thread after every worker has stopped.
template <typename Fn>
void ParallelFor(int n, int threads, Fn&& fn) {
  threads = ResolvedThreads(threads);
  threads = std::max(1, std::min(threads, n));
  if (threads <= 1) {
    for (int i = 0; i < n; ++i) fn(i);
    return;
  }
  std::atomic<int> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&] {
      for (int i = next++; i < n; i = next++) {
        try {
          fn(i);
        } catch (...) {
          std::lock_guard<std::mutex> lock(error_mutex);
          if (!error) error = std::current_exception();
        }
      }
    });
  }
  for (std::thread& w : workers) w.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace

est::Problem AugmentedProblem(const est::Problem& problem, const est::FitResult& start,
                              const Candidate& candidate, bool refit) {
  if (start.values.size() != problem.built.NumParameters()) {
    throw std::invalid_argument(
        "AugmentedProblem: the start has " + std::to_string(start.values.size()) +
        " parameter values; expected " + std::to_string(problem.built.NumParameters()) +
        " (the problem's model)");
  }
  models::Model m = problem.model;
  for (int i = 0; i < problem.built.NumParameters(); ++i) {
    m.Parameter(problem.built.parameters[i].name).value = start.values[i];
  }
  candidate.apply(&m);
  if (refit) {
    for (const auto& q : candidate.refit) m.Free(q);
  }
  est::Problem aug = problem;
  aug.model = m;
  aug.built = m.Build();
  return aug;
}

std::vector<est::SplitData> AugmentedSplits(const std::vector<est::SplitData>& splits,
                                            int num_states) {
  std::vector<est::SplitData> out = splits;
  for (est::SplitData& s : out) {
    const Eigen::Index old = s.setup.x0.size();
    if (old >= num_states) continue;
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(num_states);
    x0.head(old) = s.setup.x0;
    s.setup.x0 = x0;
    // The candidate's new states follow the method's default for their initial values.
    if (!s.setup.x0_free.empty()) s.setup.x0_free.resize(num_states, est::kInitialStateDefault);
    if (s.setup.state_guess.size() > 0) {
      Eigen::MatrixXd guess = Eigen::MatrixXd::Zero(s.setup.state_guess.rows(), num_states);
      guess.leftCols(s.setup.state_guess.cols()) = s.setup.state_guess;
      s.setup.state_guess = guess;
    }
  }
  return out;
}

std::string ValidationRole(const std::vector<est::SplitData>& splits) {
  bool validation = false, test = false;
  for (const auto& s : splits) {
    validation = validation || s.role == est::SplitRole::kValidation;
    test = test || s.role == est::SplitRole::kTest;
  }
  return validation ? "validation" : test ? "test" : "all";
}

double ValidationNrmse(const std::vector<est::SplitEvaluation>& evaluations,
                       const std::string& role) {
  double sum = 0.0;
  int count = 0;
  for (const auto& e : evaluations) {
    const bool use = role == "all" ||
                     (role == "validation" && e.role == est::SplitRole::kValidation) ||
                     (role == "test" && e.role == est::SplitRole::kTest);
    if (!use) continue;
    if (!e.simulation_ok) return kNaN;
    sum += e.simulation.overall.nrmse;
    ++count;
  }
  return count > 0 ? sum / count : kNaN;
}

std::string IntegrationCheck(const est::Problem& aug, const std::vector<est::SplitData>& splits,
                             const est::FitResult& fit, const std::string& role, double nrmse) {
  constexpr int kRefinement = 4;
  constexpr double kTolerance = 0.1;
  if (aug.estimation.integrator.method != est::IntegrationMethod::kFixedStep) return "";
  est::Problem fine = aug;
  fine.estimation.integrator.fixed_step.substeps *= kRefinement;
  const std::vector<est::SplitData> s = AugmentedSplits(splits, aug.built.NumStates());
  const double refined =
      ValidationNrmse(est::Simulate(fine, s, fit.values, fit.initial_states), role);
  if (std::isfinite(refined) && std::fabs(refined - nrmse) <= kTolerance * nrmse) return "";
  char line[240];
  std::snprintf(line, sizeof(line),
                "the fitted dynamics are not resolved by the integrator: validation NRMSE %.4g "
                "with the problem's step, %.4g with %d times the substeps",
                nrmse, refined, kRefinement);
  return line;
}

double ChiSquareSurvival(double x, int dof) {
  if (dof < 1) {
    throw std::invalid_argument("ChiSquareSurvival: expected dof >= 1, got " + std::to_string(dof));
  }
  if (!(x > 0.0)) return std::isnan(x) ? kNaN : 1.0;
  return GammaQ(0.5 * dof, 0.5 * x);
}

void ScreeningOptions::Validate() const {
  period_scan.Validate();
  if (!(contender_share >= 0.0 && contender_share <= 1.0)) {
    throw std::invalid_argument("ScreeningOptions.contender_share: expected in [0, 1], got " +
                                std::to_string(contender_share));
  }
  if (!(refit_max_seconds >= 0.0)) {
    throw std::invalid_argument("ScreeningOptions.refit_max_seconds: expected >= 0, got " +
                                std::to_string(refit_max_seconds));
  }
  if (!(nested_margin >= 0.0)) {
    throw std::invalid_argument("ScreeningOptions.nested_margin: expected >= 0, got " +
                                std::to_string(nested_margin));
  }
  if (refit_top < 0) {
    throw std::invalid_argument("ScreeningOptions.refit_top: expected >= 0, got " +
                                std::to_string(refit_top));
  }
  if (num_threads < 0) {
    throw std::invalid_argument("ScreeningOptions.num_threads: expected >= 0, got " +
                                std::to_string(num_threads));
  }
  if (!(tie_tolerance >= 0.0)) {
    throw std::invalid_argument("ScreeningOptions.tie_tolerance: expected >= 0, got " +
                                std::to_string(tie_tolerance));
  }
  candidates.Validate();
}

namespace internal {

void RankRefits(double tie, double margin, std::vector<RefitResult>* ranked) {
  std::vector<RefitResult>& refits = *ranked;
  auto group = [](const RefitResult& r) { return !r.ok ? 2 : r.at_bound ? 1 : 0; };
  // By group, then by validation NRMSE (failures keep their order). A comparator that called two
  // NRMSEs within the tie tolerance equal would not be an ordering (a ~ b and b ~ c with a < c),
  // so ties are settled afterwards: each run of re-fits of one group whose NRMSEs exceed the
  // run's first (best) one by at most `tie` of their own is ordered by BIC. Ok re-fits have finite
  // NRMSEs (a non-finite validation makes a re-fit fail).
  std::stable_sort(refits.begin(), refits.end(), [&](const RefitResult& a, const RefitResult& b) {
    if (group(a) != group(b)) return group(a) < group(b);
    if (group(a) == 2) return false;
    return a.validation_nrmse_after < b.validation_nrmse_after;
  });
  const std::size_t n = refits.size();
  for (std::size_t i = 0; i < n && group(refits[i]) != 2;) {
    const double best = refits[i].validation_nrmse_after;
    std::size_t j = i + 1;
    while (j < n && group(refits[j]) == group(refits[i]) &&
           refits[j].validation_nrmse_after - best <= tie * refits[j].validation_nrmse_after) {
      ++j;
    }
    std::stable_sort(refits.begin() + static_cast<std::ptrdiff_t>(i),
                     refits.begin() + static_cast<std::ptrdiff_t>(j),
                     [](const RefitResult& a, const RefitResult& b) { return a.bic < b.bic; });
    i = j;
  }
  // Parsimony between nested effects: where a re-fit's effect reduces to a simpler re-fitted one on
  // the same attachment (Candidate::reduces_to) that is worse by at most `margin`, the simpler one
  // takes its place and the general one follows it: the nested family ranks by its best member,
  // and is named by its simplest adequate one. The position is checked again after a move (the
  // simpler one may contain a simpler one still); a re-fit is never compared with itself, and the
  // moves are bounded besides.
  std::size_t moves = 0;
  for (std::size_t i = 0; i < n && group(refits[i]) == 0;) {
    bool moved = false;
    for (std::size_t j = i + 1; j < n; ++j) {
      const RefitResult& general = refits[i];
      const RefitResult& simple = refits[j];
      const std::vector<std::string>& r = general.candidate.reduces_to;
      if (group(simple) == 0 && simple.attachment == general.attachment &&
          std::find(r.begin(), r.end(), simple.effect) != r.end() &&
          simple.validation_nrmse_after - general.validation_nrmse_after <= margin) {
        std::rotate(refits.begin() + static_cast<std::ptrdiff_t>(i),
                    refits.begin() + static_cast<std::ptrdiff_t>(j),
                    refits.begin() + static_cast<std::ptrdiff_t>(j + 1));
        moved = true;
        break;
      }
    }
    if (!moved || ++moves > n * n) ++i;
  }
}

}  // namespace internal

double AutomaticRefitBudget(const est::FitResult& nominal) {
  return std::max(kAutoBudgetFactor * nominal.solve_thread_user_seconds, kAutoBudgetFloor);
}

Diagnosis ScreenAndRefit(const est::Problem& problem, const std::vector<est::SplitData>& splits,
                         const est::FitResult& nominal, const ScreeningOptions& options) {
  options.Validate();
  if (nominal.values.size() != problem.built.NumParameters()) {
    throw std::invalid_argument(
        "ScreenAndRefit: nominal has " + std::to_string(nominal.values.size()) +
        " parameter values; expected " + std::to_string(problem.built.NumParameters()) +
        " (the problem's model)");
  }
  Diagnosis d;
  d.validation_role = ValidationRole(splits);
  d.nominal_validation_nrmse = ValidationNrmse(nominal.evaluations, d.validation_role);
  InformationCriteria(nominal, &d.nominal_aic, &d.nominal_bic);
  // The ripple periods from the nominal residuals' periodogram against each axis' position.
  CandidateOptions candidate_options = options.candidates;
  const std::vector<std::string> wanted_effects = SelectedEffects(problem, candidate_options);
  if (candidate_options.ripple_periods.empty() && problem.diagnosis.ripple_periods.empty() &&
      std::find(wanted_effects.begin(), wanted_effects.end(), "ripple") != wanted_effects.end()) {
    for (const MechanicalAxis& axis : FindAxes(problem)) {
      if (axis.position.empty() ||
          candidate_options.ripple_periods_by_position.count(axis.position)) {
        continue;
      }
      const PeriodScan scan =
          ScanPeriods(problem.built, nominal, axis.position, !axis.prismatic, options.period_scan);
      if (scan.peaks.empty()) continue;
      candidate_options.ripple_periods_by_position[axis.position] = scan.peaks;
      d.ripple_periods[axis.position] = scan.peaks;
    }
  }
  const std::vector<Candidate> candidates = EnumerateCandidates(problem, candidate_options);
  std::mutex progress_mutex;
  auto report = [&](const std::string& line) {
    if (!options.progress) return;
    std::lock_guard<std::mutex> lock(progress_mutex);
    options.progress(line);
  };
  d.screened.resize(candidates.size());
  ParallelFor(static_cast<int>(candidates.size()), options.num_threads, [&](int i) {
    report("screening " + candidates[i].Name() + " (" + std::to_string(i + 1) + "/" +
           std::to_string(candidates.size()) + ")");
    d.screened[i] = Score(problem, splits, nominal, candidates[i]);
  });
  std::stable_sort(d.screened.begin(), d.screened.end(),
                   [](const CandidateScore& a, const CandidateScore& b) {
                     const bool fa = std::isfinite(a.score), fb = std::isfinite(b.score);
                     if (fa != fb) return fa;
                     return fa && a.score > b.score;
                   });
  std::vector<const CandidateScore*> to_refit;
  for (const CandidateScore& s : d.screened) {
    if (static_cast<int>(to_refit.size()) >= options.refit_top || !std::isfinite(s.score)) break;
    to_refit.push_back(&s);
  }
  // Structural candidates have no score: each is re-fitted (after the scored ones).
  for (const CandidateScore& s : d.screened) {
    if (s.candidate.structural && s.failure.empty()) to_refit.push_back(&s);
  }
  // The budget of each re-fit: as given, else automatic from this nominal fit.
  const double budget =
      options.refit_max_seconds > 0.0 ? options.refit_max_seconds : AutomaticRefitBudget(nominal);
  // Stage A of every re-fit side by side; stage B (the shape parameters freed) only for the
  // round's contenders (ScreeningOptions::contender_share), which are then finished side by side.
  const int n_refit = static_cast<int>(to_refit.size());
  d.refits.resize(to_refit.size());
  std::vector<std::unique_ptr<internal::RefitSteps>> runs(to_refit.size());
  const bool in_processes =
      options.refit_in_processes &&
      internal::RefitsInProcesses(problem, std::min(ResolvedThreads(options.num_threads), n_refit));
  ParallelFor(n_refit, options.num_threads, [&](int i) {
    report("re-fitting " + to_refit[i]->candidate.Name() + " (" + std::to_string(i + 1) + "/" +
           std::to_string(to_refit.size()) + ")" + (in_processes ? " in a process" : ""));
    if (in_processes) {
      try {
        runs[i] = std::make_unique<internal::RefitProcess>(problem, splits, nominal, *to_refit[i],
                                                           d.validation_role,
                                                           d.nominal_validation_nrmse, budget);
      } catch (const std::runtime_error& e) {
        report(to_refit[i]->candidate.Name() + ": " + e.what() + "; re-fitted in a thread");
      }
    }
    if (!runs[i]) {
      runs[i] = std::make_unique<internal::RefitRun>(problem, splits, nominal, *to_refit[i],
                                                     d.validation_role, d.nominal_validation_nrmse,
                                                     budget);
    }
    runs[i]->RunStageA();
    if (!runs[i]->HasShapeStage()) {
      d.refits[i] = runs[i]->Finish();
      runs[i].reset();
    }
  });
  double best_gain = 0.0;
  for (int i = 0; i < n_refit; ++i) {
    const RefitResult& r = runs[i] ? runs[i]->result() : d.refits[i];
    if (r.ok && !r.at_bound) {
      best_gain = std::max(best_gain, r.validation_nrmse_before - r.validation_nrmse_after);
    }
  }
  std::vector<int> contenders;
  for (int i = 0; i < n_refit; ++i) {
    if (!runs[i]) continue;
    const RefitResult& r = runs[i]->result();
    const double gain = r.validation_nrmse_before - r.validation_nrmse_after;
    // A structural candidate's stage A holds its own parameters at guesses, not at screened
    // values (no score test): only its stage B fits them, so it is always a contender.
    const bool structural = to_refit[i]->candidate.structural;
    if (r.ok && (structural || gain >= options.contender_share * best_gain)) {
      contenders.push_back(i);
    } else {
      char reason[160];
      std::snprintf(reason, sizeof(reason),
                    "not a contender of the round (validation NRMSE gain %.3g; the best's %.3g)",
                    gain, best_gain);
      runs[i]->HoldShapes(reason);
      d.refits[i] = runs[i]->Finish();
      runs[i].reset();
    }
  }
  ParallelFor(static_cast<int>(contenders.size()), options.num_threads, [&](int k) {
    const int i = contenders[k];
    report("freeing the shape of " + to_refit[i]->candidate.Name() + " (" + std::to_string(k + 1) +
           "/" + std::to_string(contenders.size()) + ")");
    runs[i]->RunStageB();
    d.refits[i] = runs[i]->Finish();
    runs[i].reset();
  });
  internal::RankRefits(options.tie_tolerance, options.nested_margin * d.nominal_validation_nrmse,
                       &d.refits);
  return d;
}

std::string Diagnosis::BriefReport() const {
  std::ostringstream o;
  if (!refits.empty() && refits.front().ok && !refits.front().at_bound) {
    const RefitResult& r = refits.front();
    o << "best: " << r.effect << " (" << r.detail << ") on " << r.attachment << ", "
      << validation_role << " NRMSE " << Format("%.4g", r.validation_nrmse_before) << " -> "
      << Format("%.4g", r.validation_nrmse_after) << " (" << Format("%.0f", 100.0 * r.relative_gain)
      << " % of it)";
  } else {
    o << "no successful re-fit";
  }
  o << "; screened " << screened.size() << ", re-fitted " << refits.size();
  return o.str();
}

std::string Diagnosis::FullReport() const {
  std::ostringstream o;
  o << BriefReport() << "\n";
  o << "nominal: " << validation_role << " NRMSE " << Format("%.4g", nominal_validation_nrmse)
    << ", AIC " << Format("%.1f", nominal_aic) << ", BIC " << Format("%.1f", nominal_bic) << "\n";
  o << "screening (score test at the neutral value):\n";
  char line[512];
  std::snprintf(line, sizeof(line), "  %-20s %-24s %-36s %12s %4s %10s\n", "effect", "detail",
                "attachment", "LM", "dof", "p");
  o << line;
  for (const CandidateScore& s : screened) {
    std::snprintf(line, sizeof(line), "  %-20s %-24s %-36s %12.4g %4d %10.3g%s\n",
                  s.candidate.effect.c_str(), s.candidate.detail.c_str(),
                  s.candidate.attachment.c_str(), s.score, s.dof, s.p_value,
                  s.restricted_solve ? "  (restricted solve)" : "");
    o << line;
    if (!s.failure.empty()) o << "    failed: " << s.failure << "\n";
  }
  o << "re-fits (ranked):\n";
  std::snprintf(line, sizeof(line), "  %-20s %-24s %10s %10s %8s %12s %12s  %s\n", "effect",
                "detail", "NRMSE", "after", "closed", "AIC", "BIC", "status");
  o << line;
  for (const RefitResult& r : refits) {
    const std::string status = !r.ok ? "FAILED: " + r.failure : r.at_bound ? "at bound" : "ok";
    std::snprintf(line, sizeof(line), "  %-20s %-24s %10.4g %10.4g %7.1f%% %12.1f %12.1f  %s\n",
                  r.effect.c_str(), r.detail.c_str(), r.validation_nrmse_before,
                  r.validation_nrmse_after, 100.0 * r.relative_gain, r.aic, r.bic, status.c_str());
    o << line;
    for (const std::string& stage : r.stages) o << "      " << stage << "\n";
    for (const auto& p : r.parameters) {
      std::snprintf(line, sizeof(line), "      %-32s %12.5g +- %-10.3g %s%s\n", p.name.c_str(),
                    p.value, p.std_error, p.unit.c_str(),
                    p.at_bound ? "  AT BOUND" : (p.free ? "" : "  (held)"));
      o << line;
    }
  }
  return o.str();
}

}  // namespace graybox::diagnosis
