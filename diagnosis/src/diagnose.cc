#include "graybox/diagnosis/diagnose.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The flexible reference's nice value (weight 110 against the rounds' 1024 on Linux).
constexpr int kReferenceNice = 10;

std::string Format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

std::string Percent(double fraction) { return Format("%.2g", 100.0 * fraction) + " %"; }

int NumFree(const est::FitResult& fit) {
  int k = 0;
  for (const auto& p : fit.parameters) k += p.free ? 1 : 0;
  return k;
}

class Stopwatch {
 public:
  double Lap() {
    const auto now = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return s;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// The likelihood-ratio test of step 3(b) between two nested least-squares fits; `chosen`
// parameters of `after` were estimated without being free in it (a structural candidate's held
// parameters, chosen by its grids).
void LikelihoodRatio(const est::FitResult& before, const est::FitResult& after, int chosen,
                     double* lr, double* p, int* dof) {
  *dof = NumFree(after) - NumFree(before) + chosen;
  const double n = after.num_residuals;
  const double rss0 = 2.0 * before.solver_result.cost;
  const double rss1 = 2.0 * after.solver_result.cost;
  if (!(n > 0.0) || !(rss0 > 0.0) || !(rss1 > 0.0) || *dof < 1) {
    *lr = kNaN;
    *p = kNaN;
    return;
  }
  *lr = n * std::log(rss0 / rss1);
  *p = ChiSquareSurvival(*lr, *dof);
}

// The place of the gap in words: the channel with the largest residual energy share and that
// channel's top-ranked entry with a positive score, preferring an operating regime (the most
// physical statement), then a time window, then a frequency band.
std::string Place(const Localization& loc) {
  if (loc.channels.empty()) return "the outputs";
  const ChannelResidual* worst = &loc.channels.front();
  for (const ChannelResidual& c : loc.channels) {
    if (c.energy_share > worst->energy_share) worst = &c;
  }
  std::string place = worst->name;
  for (const char* kind : {"regime", "window", "band"}) {
    const std::vector<LocalizationEntry> entries = loc.Entries(kind, worst->name);
    if (entries.empty() || !(entries.front().score > 0.0)) continue;
    const LocalizationEntry& e = entries.front();
    place += std::string(", ") +
             (e.kind == "window" ? "in "
              : e.kind == "band" ? "in the band "
                                 : "at ") +
             e.label + ": " + Percent(e.energy_share) + " of its residual energy in " +
             Percent(e.sample_share) + " of the " + (e.kind == "band" ? "spectrum" : "samples");
    break;
  }
  return place;
}

// The structured energy of a localisation (diagnose.h): mean over channels of NRMSE^2 max(0,
// r(1)); NaN without channels.
double StructuredEnergy(const Localization& loc) {
  if (loc.channels.empty()) return kNaN;
  double sum = 0.0;
  for (const ChannelResidual& c : loc.channels) {
    double r1 = 0.0;
    for (const Whiteness& w : loc.whiteness) {
      if (w.channel == c.name && !w.correlation.empty() && std::isfinite(w.correlation[0])) {
        r1 = w.correlation[0];
      }
    }
    sum += c.nrmse * c.nrmse * std::max(0.0, r1);
  }
  return sum / static_cast<double>(loc.channels.size());
}

std::string Verdict(const DiagnosisReport& d) {
  std::string v = "the gap lies in " + Place(d.nominal_localization) + "; ";
  if (d.accepted.empty()) {
    v += "not explained by the candidate library";
    if (!d.stop_reason.empty()) v += " (" + d.stop_reason + ")";
    return v;
  }
  // The shares of the gap only while the accepted effects end at or above the reference's error:
  // below it (at the noise floor with the reference, or an effect its static networks cannot
  // represent, such as a chamber's leak) the shares add up to more than 100 %, so the verdict
  // gives the shares of the nominal error and says that the whole gap is closed.
  const bool beyond_reference =
      std::isfinite(d.gap) && d.final_validation_nrmse < d.reference.validation_nrmse;
  const bool gap = std::isfinite(d.gap) && !beyond_reference;
  for (std::size_t i = 0; i < d.accepted.size(); ++i) {
    const AcceptedEffect& a = d.accepted[i];
    if (i > 0) v += i + 1 == d.accepted.size() ? " and " : ", ";
    std::string equally;
    for (const std::string& alt : a.alternatives) {
      const std::string effect = alt.substr(0, alt.find(' '));
      if (equally.find(effect) == std::string::npos && effect != a.effect) {
        equally += (equally.empty() ? "" : ", ") + effect;
      }
    }
    // Parameters without a finite interval, by their names in the block.
    std::string unidentified;
    for (const std::string& q : a.unidentified) {
      unidentified += (unidentified.empty() ? "" : ", ") + q.substr(q.rfind('.') + 1);
    }
    v += a.effect + " (" + a.detail + (equally.empty() ? "" : "; equally: " + equally) +
         (unidentified.empty() ? "" : "; not identified: " + unidentified) + ") " +
         (gap ? "closes " + Percent(a.gap_closed) : "removes " + Percent(a.error_share));
  }
  v += gap ? " of the gap (" : " of the " + d.validation_role + " NRMSE (";
  v += d.validation_role + " NRMSE " + Format("%.4g", d.nominal_validation_nrmse) + " -> " +
       Format("%.4g", d.final_validation_nrmse);
  if (gap) v += ", flexible reference " + Format("%.4g", d.reference.validation_nrmse);
  if (beyond_reference) {
    v += "; below the flexible reference's " + Format("%.4g", d.reference.validation_nrmse) +
         ": the whole gap closed";
  }
  v += ")";
  if (!d.explained) {
    v +=
        ", but the candidate library does not explain the gap: " + Percent(d.structured_remaining) +
        " of the residual's structured energy remains, in " + Place(d.remainder);
  }
  return v;
}

// DiagnosisReport::agreed_effects and agreement from the accepted effects and the sparse
// regression's proposal.
void Agreement(DiagnosisReport* d) {
  const SparseRegression& s = d->sparse_regression;
  std::vector<std::string> accepted, proposed;
  for (const AcceptedEffect& a : d->accepted) {
    if (std::find(accepted.begin(), accepted.end(), a.effect) == accepted.end()) {
      accepted.push_back(a.effect);
    }
  }
  for (const SparseEffect& e : s.effects) proposed.push_back(e.effect);
  auto list = [](const std::vector<std::string>& v) {
    std::string out;
    for (const auto& x : v) out += (out.empty() ? "" : ", ") + x;
    return out.empty() ? std::string("none") : out;
  };
  d->agreed_effects.clear();
  for (const auto& a : accepted) {
    if (std::find(proposed.begin(), proposed.end(), a) != proposed.end()) {
      d->agreed_effects.push_back(a);
    }
  }
  if (!s.ok) {
    d->agreement = "no independent proposal: " + s.BriefReport();
    return;
  }
  if (accepted.empty() && proposed.empty()) {
    d->agreement =
        "neither forward selection nor the sparse regression of the learned force "
        "names an effect";
    return;
  }
  d->agreement = "forward selection accepted " + list(accepted) +
                 "; the sparse regression of the learned force proposes " + list(proposed) +
                 (d->agreed_effects.empty() ? "; they share no effect"
                                            : "; both name " + list(d->agreed_effects));
  if (!accepted.empty() && !proposed.empty()) {
    d->agreement += accepted.front() == proposed.front()
                        ? " (and agree on the first)"
                        : " (first: " + accepted.front() + " against " + proposed.front() + ")";
  }
}

}  // namespace

void DiagnoseOptions::Validate() const {
  fit.Validate();
  localization.Validate();
  screening.Validate();
  reference.Validate();
  sparse_regression.Validate();
  if (max_effects < 0) {
    throw std::invalid_argument("DiagnoseOptions.max_effects: expected >= 0, got " +
                                std::to_string(max_effects));
  }
  if (!(significance > 0.0 && significance < 1.0)) {
    throw std::invalid_argument("DiagnoseOptions.significance: expected in (0, 1), got " +
                                Format("%g", significance));
  }
  if (!(max_structured_remaining > 0.0 && max_structured_remaining <= 1.0)) {
    throw std::invalid_argument(
        "DiagnoseOptions.max_structured_remaining: expected in (0, 1], got " +
        Format("%g", max_structured_remaining));
  }
  if (!(min_relative_gain >= 0.0 && min_relative_gain < 1.0)) {
    throw std::invalid_argument("DiagnoseOptions.min_relative_gain: expected in [0, 1), got " +
                                Format("%g", min_relative_gain));
  }
}

DiagnosisReport Diagnose(const est::Problem& problem, const std::vector<est::SplitData>& splits,
                         const DiagnoseOptions& options) {
  options.Validate();
  // The [diagnosis] table's effect names and named axes, before anything is computed.
  CheckDiagnosisSpec(problem);
  if (!problem.diagnosis.axes.empty()) FindAxes(problem);
  DiagnosisReport d;
  d.problem = problem.name;
  d.options = options;
  Stopwatch clock;
  // Progress comes from the screening's workers and from the reference's thread: one at a time.
  std::mutex progress_mutex;
  auto progress = [&](const std::string& line) {
    if (!options.progress) return;
    const std::lock_guard<std::mutex> lock(progress_mutex);
    options.progress(line);
  };

  progress("nominal fit of " + problem.name);
  est::FitOptions fit_options = options.fit;
  d.nominal = est::Fit(problem, splits, fit_options);
  if (!d.nominal.IsSolutionUsable()) {
    throw std::runtime_error("Diagnose: the nominal fit of '" + problem.name + "' failed (" +
                             d.nominal.solver_result.status + ": " +
                             d.nominal.solver_result.message +
                             "); a gap cannot be diagnosed around a failed fit");
  }
  {
    const std::string role = ValidationRole(splits);
    d.nominal_integration_warning = IntegrationCheck(problem, splits, d.nominal, role,
                                                     ValidationNrmse(d.nominal.evaluations, role));
    if (!d.nominal_integration_warning.empty()) {
      progress("nominal fit: " + d.nominal_integration_warning);
    }
  }
  d.seconds.emplace_back("nominal fit", clock.Lap());
  d.nominal_localization =
      Localize(problem.built, d.nominal.values, d.nominal.evaluations, options.localization);
  d.seconds.emplace_back("localisation", clock.Lap());
  d.gap = kNaN;
  // The flexible reference depends on the nominal fit only, and only the gap and the sparse
  // regression after the rounds need it: it is fitted on its own thread beside the rounds. Where
  // it does not solve with Ipopt (whose lock the re-fits share), at a lower scheduling priority,
  // so that it takes the cores the rounds leave idle (their re-fits wait for each other or for a
  // round's last re-fit) without slowing them; with Ipopt at the same priority, or a re-fit
  // waiting for its lock would wait for a thread that gets little CPU. Re-fit budgets are CPU
  // time, so the rounds' outcome does not change either way.
  // (Declared before the future: a round that throws leaves the future's destructor waiting for
  // the reference, which still writes its time.)
  double reference_seconds = 0.0;
  std::future<FlexibleReference> reference;
  if (options.fit_reference) {
    progress("flexible reference: networks on every mechanical axis (beside the rounds)");
    const bool lower_priority = FlexibleReferenceSolver(problem) != "ipopt";
    reference = std::async(std::launch::async, [&, lower_priority]() {
      // This thread only (Linux: a thread's nice value; threads it starts inherit it).
      if (lower_priority) {
        ::setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), kReferenceNice);
      }
      const auto t0 = std::chrono::steady_clock::now();
      FlexibleReference r = FitFlexibleReference(problem, splits, d.nominal, options.reference);
      reference_seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      progress(r.BriefReport());
      return r;
    });
  } else {
    d.reference.failure = "not fitted (DiagnoseOptions::fit_reference is false)";
    d.reference.validation_nrmse = kNaN;
  }

  est::Problem current = problem;
  std::vector<est::SplitData> current_splits = splits;
  est::FitResult current_fit = d.nominal;
  ScreeningOptions screening = options.screening;
  // One automatic budget for every round, from the problem's own nominal fit (a later round's
  // starting fit is an accepted re-fit, whose solve may itself have used a whole budget).
  if (screening.refit_max_seconds == 0.0) {
    screening.refit_max_seconds = AutomaticRefitBudget(d.nominal);
  }
  d.refit_budget_seconds = screening.refit_max_seconds;
  for (int round = 1;; ++round) {
    screening.progress = [&, round](const std::string& line) {
      progress("round " + std::to_string(round) + ": " + line);
    };
    SelectionRound r;
    r.round = round;
    r.screening = ScreenAndRefit(current, current_splits, current_fit, screening);
    if (round == 1) {
      d.validation_role = r.screening.validation_role;
      d.nominal_validation_nrmse = r.screening.nominal_validation_nrmse;
    }
    const double before = r.screening.nominal_validation_nrmse;
    const RefitResult* best = r.screening.refits.empty() ? nullptr : &r.screening.refits.front();
    if (best == nullptr || !best->ok) {
      r.reason = best == nullptr ? "no candidate could be re-fitted"
                                 : "no successful re-fit (" + best->failure + ")";
    } else {
      // A structural candidate's own parameters are estimated whether its re-fit freed them or
      // held them at its grids' choice, and so is the option its grid chose (the split); it may
      // hold a nominal parameter instead (the elastic split's body inertia), which NumFree
      // counts.
      int chosen = 0;
      if (best->candidate.structural) {
        for (const std::string& q : best->candidate.refit) {
          if (!best->fit.Parameter(q).free) ++chosen;
        }
        // The option its grid chose (the split).
        if (!best->candidate.option_grids.empty()) ++chosen;
      }
      int dof = 0;
      LikelihoodRatio(current_fit, best->fit, chosen, &r.lr_statistic, &r.lr_p_value, &dof);
      r.relative_gain = (before - best->validation_nrmse_after) / before;
      const std::string name = best->effect + " (" + best->detail + ")";
      if (best->at_bound) {
        r.reason = "best re-fit " + name + " ended at a bound";
      } else if (!(r.lr_p_value < options.significance)) {
        r.reason = "best re-fit " + name +
                   ": likelihood-ratio p = " + Format("%.3g", r.lr_p_value) +
                   " >= " + Format("%g", options.significance);
      } else if (!(r.relative_gain >= options.min_relative_gain)) {
        r.reason = "best re-fit " + name + ": " + d.validation_role + " NRMSE gain " +
                   Format("%.2f", 100.0 * r.relative_gain) + " % < " +
                   Format("%g", 100.0 * options.min_relative_gain) + " %";
      } else if (static_cast<int>(d.accepted.size()) >= options.max_effects) {
        r.reason = "max_effects = " + std::to_string(options.max_effects) + " reached";
      } else {
        r.accepted = true;
        AcceptedEffect a;
        a.round = round;
        a.effect = best->effect;
        a.detail = best->detail;
        a.attachment = best->attachment;
        a.instance = best->candidate.instance;
        a.validation_nrmse_before = before;
        a.validation_nrmse_after = best->validation_nrmse_after;
        a.shrinkage = before - best->validation_nrmse_after;
        a.error_share = a.shrinkage / d.nominal_validation_nrmse;
        a.lr_statistic = r.lr_statistic;
        a.lr_p_value = r.lr_p_value;
        a.dof = dof;
        a.parameters = best->parameters;
        for (const RefitResult& other : r.screening.refits) {
          if (&other == best || !other.ok || other.at_bound) continue;
          if (std::fabs(other.validation_nrmse_after - best->validation_nrmse_after) <=
              options.min_relative_gain * before) {
            a.alternatives.push_back(other.effect + " (" + other.detail + ") on " +
                                     other.attachment);
          }
        }
        d.accepted.push_back(a);
        // The effect's parameters stay free in the next rounds as they were in its re-fit: shape
        // parameters the re-fit held (stage B not kept, or not a contender) stay held, or every
        // later re-fit would free them from a start their own stage B did not accept (a held
        // Stribeck velocity freed in round 2 made every re-fit of a series elastic actuator's
        // second round fail: three in Ipopt's Restoration_Failed, two at the iteration limit).
        Candidate accepted = best->candidate;
        accepted.refit.clear();
        for (const std::string& q : best->candidate.refit) {
          if (best->fit.Parameter(q).free) accepted.refit.push_back(q);
        }
        current = AugmentedProblem(current, current_fit, accepted, true);
        // The re-fitted values are data of the built model: no second Build.
        for (int i = 0; i < current.built.NumParameters(); ++i) {
          models::ModelParameter& p = current.built.parameters[i];
          p.value = best->fit.values[i];
          current.model.Parameter(p.name).value = p.value;
        }
        current_splits = AugmentedSplits(current_splits, current.built.NumStates());
        current_fit = best->fit;
        progress("round " + std::to_string(round) + ": accepted " + name + ", " +
                 d.validation_role + " NRMSE " + Format("%.4g", before) + " -> " +
                 Format("%.4g", best->validation_nrmse_after));
      }
    }
    if (!r.accepted) progress("round " + std::to_string(round) + ": stop, " + r.reason);
    d.seconds.emplace_back("round " + std::to_string(round), clock.Lap());
    const bool go_on = r.accepted && static_cast<int>(d.accepted.size()) < options.max_effects;
    if (!r.accepted) d.stop_reason = r.reason;
    d.rounds.push_back(std::move(r));
    if (!go_on) break;
  }
  if (d.stop_reason.empty()) {
    d.stop_reason = "max_effects = " + std::to_string(options.max_effects) + " reached";
  }
  if (reference.valid()) {
    d.reference = reference.get();
    d.seconds.emplace_back("flexible reference (beside the rounds)", reference_seconds);
    if (d.reference.ok && d.reference.validation_nrmse < d.nominal_validation_nrmse) {
      d.gap = d.nominal_validation_nrmse - d.reference.validation_nrmse;
    }
  }
  for (AcceptedEffect& a : d.accepted) a.gap_closed = a.shrinkage / d.gap;  // NaN without a gap

  d.final_problem = current;
  d.final_fit = current_fit;
  for (AcceptedEffect& a : d.accepted) {
    for (est::FitParameter& p : a.parameters) {
      p = d.final_fit.Parameter(p.name);
      if (d.final_fit.has_uncertainty && p.free &&
          !(std::isfinite(p.ci_low) && std::isfinite(p.ci_high))) {
        a.unidentified.push_back(p.name);
      }
    }
  }
  d.final_validation_nrmse =
      d.accepted.empty() ? d.nominal_validation_nrmse : d.accepted.back().validation_nrmse_after;
  d.remaining_fraction = d.final_validation_nrmse / d.nominal_validation_nrmse;
  d.remainder = d.accepted.empty() ? d.nominal_localization
                                   : Localize(current.built, current_fit.values,
                                              current_fit.evaluations, options.localization);
  d.seconds.emplace_back("remainder", clock.Lap());
  SparseRegressionOptions sparse = options.sparse_regression;
  if (sparse.ripple_periods_by_position.empty() && !d.rounds.empty()) {
    sparse.ripple_periods_by_position = d.rounds.front().screening.ripple_periods;
  }
  d.sparse_regression = RegressLearnedForce(d.reference, sparse);
  if (d.sparse_regression.ok &&
      !(d.gap >= options.min_relative_gain * d.nominal_validation_nrmse)) {
    d.sparse_regression.effects.clear();
    d.sparse_regression.note =
        "the flexible reference lowers the " + d.validation_role + " NRMSE by less than " +
        Format("%g", 100.0 * options.min_relative_gain) + " %: its learned force is not a gap";
  }
  Agreement(&d);
  d.seconds.emplace_back("sparse regression", clock.Lap());
  d.structured_energy_nominal = StructuredEnergy(d.nominal_localization);
  d.structured_energy_final = StructuredEnergy(d.remainder);
  d.structured_remaining =
      d.accepted.empty() ? 1.0 : d.structured_energy_final / d.structured_energy_nominal;
  d.explained = !d.accepted.empty() && d.structured_remaining <= options.max_structured_remaining;
  d.verdict = Verdict(d);
  return d;
}

