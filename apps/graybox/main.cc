// graybox: the command-line tool. This is the only translation unit that includes CLI11 (about
// 6.5 s of compile time); the commands live in apps/src.
//
//   graybox fit PROBLEM --out DIR [--from RESULT] [--verbose] [--check-derivatives]
//   graybox simulate PROBLEM --params FILE --out DIR [--check-derivatives]
//   graybox check PROBLEM [--check-derivatives]
//   graybox diagnose PROBLEM --out DIR [--max-effects N] [--refit-top N] [--threads N]
//                    [--effects a,b,...]
//   graybox bench SUITE --out DIR [--jobs N] [--shard K/N [--costs FILE]] [--filter GLOB]
//                 [--seed S] [--resume DIR0]
//   graybox bench SUITE --slurm --shards N --out DIR [--array-parallel P] [--partition P]
//                 [--time LIMIT] [--slurm-script-only] [...]
//   graybox bench case SUITE --case ID --record FILE [--seed S]
//   graybox bench merge DIR1 DIR2 ... --out DIR
//   graybox bench baseline DIR --out FILE
//   graybox bench compare DIR --baseline FILE [--suite SUITE]
//   graybox bench withheld --out DIR [--fast] [--cases s1,s2] [--max-effects N] [--refit-top N]
//                          [--threads N] [--effects a,b,...]
//
// Exit codes: 0 success, 1 internal error, 2 bad input (nothing written), 3 solver failure
// (result.json written, its status says why). See docs/problem-format.md.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <iostream>
#include <string>
#include <vector>

#include "../src/app.h"
#include "graybox/util/did_you_mean.h"

namespace {

// The options of the diagnosis, shared by `diagnose` and `bench withheld`.
void AddDiagnosisOptions(CLI::App* cmd, graybox::app::CommandOptions* o) {
  cmd->add_option("--max-effects", o->max_effects,
                  "most effects forward selection accepts (default 3)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--refit-top", o->refit_top,
                  "candidates re-fitted per round, best by score first (default 5)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--threads", o->threads,
                  "threads for screening and re-fits (default 0: one per hardware thread)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--effects", o->effects,
                  "candidate effects to propose, comma-separated (default: every effect but "
                  "elasticity)")
      ->delimiter(',');
  cmd->add_option(
         "--refit-seconds", o->refit_seconds,
         "user CPU-time budget of each re-fit in seconds, over all its solves (default 0: 25 x the "
         "nominal solve's user CPU time, at least 10 s); a re-fit whose first stage it stops is "
         "reported as not converged")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--refit-in-processes", o->refit_in_processes,
                "where the problem is solved by Ipopt (not thread-safe), re-fit in one child "
                "process per re-fit so that the solves run side by side (default: threads, "
                "whose Ipopt solves wait for each other; see docs/performance.md)");
  cmd->add_flag("--no-reference", o->no_reference,
                "skip the flexible reference (no gap, no 'gap closed'; saves its fit, which "
                "dominates on long multi-axis records)");
}

}  // namespace

