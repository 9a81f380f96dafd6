// Slurm job arrays (slurm.h): the array and merge scripts, and their submission with sbatch.
#include "graybox/bench/slurm.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "graybox/util/write_file.h"

extern char** environ;

namespace graybox::bench {

namespace fs = std::filesystem;

namespace {

// A word for bash: single-quoted, an embedded ' as '\''.
std::string Quote(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

void RequireAbsolute(const std::string& field, const std::string& path) {
  if (path.empty() || !fs::path(path).is_absolute()) {
    throw std::invalid_argument("SlurmOptions." + field + ": expected an absolute path, got '" +
                                path + "'");
  }
}

const std::string kAlnum = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";

// A value of an #SBATCH line (which bash does not parse): only characters of `allowed`.
void RequireWord(const std::string& field, const std::string& value, const std::string& allowed) {
  for (const char c : value) {
    if (allowed.find(c) != std::string::npos) continue;
    const bool control = static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
    throw std::invalid_argument(
        "SlurmOptions." + field + ": '" + value + "' has " +
        (control ? std::string("a control character") : "'" + std::string(1, c) + "'") +
        ", which an #SBATCH line cannot hold (allowed: letters, digits and '" +
        allowed.substr(kAlnum.size()) + "')");
  }
}

// graybox-bench-<the suite's stem>, in characters that need no quoting.
std::string JobName(const std::string& suite) {
  std::string p = suite;
  while (p.size() > 1 && p.back() == '/') p.pop_back();
  std::string stem = fs::path(p).stem().string();
  for (char& c : stem) {
    if ((kAlnum + "._-").find(c) == std::string::npos) c = '_';
  }
  return "graybox-bench-" + stem;
}

// The #SBATCH lines both scripts share.
std::string CommonDirectives(const SlurmOptions& o, int cpus) {
  std::string s;
  if (!o.partition.empty()) s += "#SBATCH --partition=" + o.partition + "\n";
  if (!o.time_limit.empty()) s += "#SBATCH --time=" + o.time_limit + "\n";
  return s + "#SBATCH --cpus-per-task=" + std::to_string(cpus) + "\n";
}

// Runs argv (argv[0] from PATH) with stdin from /dev/null; its exit status and its stdout and
// stderr together.
int Run(const std::vector<std::string>& args, std::string& output) {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) {
    throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  }
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDERR_FILENO);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  if (rc != 0) {
    close(fds[0]);
    throw std::runtime_error("cannot run " + args[0] + ": " + std::strerror(rc) +
                             (rc == ENOENT ? " (is Slurm's sbatch on PATH?)" : ""));
  }
  char buf[4096];
  ssize_t n;
  while ((n = read(fds[0], buf, sizeof(buf))) > 0 || (n < 0 && errno == EINTR)) {
    if (n > 0) output.append(buf, static_cast<std::size_t>(n));
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// `sbatch --parsable [extra] SCRIPT`: the job id.
std::string Sbatch(const std::string& script, const std::string& extra, const std::string& what) {
  std::vector<std::string> args = {"sbatch", "--parsable"};
  if (!extra.empty()) args.push_back(extra);
  args.push_back(script);
  std::string output;
  const int code = Run(args, output);
  // The id is the last line that is one ("123" or "123;cluster"); warnings may come before it.
  std::string id, line;
  std::istringstream lines(output);
  while (std::getline(lines, line)) {
    const std::string head = line.substr(0, line.find(';'));
    if (!head.empty() && head.find_first_not_of("0123456789") == std::string::npos) id = head;
  }
  while (!output.empty() && std::isspace(static_cast<unsigned char>(output.back()))) {
    output.pop_back();
  }
  if (code != 0 || id.empty()) {
    throw std::runtime_error("sbatch " + what + " (" + script + ") failed (exit " +
                             std::to_string(code) + "): " + output);
  }
  return id;
}

}  // namespace

void SlurmOptions::Validate() const {
  RequireAbsolute("graybox", graybox);
  RequireAbsolute("suite", suite);
  RequireAbsolute("out_dir", out_dir);
  if (!costs.empty()) RequireAbsolute("costs", costs);
  RequireWord("out_dir", out_dir, kAlnum + "/._-+,:=@");
  if (shards < 1) {
    throw std::invalid_argument("SlurmOptions.shards: expected >= 1, got " +
                                std::to_string(shards));
  }
  if (array_parallel < 0) {
    throw std::invalid_argument("SlurmOptions.array_parallel: expected >= 0 (0: no limit), got " +
                                std::to_string(array_parallel));
  }
  RequireWord("partition", partition, kAlnum + "._-,");
  RequireWord("time_limit", time_limit, kAlnum + ":-");
  if (jobs_per_task < 1) {
    throw std::invalid_argument("SlurmOptions.jobs_per_task: expected >= 1, got " +
                                std::to_string(jobs_per_task));
  }
}

SlurmScripts WriteSlurmScripts(const SlurmOptions& o) {
  o.Validate();
  std::string out = fs::path(o.out_dir).lexically_normal().string();
  while (out.size() > 1 && out.back() == '/') out.pop_back();
  const std::string n = std::to_string(o.shards), name = JobName(o.suite);
  const std::string throttle = o.array_parallel > 0 ? "%" + std::to_string(o.array_parallel) : "";
  SlurmScripts s;
  std::string& a = s.array_script;
  a = "#!/bin/bash\n#SBATCH --job-name=" + name + "\n";
  a += "#SBATCH --array=1-" + n + throttle + "\n";
  a += "#SBATCH --output=" + out + "/slurm/%A_%a.log\n";
  a += CommonDirectives(o, o.jobs_per_task);
  a += "# graybox bench --slurm: array task K runs shard K of " + n + " into OUT/shards/K;\n";
  a += "# bench_merge.sh joins them (sbatch --dependency=afterany:<this array's job id>).\n";
  a += "set -euo pipefail\n";
  a += "shard=${SLURM_ARRAY_TASK_ID:?submit this script with sbatch (an array task)}\n";
  a += "# No shard of an earlier run in OUT may pass for this one's (merge would take it).\n";
  a += "rm -rf -- " + Quote(out + "/shards/") + "\"$shard\"\n";
  a += "exec " + Quote(o.graybox) + " bench " + Quote(o.suite) + " \\\n";
  a += "  --shard \"$shard/" + n + "\" --jobs " + std::to_string(o.jobs_per_task);
  if (!o.filter.empty()) a += " --filter " + Quote(o.filter);
  if (o.seed >= 0) a += " --seed " + std::to_string(o.seed);
  if (!o.costs.empty()) a += " --costs " + Quote(o.costs);
  a += " \\\n  --out " + Quote(out + "/shards/") + "\"$shard\"\n";
  std::string& m = s.merge_script;
  m = "#!/bin/bash\n#SBATCH --job-name=" + name + "-merge\n";
  m += "#SBATCH --output=" + out + "/slurm/merge_%j.log\n";
  m += CommonDirectives(o, 1);
  m += "# graybox bench --slurm: joins the " + n + " shards of the array into OUT/merged; submit\n";
  m += "# with sbatch --dependency=afterany:<array job id> (merge names a missing shard).\n";
  m += "set -euo pipefail\nexec " + Quote(o.graybox) + " bench merge \\\n";
  for (int k = 1; k <= o.shards; ++k)
    m += "  " + Quote(out + "/shards/" + std::to_string(k)) + " \\\n";
  m += "  --out " + Quote(out + "/merged") + "\n";
  return s;
}

SlurmScripts SaveSlurmScripts(const SlurmOptions& o) {
  const SlurmScripts texts = WriteSlurmScripts(o);
  const fs::path dir = fs::path(o.out_dir) / "slurm";
  std::error_code ec;
  for (const fs::path& folder : {dir, fs::path(o.out_dir) / "shards"}) {
    fs::create_directories(folder, ec);
    if (ec) throw std::runtime_error("cannot create '" + folder.string() + "': " + ec.message());
  }
  SlurmScripts paths{(dir / "bench_array.sh").string(), (dir / "bench_merge.sh").string()};
  for (const auto& [path, text] : {std::pair{paths.array_script, texts.array_script},
                                   std::pair{paths.merge_script, texts.merge_script}}) {
    util::WriteFileAtomically(path, text);
    fs::permissions(path, fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec,
                    fs::perm_options::add, ec);
  }
  return paths;
}

SlurmSubmission SubmitSlurm(const std::string& array_script_path,
                            const std::string& merge_script_path) {
  SlurmSubmission s;
  s.array_job = Sbatch(array_script_path, "", "of the array script");
  try {
    s.merge_job =
        Sbatch(merge_script_path, "--dependency=afterany:" + s.array_job, "of the merge script");
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string(e.what()) + " (the array job " + s.array_job +
                             " is submitted: scancel " + s.array_job + " to cancel it)");
  }
  return s;
}

}  // namespace graybox::bench