std::string DiagnosisReport::BriefReport() const {
  std::ostringstream o;
  o << verdict << "\n";
  o << validation_role << " NRMSE: nominal " << Format("%.4g", nominal_validation_nrmse)
    << ", final " << Format("%.4g", final_validation_nrmse) << " ("
    << Format("%.1f", 100.0 * remaining_fraction) << " % remains); " << accepted.size()
    << " effect(s) accepted in " << rounds.size() << " round(s); structured energy "
    << Format("%.4g", structured_energy_nominal) << " -> "
    << Format("%.4g", structured_energy_final) << " ("
    << Format("%.1f", 100.0 * structured_remaining) << " % remains; "
    << (explained ? "explained" : "not explained") << ")";
  if (!nominal_integration_warning.empty()) {
    o << "\nWARNING: nominal fit: " << nominal_integration_warning;
  }
  return o.str();
}

std::string DiagnosisReport::FullReport() const {
  std::ostringstream o;
  o << BriefReport() << "\n\n";
  o << "== nominal fit\n" << nominal.BriefReport() << "\n";
  if (!nominal_integration_warning.empty()) o << "WARNING: " << nominal_integration_warning << "\n";
  o << reference.BriefReport() << "; gap " << Format("%.4g", gap) << "\n\n";
  o << "== where the nominal gap lies\n" << nominal_localization.FullReport() << "\n";
  for (const SelectionRound& r : rounds) {
    o << "== round " << r.round << "\n" << r.screening.FullReport();
    o << (r.accepted ? "accepted" : "not accepted: " + r.reason);
    if (std::isfinite(r.lr_statistic)) {
      o << " (LR " << Format("%.4g", r.lr_statistic) << ", p " << Format("%.3g", r.lr_p_value)
        << ", " << validation_role << " NRMSE gain " << Format("%.2f", 100.0 * r.relative_gain)
        << " %)";
    }
    o << "\n\n";
  }
  o << "== accepted effects\n";
  if (accepted.empty()) o << "  none\n";
  char line[512];
  for (const AcceptedEffect& a : accepted) {
    std::snprintf(line, sizeof(line),
                  "  %d. %s (%s) on %s: %s NRMSE %.4g -> %.4g (%.1f %% of it), closes %.1f %% of "
                  "the gap, LR %.4g (dof %d, p %.3g)\n",
                  a.round, a.effect.c_str(), a.detail.c_str(), a.attachment.c_str(),
                  validation_role.c_str(), a.validation_nrmse_before, a.validation_nrmse_after,
                  100.0 * a.error_share, 100.0 * a.gap_closed, a.lr_statistic, a.dof, a.lr_p_value);
    o << line;
    for (const auto& p : a.parameters) {
      const bool unidentified =
          std::find(a.unidentified.begin(), a.unidentified.end(), p.name) != a.unidentified.end();
      std::snprintf(
          line, sizeof(line), "       %-32s %12.5g +- %-10.3g [%.5g, %.5g] %s%s\n", p.name.c_str(),
          p.value, p.std_error, p.ci_low, p.ci_high, p.unit.c_str(),
          p.free ? (unidentified ? "  (not identified: no finite interval)" : "") : "  (held)");
      o << line;
    }
  }
  o << "stop: " << stop_reason << "\n\n";
  o << "== unexplained remainder\n" << remainder.FullReport() << "\n";
  o << "== independent proposal\n" << sparse_regression.BriefReport() << "\n";
  for (const AxisRegression& a : sparse_regression.axes) {
    o << "  " << a.velocity << " -> " << a.force << ": learned force RMS "
      << Format("%.4g", a.learned_force_rms) << " ("
      << Format("%.1f", 100.0 * a.absorbed_by_nominal)
      << " % of its energy along the nominal parameters), R^2 " << Format("%.3f", a.r_squared)
      << " of the rest, " << a.samples << " samples\n";
    for (const SparseTerm& t : a.terms) {
      std::snprintf(line, sizeof(line), "    %-20s %-40s %12.5g  share %.3f\n", t.effect.c_str(),
                    t.shape.c_str(), t.coefficient, t.share);
      o << line;
    }
  }
  o << agreement << "\n\n";
  o << "== timings\n";
  for (const auto& [phase, s] : seconds) o << "  " << phase << ": " << Format("%.2f", s) << " s\n";
  return o.str();
}

}  // namespace graybox::diagnosis