int main(int argc, char** argv) {
  using graybox::app::CommandOptions;
  std::string command_line;
  for (int i = 0; i < argc; ++i) command_line += (i ? " " : "") + std::string(argv[i]);

  CLI::App app{"graybox: gray-box identification of mechatronic systems from problem files"};
  app.require_subcommand(1);
  app.set_version_flag(
      "--version", std::string(graybox::app::Version()) + " (" + graybox::app::GitRevision() + ")");
  CommandOptions fit, simulate, check, diagnose, withheld, blocks;
  for (CommandOptions* o : {&fit, &simulate, &check, &diagnose, &withheld}) {
    o->command_line = command_line;
  }

  CLI::App* fit_cmd = app.add_subcommand("fit", "identify the parameters of a problem file");
  fit_cmd->add_option("problem", fit.problem, "problem file (TOML)")->required();
  fit_cmd->add_option("--out,-o", fit.out, "output directory (result.json, plots/, traces/)")
      ->required();
  fit_cmd->add_option("--from", fit.params,
                      "start from the parameter values of an earlier result.json (or a TOML "
                      "table \"inst.param\" = value); free/fixed and bounds stay the file's");
  fit_cmd->add_flag("--verbose,-v", fit.verbose, "print the solver's iterations");
  fit_cmd
      ->add_option("--max-seconds", fit.max_seconds,
                   "wall-time limit of the solve in seconds (default 0: the problem's "
                   "[estimation] max_seconds, else none); a solve that reaches it ends with "
                   "exit 3 and its outputs written")
      ->check(CLI::NonNegativeNumber);
  fit_cmd->add_flag("--check-derivatives", fit.check_derivatives,
                    "check the derivatives of the model and of the assembled NLP by finite "
                    "differences before solving");

  CLI::App* sim_cmd =
      app.add_subcommand("simulate", "simulate every split of a problem with given parameters");
  sim_cmd->add_option("problem", simulate.problem, "problem file (TOML)")->required();
  sim_cmd
      ->add_option("--params,-p", simulate.params,
                   "parameter values: a result.json or a TOML table \"inst.param\" = value")
      ->required();
  sim_cmd
      ->add_option("--out,-o", simulate.out,
                   "output directory (simulation.json, plots/, "
                   "traces/)")
      ->required();
  sim_cmd->add_flag("--check-derivatives", simulate.check_derivatives,
                    "check the model's derivatives by finite differences");

  CLI::App* check_cmd =
      app.add_subcommand("check", "parse a problem file and read its data without solving");
  check_cmd->add_option("problem", check.problem, "problem file (TOML)")->required();
  check_cmd->add_flag("--check-derivatives", check.check_derivatives,
                      "check the model's derivatives by finite differences");

  CLI::App* diagnose_cmd = app.add_subcommand(
      "diagnose",
      "find where the model's simulation error lies, which unmodelled effect causes it and how "
      "far it shrinks once the effect is added");
  diagnose_cmd->add_option("problem", diagnose.problem, "problem file (TOML)")->required();
  diagnose_cmd->add_option("--out,-o", diagnose.out, "output directory (diagnosis.json)")
      ->required();
  AddDiagnosisOptions(diagnose_cmd, &diagnose);

  CLI::App* blocks_cmd = app.add_subcommand(
      "blocks",
      "list the registered block types, or describe one: its inputs, outputs, states, parameters "
      "(units, bounds, neutral values) and equations");
  blocks_cmd->add_option("type", blocks.block_type,
                         "block type to describe (e.g. friction.coulomb)");
  blocks_cmd->add_option("--option", blocks.block_options,
                         "a block option key=value (numbers: key=1 or key=1,2; else a word); "
                         "repeatable");

  CommandOptions bench, bench_case, merge, baseline, compare;
  CLI::App* bench_cmd = app.add_subcommand(
      "bench",
      "run a suite of problems and variations, each case in its own process (docs/bench.md): "
      "DIR/bench.json, bench.csv, bench.md; or a benchmark of the library (withheld)");
  bench_cmd->require_subcommand(0, 1);
  bench_cmd->add_option("suite", bench.suite, "suite file (TOML) or folder of problem files");
  bench_cmd->add_option("--out,-o", bench.out, "output directory (bench.json)");
  bench_cmd->add_option("--jobs,-j", bench.jobs, "cases at a time (default 1)")
      ->check(CLI::PositiveNumber);
  bench_cmd->add_option("--shard", bench.shard,
                        "run the K-th of N parts of the cases, K/N (balanced, deterministic)");
  bench_cmd->add_option("--filter", bench.filter,
                        "only the cases whose id matches this glob ('*': any characters)");
  bench_cmd
      ->add_option("--seed", bench.seed,
                   "run every case once with this seed (the fit's and the perturbation's) in "
                   "place of the suite's seeds")
      ->check(CLI::Range(0L, 4294967295L));
  bench_cmd->add_option("--costs", bench.costs,
                        "balance --shard by the case times of an earlier output or baseline "
                        "(bench.json); cases it lacks cost its median");
  bench_cmd->add_flag("--slurm", bench.slurm,
                      "run the suite on a Slurm cluster: a job array of --shards N tasks (one "
                      "shard each, into DIR/shards/K) and a merge job after it (DIR/merged); "
                      "DIR on the file system the nodes share");
  bench_cmd->add_option("--shards", bench.shards, "--slurm: the array's tasks (shards)")
      ->check(CLI::PositiveNumber);
  bench_cmd
      ->add_option("--array-parallel", bench.array_parallel,
                   "--slurm: array tasks at a time (default 0: as the scheduler allows)")
      ->check(CLI::NonNegativeNumber);
  bench_cmd->add_option("--partition", bench.partition, "--slurm: sbatch --partition");
  bench_cmd->add_option("--time", bench.time_limit,
                        "--slurm: sbatch --time of each task and the merge (e.g. 02:00:00)");
  bench_cmd->add_flag("--slurm-script-only", bench.slurm_script_only,
                      "--slurm: write DIR/slurm/bench_array.sh and bench_merge.sh, do not "
                      "submit them");
  bench_cmd->add_option("--resume", bench.resume,
                        "an earlier output folder of this suite (same --shard and --filter): "
                        "its recorded cases are kept, the rest run (--out defaults to it)");
  CLI::App* merge_cmd = bench_cmd->add_subcommand(
      "merge",
      "join shard outputs (--shard K/N runs) into one: every shard once, records in the "
      "suite's order");
  merge_cmd->add_option("dirs", merge.inputs, "the shards' output folders")->required();
  merge_cmd->add_option("--out,-o", merge.out, "output directory (bench.json)")->required();
  CLI::App* baseline_cmd = bench_cmd->add_subcommand(
      "baseline",
      "write a run's results as the baseline file that bench compare reads (the one "
      "command that regenerates a baseline)");
  baseline_cmd->add_option("dir", baseline.inputs, "the run's output folder")
      ->required()
      ->expected(1);
  baseline_cmd->add_option("--out,-o", baseline.out, "baseline file (JSON)")->required();
  CLI::App* compare_cmd = bench_cmd->add_subcommand(
      "compare",
      "compare a run with a baseline within the suite's tolerances: every value "
      "outside them, new failures, missing cases, time regressions; exit 4 on any");
  compare_cmd->add_option("dir", compare.inputs, "the run's output folder (or bench.json)")
      ->required()
      ->expected(1);
  compare_cmd->add_option("--baseline", compare.baseline, "baseline file")->required();
  compare_cmd->add_option("--suite", compare.suite,
                          "read the tolerances from this suite file (default: the suite as the "
                          "run read it)");
  CLI::App* case_cmd = bench_cmd->add_subcommand(
      "case", "run one case of a suite in this process and write its record (what bench runs)");
  case_cmd->add_option("suite", bench_case.suite, "suite file or folder")->required();
  case_cmd->add_option("--case", bench_case.case_id, "the case's id")->required();
  case_cmd->add_option("--record", bench_case.record, "where to write its record (JSON)")
      ->required();
  case_cmd
      ->add_option("--seed", bench_case.seed,
                   "the seed the run had (graybox bench --seed), in place of the suite's")
      ->check(CLI::Range(0L, 4294967295L));
  CLI::App* withheld_cmd = bench_cmd->add_subcommand(
      "withheld",
      "run the diagnosis on the withheld-effect cases (problems/withheld) and score it: "
      "DIR/bench.json, the confusion table and the pass marks");
  withheld_cmd->add_option("--out,-o", withheld.out, "output directory (bench.json)")->required();
  withheld_cmd->add_flag("--fast", withheld.fast, "the small subset CI runs");
  withheld_cmd
      ->add_option("--cases", withheld.cases,
                   "only the cases whose name contains one of these, comma-separated")
      ->delimiter(',');
  AddDiagnosisOptions(withheld_cmd, &withheld);

  // A mistyped subcommand: CLI11 would say only "A subcommand is required".
  if (argc >= 2 && argv[1][0] != '-') {
    std::vector<std::string> names;
    for (const CLI::App* sub : app.get_subcommands({})) names.push_back(sub->get_name());
    const std::string given = argv[1];
    if (std::find(names.begin(), names.end(), given) == names.end()) {
      std::string list;
      for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
      std::cerr << "graybox: error: unknown command '" << graybox::app::Printable(given) << "'"
                << graybox::util::DidYouMeanHint(given, names) << " (commands: " << list
                << "; graybox --help)\n";
      return graybox::app::kExitBadInput;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help, version or the error
    return code == 0 ? graybox::app::kExitSuccess : graybox::app::kExitBadInput;
  }
  if (fit_cmd->parsed()) return graybox::app::RunFit(fit);
  if (sim_cmd->parsed()) return graybox::app::RunSimulate(simulate);
  if (diagnose_cmd->parsed()) return graybox::app::RunDiagnose(diagnose);
  if (withheld_cmd->parsed()) return graybox::app::RunBenchWithheld(withheld);
  if (case_cmd->parsed()) return graybox::app::RunBenchCase(bench_case);
  merge.command_line = command_line;
  if (merge_cmd->parsed()) return graybox::app::RunBenchMerge(merge);
  if (baseline_cmd->parsed()) return graybox::app::RunBenchBaseline(baseline);
  if (compare_cmd->parsed()) return graybox::app::RunBenchCompare(compare);
  if (bench_cmd->parsed()) {
    if (bench.out.empty()) bench.out = bench.resume;
    if (bench.suite.empty() || bench.out.empty()) {
      std::cerr << "graybox: error: bench: expected a suite and --out DIR (graybox bench SUITE "
                   "--out DIR), or a subcommand (merge, baseline, compare, withheld, case)\n";
      return graybox::app::kExitBadInput;
    }
    bench.command_line = command_line;
    if (bench.slurm || bench.slurm_script_only) return graybox::app::RunBenchSlurm(bench);
    return graybox::app::RunBench(bench);
  }
  if (blocks_cmd->parsed()) return graybox::app::RunBlocks(blocks);
  return graybox::app::RunCheck(check);
}
