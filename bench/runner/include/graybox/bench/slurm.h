// Slurm job arrays for `graybox bench SUITE --slurm` (docs/bench.md): a suite run as N shards,
// one array task per shard, and a merge job that runs after the array whatever its tasks' fate.
//
//   WriteSlurmScripts   the two batch scripts' texts:
//                         array: #SBATCH --job-name=graybox-bench-<suite file's stem>,
//                                --array=1-N[%P], --output=OUT/slurm/%A_%a.log, [--partition],
//                                [--time], --cpus-per-task=J; removes
//                                OUT/shards/${SLURM_ARRAY_TASK_ID} (an earlier run's shard must
//                                not be merged as this one's), then runs
//                                GRAYBOX bench SUITE --shard ${SLURM_ARRAY_TASK_ID}/N --jobs J
//                                [--filter F] [--seed S] [--costs C] --out
//                                OUT/shards/${SLURM_ARRAY_TASK_ID}
//                         merge: --job-name=graybox-bench-<stem>-merge,
//                                --output=OUT/slurm/merge_%j.log, the same partition and time;
//                                runs GRAYBOX bench merge OUT/shards/1 ... OUT/shards/N
//                                --out OUT/merged (every shard named, so that merge reports a
//                                missing one)
//                       Paths are absolute and single-quoted for bash; the jobs inherit the
//                       submitting shell's environment (sbatch's default --export=ALL).
//   SaveSlurmScripts    creates OUT/slurm (Slurm opens a task's --output file before the
//                       script runs: without the folder a task fails with no log at all) and
//                       OUT/shards, writes OUT/slurm/bench_array.sh and bench_merge.sh
//                       (executable), returns their paths.
//   SubmitSlurm         `sbatch --parsable ARRAY`, then `sbatch --parsable
//                       --dependency=afterany:<array id> MERGE` (sbatch from PATH, arguments
//                       passed as argv, no shell); the two job ids.
//
// OUT must be on a file system that the compute nodes share with the submitting machine (the
// scripts name it, the shards write there, the merge reads there), and so must GRAYBOX and the
// suite with its problem files and data.
//
// Failure behaviour: SlurmOptions::Validate (called by WriteSlurmScripts and SaveSlurmScripts)
// throws std::invalid_argument naming the field; SaveSlurmScripts throws std::runtime_error when
// a folder or file cannot be written; SubmitSlurm throws std::runtime_error with sbatch's output
// when sbatch cannot be started or fails (when the merge job is refused, the message names the
// array job that was already submitted, for scancel).
#pragma once

#include <string>

namespace graybox::bench {

struct SlurmOptions {
  std::string graybox;  // absolute path of the graybox executable
  std::string suite;    // absolute path of the suite file (or folder)
  /// Absolute output folder on the shared file system. It is written into #SBATCH --output
  /// lines, which bash does not parse: no whitespace, quotes, backslash or '%' in it.
  std::string out_dir;
  int shards = 0;          // array tasks (>= 1), one shard each
  int array_parallel = 0;  // tasks at a time (the array's %N throttle); 0: no limit
  std::string partition;   // sbatch --partition (a name or a comma list); empty: the default
  std::string time_limit;  // sbatch --time of each task and the merge, e.g. "02:00:00"; empty: none
  int jobs_per_task = 1;   // graybox bench --jobs in each task, and its --cpus-per-task (>= 1)
  std::string filter;      // passed through as --filter; empty: every case
  long seed = -1;          // passed through as --seed when >= 0
  std::string costs;       // absolute path passed through as --costs (balances the shards by an
                           // earlier run's times); empty: every case costs 1
  /// Throws std::invalid_argument naming the first invalid field.
  void Validate() const;
};

struct SlurmScripts {
  std::string array_script, merge_script;
};

/// The two scripts' texts (file comment). Validates the options.
SlurmScripts WriteSlurmScripts(const SlurmOptions& options);

/// Writes the scripts into OUT/slurm (creating it and OUT/shards); returns the two files' paths.
SlurmScripts SaveSlurmScripts(const SlurmOptions& options);

struct SlurmSubmission {
  std::string array_job, merge_job;  // the job ids sbatch printed
};

/// Submits the array script, then the merge script with --dependency=afterany:<array job>.
SlurmSubmission SubmitSlurm(const std::string& array_script_path,
                            const std::string& merge_script_path);

}  // namespace graybox::bench
