// diagnosis.json (nlohmann_json, insertion-ordered; NaN and Inf become null).
#include "graybox/diagnosis/report_json.h"

#include <nlohmann/json.hpp>

#include <cstdio>

#include "graybox/estimators/problem/augmentation_toml.h"

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;
using Json = nlohmann::ordered_json;

constexpr const char* kMetricDefinition =
    "validation_nrmse: mean over the validation splits (validation_role) of the mean over the "
    "output channels of NRMSE = RMSE / std(measured channel) of the free-run simulation";

Json ParameterJson(const est::FitParameter& p) {
  Json j;
  j["name"] = p.name;
  j["unit"] = p.unit;
  j["value"] = p.value;
  j["std_error"] = p.std_error;
  j["ci95"] = {p.ci_low, p.ci_high};
  j["bounds"] = {p.lower, p.upper};
  j["free"] = p.free;
  j["at_bound"] = p.at_bound;
  return j;
}

// The re-fitted candidate as problem-file text: its [[model.augment]] table (with the option the
// screening and the re-fit chose; empty for candidates without a declarative form,
// Candidate::augmentation) and the lines of [model.parameters] with the re-fitted values, free as
// in the re-fit.
std::string AugmentText(const RefitResult& f) {
  if (f.candidate.augmentation.type.empty()) return "";
  try {
    return est::AugmentationToml(f.candidate.augmentation);
  } catch (const std::exception&) {
    return "";
  }
}

std::string ParameterLines(const RefitResult& f) {
  std::string text;
  std::vector<est::FitParameter> lines;
  // A structural candidate's change of a model parameter it reads (the elastic split's body
  // inertia, held at the split) comes first: the re-run sets it.
  if (f.candidate.structural && f.fit.IsSolutionUsable()) {
    for (const auto& [option, parameter] : f.candidate.options_from_parameters) {
      for (const est::FitParameter& p : f.fit.parameters) {
        if (p.name == parameter) lines.push_back(p);
      }
    }
  }
  lines.insert(lines.end(), f.parameters.begin(), f.parameters.end());
  for (const est::FitParameter& p : lines) {
    char line[256];
    std::snprintf(line, sizeof(line), "\"%s\" = { value = %.10g, free = %s }\n", p.name.c_str(),
                  p.value, p.free ? "true" : "false");
    text += line;
  }
  return text;
}

Json ParametersJson(const std::vector<est::FitParameter>& parameters) {
  Json j = Json::array();
  for (const auto& p : parameters) j.push_back(ParameterJson(p));
  return j;
}

// The sparse regression's effects: [{effect, share}, ...].
Json EffectsJson(const std::vector<SparseEffect>& effects) {
  Json j = Json::array();
  for (const SparseEffect& e : effects) j.push_back({{"effect", e.effect}, {"share", e.share}});
  return j;
}

Json FitJson(const est::FitResult& fit) {
  Json j;
  j["method"] = fit.method;
  j["solver"] = fit.solver;
  j["status"] = fit.solver_result.status;
  j["usable"] = fit.IsSolutionUsable();
  j["iterations"] = fit.solver_result.iterations;
  j["cost"] = fit.solver_result.cost;
  j["num_residuals"] = fit.num_residuals;
  j["parameters"] = ParametersJson(fit.parameters);
  Json splits = Json::object();
  for (const est::SplitEvaluation& e : fit.evaluations) {
    Json s;
    s["role"] = est::SplitRoleName(e.role);
    s["simulation_ok"] = e.simulation_ok;
    s["nrmse"] = e.simulation.overall.nrmse;
    Json channels = Json::object();
    for (const auto& c : e.simulation.channels) channels[c.name] = c.nrmse;
    s["channel_nrmse"] = channels;
    splits[e.name] = s;
  }
  j["splits"] = splits;
  return j;
}

Json EntryJson(const LocalizationEntry& e) {
  Json j;
  j["channel"] = e.channel;
  j["kind"] = e.kind;
  j["partition"] = e.partition;
  j["signal"] = e.signal;
  j["label"] = e.label;
  j["energy_share"] = e.energy_share;
  j["sample_share"] = e.sample_share;
  j["concentration"] = e.concentration;
  j["score"] = e.score;
  j["range"] = {e.lower, e.upper};
  return j;
}

