// The commands: parse the problem, call the library (estimators::Fit, estimators::Simulate) and
// write what it returns. Nothing is written before the problem and its data have been validated;
// outputs are written atomically, result.json last.
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include "app.h"
#include "graybox/bench/withheld_bench.h"
#include "graybox/diagnosis/diagnose.h"
#include "graybox/diagnosis/report_html.h"
#include "graybox/diagnosis/report_json.h"
#include "graybox/models/block_description.h"
#include "report.h"

namespace graybox::app {

using estimators::Problem;
using estimators::SplitData;

void Progress(const std::string& line) { std::cout << Printable(line) << std::endl; }

std::string Sci(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

int Guarded(const std::function<int()>& body) {
  try {
    return body();
  } catch (const std::invalid_argument& e) {
    std::cerr << "graybox: error: " << Printable(e.what()) << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "graybox: internal error: " << Printable(e.what()) << "\n";
    return kExitInternalError;
  }
}

std::function<void(const std::string&)> StampedProgress(const Timer& total,
                                                        const std::string& indent) {
  return [&total, indent](const std::string& line) {
    char stamp[32];
    std::snprintf(stamp, sizeof stamp, "[%7.1f s] ", total.Seconds());
    Progress(indent + stamp + line);
  };
}

std::vector<std::pair<std::string, std::string>> RunMetadata(const CommandOptions& o) {
  return {{"command_line", o.command_line}, {"revision", GitRevision()}, {"version", Version()}};
}

namespace {

// Runs a stage that formulates and solves `problem`: a std::invalid_argument it raises (estimation
// data that cannot determine the free parameters, a filter the record cannot take) is reported at
// the problem file's [estimation] table, as the loader reports its own errors (file:line:column).
template <typename Fn>
auto AtEstimation(const Problem& problem, Fn&& fn) -> decltype(fn()) {
  try {
    return fn();
  } catch (const estimators::ProblemFileError&) {
    throw;
  } catch (const std::invalid_argument& e) {
    estimators::SourceLocation where = problem.estimation.where;
    if (where.file.empty()) where.file = problem.path;
    if (where.table.empty()) where.table = "estimation";
    throw estimators::ProblemFileError(where, e.what());
  }
}

void PrintProblem(const Problem& problem, const std::vector<SplitData>& splits) {
  const models::StateSpaceModel& m = problem.built;
  int free = 0;
  for (const auto& p : m.parameters) free += p.free ? 1 : 0;
  Progress("  model '" + m.name + "': " + std::to_string(m.NumStates()) + " states, " +
           std::to_string(m.NumInputs()) + " inputs, " + std::to_string(m.NumOutputs()) +
           " outputs, " + std::to_string(m.NumParameters()) + " parameters (" +
           std::to_string(free) + " free)");
  for (const SplitData& s : splits) {
    Progress("  split '" + s.name + "' (" + estimators::SplitRoleName(s.role) + ") from data '" +
             s.data_name + "': samples " + std::to_string(s.begin) + ".." +
             std::to_string(s.begin + s.experiment.NumSamples()) + " at " + Sci(s.experiment.dt) +
             " s");
  }
}

void Finish(RunOutput* out, const std::string& json_name, RunReport* report, const Timer& total) {
  report->seconds.emplace_back("total", total.Seconds());
  const auto written = WriteOutputs(out->path(), json_name, *report);
  const std::string what = out->Commit();
  Progress("  wrote " + json_name + " and " + std::to_string(written.size() - 1) +
           " plots and traces: " + what);
}

std::string Join(const std::vector<std::string>& words, const std::string& separator) {
  std::string s;
  for (const auto& w : words) s += (s.empty() ? "" : separator) + w;
  return s;
}

// The diagnosis options the command line sets (shared by diagnose and bench withheld).
diagnosis::DiagnoseOptions DiagnoseOptionsFrom(const CommandOptions& o) {
  diagnosis::DiagnoseOptions options;
  options.max_effects = o.max_effects;
  options.screening.refit_top = o.refit_top;
  options.screening.num_threads = o.threads;
  options.screening.candidates.effects = o.effects;
  options.fit_reference = !o.no_reference;
  options.screening.refit_max_seconds = o.refit_seconds;
  options.screening.refit_in_processes = o.refit_in_processes;
  return options;
}

}  // namespace

int RunFit(const CommandOptions& o) {
  return Guarded([&]() -> int {
    const Timer total;
    RunReport report;
    report.command = "fit";
    report.command_line = o.command_line;
    Timer t;
    Problem problem = estimators::LoadProblem(o.problem);
    report.problem = &problem;
    report.seed = problem.estimation.seed;
    Progress("graybox fit: problem '" + problem.name + "' (" + o.problem + ")");
    RunOutput out(o.out);
    if (!o.params.empty()) {
      // --from: the starting values of an earlier run (a candidate the diagnosis tried, a fit
      // to continue); which parameters are free and their bounds stay the problem file's.
      const std::map<std::string, double> values = LoadParameterValues(o.params, problem.built);
      for (const auto& [name, value] : values) {
        models::ModelParameter& p = problem.built.parameters[problem.built.ParameterIndex(name)];
        p.value = value;
        problem.model.SetParameter(name, value);
      }
      report.parameter_file = o.params;
      Progress("  starting from " + std::to_string(values.size()) + " parameter values of " +
               o.params);
    }
    const std::vector<SplitData> splits = estimators::LoadData(problem);
    CheckSplitFileNames(splits);
    PrintProblem(problem, splits);
    report.seconds.emplace_back("load", t.Seconds());
    estimators::FitOptions options;
    options.verbose = o.verbose;
    options.check_derivatives = o.check_derivatives;
    options.max_solve_seconds = o.max_seconds;
    options.progress = Progress;
    report.fit = AtEstimation(problem, [&] { return estimators::Fit(problem, splits, options); });
    report.has_fit = true;
    const estimators::FitResult& fit = report.fit;
    for (const auto& phase : fit.seconds) report.seconds.push_back(phase);
    report.initial_parameters = problem.built.ParameterValues();
    report.parameters = fit.values;
    report.evaluations = fit.evaluations;
    report.derivative_checks = fit.derivative_checks;
    if (fit.has_uncertainty) {
      std::cout << Printable(fit.uncertainty.FullReport());
    } else {
      Progress("  no parameter uncertainty: " + fit.uncertainty_error);
    }
    if (!fit.solver_result.success) {
      report.status = "solver_failure";
      report.exit_code = kExitSolverFailure;
      report.message = fit.solver_result.message.empty()
                           ? "the solver stopped with status " + fit.solver_result.status
                           : fit.solver_result.message;
    }
    Finish(&out, "result.json", &report, total);
    if (report.exit_code != kExitSuccess) {
      std::cerr << "graybox: solver failure: " << Printable(report.message) << "\n";
    }
    return report.exit_code;
  });
}

int RunSimulate(const CommandOptions& o) {
  return Guarded([&]() -> int {
    const Timer total;
    RunReport report;
    report.command = "simulate";
    report.command_line = o.command_line;
    report.parameter_file = o.params;
    Timer t;
    const Problem problem = estimators::LoadProblem(o.problem);
    report.problem = &problem;
    Progress("graybox simulate: problem '" + problem.name + "' (" + o.problem + ")");
    RunOutput out(o.out);
    const std::map<std::string, double> values = LoadParameterValues(o.params, problem.built);
    const std::vector<SplitData> splits = estimators::LoadData(problem);
    CheckSplitFileNames(splits);
    PrintProblem(problem, splits);
    report.seconds.emplace_back("load", t.Seconds());
    report.initial_parameters = problem.built.ParameterValues();
    report.parameters = report.initial_parameters;
    for (const auto& [name, value] : values) {
      report.parameters[problem.built.ParameterIndex(name)] = value;
    }
    Progress("  " + std::to_string(values.size()) + " parameter values from " + o.params);
    if (o.check_derivatives && !splits.empty()) {
      Progress("  derivative checks at the given parameters (split '" + splits[0].name + "'):");
      report.derivative_checks =
          estimators::CheckModelDerivatives(problem, splits[0], report.parameters);
      for (const auto& line : report.derivative_checks) Progress("  " + line.report);
    }
    t = Timer();
    report.evaluations = estimators::Simulate(problem, splits, report.parameters);
    for (const estimators::SplitEvaluation& e : report.evaluations) {
      Progress("  " + e.BriefReport());
      if (!e.simulation_ok && report.exit_code == kExitSuccess) {
        report.status = "simulation_failure";
        report.exit_code = kExitSolverFailure;
        report.message = "the simulation of split '" + e.name + "' diverged at sample " +
                         std::to_string(e.failed_at);
      }
    }
    report.seconds.emplace_back("simulate", t.Seconds());
    Finish(&out, "simulation.json", &report, total);
    if (report.exit_code != kExitSuccess) {
      std::cerr << "graybox: " << Printable(report.message) << "\n";
    }
    return report.exit_code;
  });
}

int RunDiagnose(const CommandOptions& o) {
  return Guarded([&]() -> int {
    const Timer total;
    const Problem problem = estimators::LoadProblem(o.problem);
    Progress("graybox diagnose: problem '" + problem.name + "' (" + o.problem + ")");
    RunOutput out(o.out);
    diagnosis::DiagnoseOptions options = DiagnoseOptionsFrom(o);
    options.Validate();
    const std::vector<SplitData> splits = estimators::LoadData(problem);
    CheckSplitFileNames(splits);
    PrintProblem(problem, splits);
    options.progress = StampedProgress(total, "  ");
    const diagnosis::DiagnosisReport d =
        AtEstimation(problem, [&] { return diagnosis::Diagnose(problem, splits, options); });
    std::cout << Printable(d.FullReport());
    namespace fs = std::filesystem;
    std::vector<std::pair<std::string, std::string>> run = RunMetadata(o);
    run.emplace_back("seed", std::to_string(problem.estimation.seed));
    WriteFileAtomically((fs::path(out.path()) / "report.html").string(),
                        diagnosis::DiagnosisHtml(d, run));
    WriteFileAtomically((fs::path(out.path()) / "diagnosis.json").string(),
                        diagnosis::DiagnosisJson(d, run));
    const std::string what = out.Commit();
    Progress("verdict: " + d.verdict);
    Progress("  wrote diagnosis.json and report.html: " + what + " (" + Sci(total.Seconds()) +
             " s)");
    return kExitSuccess;
  });
}

int RunBenchWithheld(const CommandOptions& o) {
  return Guarded([&]() -> int {
    const Timer total;
    RunOutput out(o.out);
    bench::WithheldBenchOptions options;
    options.cases.fast_subset = o.fast;
    options.name_filters = o.cases;
    options.diagnose = DiagnoseOptionsFrom(o);
    options.Validate();
    options.progress = StampedProgress(total, "");
    Progress("graybox bench withheld" + std::string(o.fast ? " (fast subset)" : ""));
    const bench::WithheldBench b = bench::RunWithheldBench(options);
    std::cout << "confusion (rows: withheld, columns: top-ranked):\n"
              << Printable(b.ConfusionTable() + b.Summary());
    namespace fs = std::filesystem;
    fs::create_directories(fs::path(out.path()) / "cases");
    for (const bench::WithheldRecord& r : b.records) {
      if (r.diagnosis_json.empty()) continue;
      std::string file = r.name;
      for (std::size_t p = file.find('/'); p != std::string::npos; p = file.find('/', p)) {
        file.replace(p, 1, "__");
      }
      WriteFileAtomically((fs::path(out.path()) / "cases" / (file + ".json")).string(),
                          r.diagnosis_json);
    }
    // bench.json last: a reader that finds it finds every case's diagnosis too.
    WriteFileAtomically((fs::path(out.path()) / "bench.json").string(),
                        bench::WithheldBenchJson(b, RunMetadata(o)));
    Progress("wrote bench.json and the cases' diagnoses: " + out.Commit());
    return kExitSuccess;
  });
}

int RunCheck(const CommandOptions& o) {
  return Guarded([&]() -> int {
    const Problem problem = estimators::LoadProblem(o.problem);
    Progress("graybox check: problem '" + problem.name + "' (" + o.problem + ")");
    const std::vector<SplitData> splits = estimators::LoadData(problem);
    CheckSplitFileNames(splits);
    PrintProblem(problem, splits);
    const models::StateSpaceModel& m = problem.built;
    for (const auto& p : m.parameters) {
      Progress("    " + p.name + " = " + Sci(p.value) + " " + p.info.unit +
               (p.free ? "  free in [" + Sci(p.lower) + ", " + Sci(p.upper) + "]" : "  fixed"));
    }
    if (o.check_derivatives && !splits.empty()) {
      for (const auto& line :
           estimators::CheckModelDerivatives(problem, splits[0], m.ParameterValues())) {
        Progress("  " + line.report);
      }
    }
    if (problem.diagnosis.where.count("")) {
      // The [diagnosis] table: its effect names, and the axes and effects the diagnosis uses.
      diagnosis::CheckDiagnosisSpec(problem);
      for (const auto& axis : diagnosis::FindAxes(problem)) {
        Progress("  diagnosis axis: velocity " + axis.velocity + ", force " + axis.connection +
                 (axis.position.empty() ? "" : ", position " + axis.position) +
                 (axis.inputs.empty() ? "" : ", actuators " + Join(axis.inputs, ", ")));
      }
      diagnosis::CandidateOptions none;
      Progress("  diagnosis effects: " + Join(diagnosis::SelectedEffects(problem, none), ", "));
    }
    Progress("  OK: method " + problem.estimation.method + " with " + problem.estimation.solver);
    return kExitSuccess;
  });
}

int RunBlocks(const CommandOptions& o) {
  return Guarded([&]() -> int {
    if (o.block_type.empty()) {
      if (!o.block_options.empty()) {
        throw std::invalid_argument("--option: expected a block TYPE to apply it to, got none");
      }
      std::cout << models::ListBlocks();
      return kExitSuccess;
    }
    models::BlockOptions options;
    for (const std::string& item : o.block_options) {
      const std::size_t eq = item.find('=');
      if (eq == std::string::npos || eq == 0) {
        throw std::invalid_argument("--option '" + item + "': expected key=value");
      }
      const std::string key = item.substr(0, eq), value = item.substr(eq + 1);
      std::vector<double> numbers;
      std::stringstream list(value);
      std::string piece;
      bool all_numbers = !value.empty();
      while (all_numbers && std::getline(list, piece, ',')) {
        char* end = nullptr;
        const double v = std::strtod(piece.c_str(), &end);
        all_numbers = !piece.empty() && end != nullptr && *end == '\0' && std::isfinite(v);
        numbers.push_back(v);
      }
      if (all_numbers) {
        options.numbers[key] = numbers;
      } else {
        options.words[key] = value;
      }
    }
    std::cout << Printable(models::DescribeBlock(o.block_type, options));
    return kExitSuccess;
  });
}

}  // namespace graybox::app