Json LocalizationJson(const Localization& loc) {
  Json j;
  j["splits"] = loc.splits;
  j["used_all_splits"] = loc.used_all_splits;
  j["num_samples"] = loc.num_samples;
  j["num_dropped"] = loc.num_dropped;
  Json channels = Json::array();
  for (const ChannelResidual& c : loc.channels) {
    Json cj;
    cj["name"] = c.name;
    cj["unit"] = c.unit;
    cj["scale"] = c.scale;
    cj["energy_share"] = c.energy_share;
    cj["nrmse"] = c.nrmse;
    channels.push_back(cj);
  }
  j["channels"] = channels;
  j["regime_signals"] = loc.regime_signals;
  Json entries = Json::array();
  for (const LocalizationEntry& e : loc.entries) entries.push_back(EntryJson(e));
  j["entries"] = entries;
  Json bands = Json::array();
  for (const BandEnergy& b : loc.bands) {
    Json bj;
    bj["channel"] = b.channel;
    bj["hz"] = {b.f_low, b.f_high};
    bj["residual_share"] = b.residual_share;
    bj["output_share"] = b.output_share;
    bj["power_ratio"] = b.power_ratio;
    bands.push_back(bj);
  }
  j["bands"] = bands;
  Json white = Json::array();
  for (const Whiteness& w : loc.whiteness) {
    Json wj;
    wj["channel"] = w.channel;
    wj["bound"] = w.bound;
    wj["fraction_outside"] = w.fraction_outside;
    wj["worst_lag"] = w.worst_lag;
    wj["autocorrelation"] = w.correlation;
    white.push_back(wj);
  }
  j["whiteness"] = white;
  Json cross = Json::array();
  for (const CrossCorrelation& c : loc.cross_correlations) {
    Json cj;
    cj["channel"] = c.channel;
    cj["input"] = c.input;
    cj["bound"] = c.bound;
    cj["fraction_outside"] = c.fraction_outside;
    cj["peak_lag"] = c.peak_lag;
    cj["peak"] = c.peak;
    cj["lags"] = c.lags;
    cj["correlation"] = c.correlation;
    cross.push_back(cj);
  }
  j["cross_correlation"] = cross;
  j["notes"] = loc.notes;
  return j;
}

Json RoundJson(const SelectionRound& r) {
  Json j;
  j["round"] = r.round;
  j["validation_nrmse_before"] = r.screening.nominal_validation_nrmse;
  Json periods = Json::object();
  for (const auto& [position, values] : r.screening.ripple_periods) periods[position] = values;
  j["ripple_periods"] = periods;
  Json screened = Json::array();
  for (const CandidateScore& s : r.screening.screened) {
    Json sj;
    sj["effect"] = s.candidate.effect;
    sj["detail"] = s.candidate.detail;
    sj["attachment"] = s.candidate.attachment;
    sj["instance"] = s.candidate.instance;
    sj["score"] = s.score;
    sj["dof"] = s.dof;
    sj["p_value"] = s.p_value;
    sj["restricted_solve"] = s.restricted_solve;
    sj["failure"] = s.failure;
    sj["one_step"] = s.one_step;
    Json shape = Json::object();
    for (const auto& [name, value] : s.shape_start) shape[name] = value;
    sj["shape_start"] = shape;
    screened.push_back(sj);
  }
  j["screened"] = screened;
  Json refits = Json::array();
  for (const RefitResult& f : r.screening.refits) {
    Json fj;
    fj["effect"] = f.effect;
    fj["detail"] = f.detail;
    fj["attachment"] = f.attachment;
    fj["ok"] = f.ok;
    fj["at_bound"] = f.at_bound;
    fj["failure"] = f.failure;
    fj["validation_nrmse_before"] = f.validation_nrmse_before;
    fj["validation_nrmse_after"] = f.validation_nrmse_after;
    fj["relative_gain"] = f.relative_gain;
    fj["aic"] = f.aic;
    fj["bic"] = f.bic;
    fj["score"] = f.score;
    fj["solver_status"] = f.fit.solver_result.status;
    fj["stages"] = f.stages;
    fj["augment_toml"] = AugmentText(f);
    fj["parameters_toml"] = ParameterLines(f);
    fj["parameters"] = ParametersJson(f.parameters);
    refits.push_back(fj);
  }
  j["refits"] = refits;
  j["accepted"] = r.accepted;
  j["reason"] = r.reason;
  j["lr_statistic"] = r.lr_statistic;
  j["lr_p_value"] = r.lr_p_value;
  j["relative_gain"] = r.relative_gain;
  return j;
}

}  // namespace

std::string DiagnosisJson(const DiagnosisReport& d,
                          const std::vector<std::pair<std::string, std::string>>& run) {
  Json j;
  j["schema"] = kDiagnosisJsonSchema;
  j["problem"] = d.problem;
  Json run_json = Json::object();
  for (const auto& [k, v] : run) run_json[k] = v;
  j["run"] = run_json;
  Json options;
  options["max_effects"] = d.options.max_effects;
  options["significance"] = d.options.significance;
  options["min_relative_gain"] = d.options.min_relative_gain;
  options["refit_top"] = d.options.screening.refit_top;
  options["num_threads"] = d.options.screening.num_threads;
  options["refit_in_processes"] = d.options.screening.refit_in_processes;
  options["tie_tolerance"] = d.options.screening.tie_tolerance;
  options["contender_share"] = d.options.screening.contender_share;
  options["refit_max_seconds"] = d.options.screening.refit_max_seconds;
  options["effects"] = d.options.screening.candidates.effects;
  options["fit_reference"] = d.options.fit_reference;
  options["max_structured_remaining"] = d.options.max_structured_remaining;
  options["reference"] = {{"hidden", d.options.reference.hidden},
                          {"max_steepness", d.options.reference.max_steepness},
                          {"train_hidden_layer", d.options.reference.train_hidden_layer},
                          {"weight_decay", d.options.reference.weight_decay},
                          {"position_network", d.options.reference.position_network},
                          {"seed", d.options.reference.seed}};
  const LocalizationOptions& lo = d.options.localization;
  options["localization"] = {{"num_windows", lo.num_windows},
                             {"num_bins", lo.num_bins},
                             {"near_zero_fraction", lo.near_zero_fraction},
                             {"reversal_samples", lo.reversal_samples},
                             {"max_lag", lo.max_lag},
                             {"num_bands", lo.num_bands},
                             {"confidence", lo.confidence}};
  j["options"] = options;
  j["metric"] = kMetricDefinition;
  j["validation_role"] = d.validation_role;
  j["verdict"] = d.verdict;
  j["explained"] = d.explained;
  Json nominal = FitJson(d.nominal);
  nominal["validation_nrmse"] = d.nominal_validation_nrmse;
  nominal["integration_warning"] = d.nominal_integration_warning;
  nominal["solve_thread_user_seconds"] = d.nominal.solve_thread_user_seconds;
  j["nominal"] = nominal;
  j["refit_budget_seconds"] = d.refit_budget_seconds;
  j["localization"] = LocalizationJson(d.nominal_localization);
  Json reference;
  reference["ok"] = d.reference.ok;
  reference["failure"] = d.reference.failure;
  reference["validation_nrmse"] = d.reference.validation_nrmse;
  reference["networks"] = d.reference.networks;
  reference["num_network_parameters"] = d.reference.num_network_parameters;
  reference["gap"] = d.gap;
  j["reference"] = reference;
  Json rounds = Json::array();
  for (const SelectionRound& r : d.rounds) rounds.push_back(RoundJson(r));
  j["rounds"] = rounds;
  Json accepted = Json::array();
  for (const AcceptedEffect& a : d.accepted) {
    Json aj;
    aj["effect"] = a.effect;
    aj["detail"] = a.detail;
    aj["attachment"] = a.attachment;
    aj["instance"] = a.instance;
    aj["round"] = a.round;
    aj["validation_nrmse_before"] = a.validation_nrmse_before;
    aj["validation_nrmse_after"] = a.validation_nrmse_after;
    aj["shrinkage"] = a.shrinkage;
    aj["error_share"] = a.error_share;
    aj["gap_closed"] = a.gap_closed;
    aj["lr_statistic"] = a.lr_statistic;
    aj["lr_p_value"] = a.lr_p_value;
    aj["dof"] = a.dof;
    aj["alternatives"] = a.alternatives;
    aj["parameters"] = ParametersJson(a.parameters);
    aj["unidentified"] = a.unidentified;
    accepted.push_back(aj);
  }
  j["accepted"] = accepted;
  j["stop_reason"] = d.stop_reason;
  Json remainder;
  remainder["validation_nrmse"] = d.final_validation_nrmse;
  remainder["remaining_fraction"] = d.remaining_fraction;
  remainder["structured_energy_nominal"] = d.structured_energy_nominal;
  remainder["structured_energy_final"] = d.structured_energy_final;
  remainder["structured_remaining"] = d.structured_remaining;
  remainder["final_fit"] = FitJson(d.final_fit);
  remainder["localization"] = LocalizationJson(d.remainder);
  j["remainder"] = remainder;
  const SparseRegression& sr = d.sparse_regression;
  Json sparse;
  sparse["ok"] = sr.ok;
  sparse["failure"] = sr.failure;
  sparse["note"] = sr.note;
  sparse["threshold"] = d.options.sparse_regression.threshold;
  sparse["effects"] = EffectsJson(sr.effects);
  sparse["axes"] = Json::array();
  for (const AxisRegression& a : sr.axes) {
    Json aj;
    aj["velocity"] = a.velocity;
    aj["force"] = a.force;
    aj["samples"] = a.samples;
    aj["learned_force_rms"] = a.learned_force_rms;
    aj["absorbed_by_nominal"] = a.absorbed_by_nominal;
    aj["r_squared"] = a.r_squared;
    aj["terms"] = Json::array();
    for (const SparseTerm& t : a.terms) {
      aj["terms"].push_back({{"effect", t.effect},
                             {"shape", t.shape},
                             {"coefficient", t.coefficient},
                             {"share", t.share}});
    }
    aj["effects"] = EffectsJson(a.effects);
    sparse["axes"].push_back(aj);
  }
  sparse["agreed_effects"] = d.agreed_effects;
  sparse["agreement"] = d.agreement;
  j["sparse_regression"] = sparse;
  Json seconds = Json::object();
  for (const auto& [phase, s] : d.seconds) seconds[phase] = s;
  j["seconds"] = seconds;
  return j.dump(2);
}

}  // namespace graybox::diagnosis
