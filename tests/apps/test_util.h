// Helpers of the apps tests: scratch directories, running the built `graybox` executable, and a
// small generated problem (a mass with viscous friction pushed by a known force) whose data are
// computed in closed form.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace graybox::apps_testing {

namespace fs = std::filesystem;

/// A fresh directory under the system temp folder, removed with its contents at destruction.
class ScratchDir {
 public:
  ScratchDir() {
    static std::atomic<int> counter{0};
    path_ = fs::temp_directory_path() /
            ("graybox_apps_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const fs::path& path() const { return path_; }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

inline void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

inline std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The result of running the executable: exit code and the combined stdout + stderr.
struct RunResult {
  int exit_code = -1;
  std::string output;
};

/// Runs `graybox <arguments>` (arguments already shell-quoted where needed) from `cwd`, after
/// `prefix` (a wrapper such as "timeout -s INT 2 ").
inline RunResult RunGraybox(const std::string& arguments, const std::string& log_path,
                            const std::string& cwd = "", const std::string& prefix = "") {
  const std::string command = (cwd.empty() ? "" : "cd '" + cwd + "' && ") + prefix + "'" +
                              GRAYBOX_EXECUTABLE + "' " + arguments + " > '" + log_path + "' 2>&1";
  const int status = std::system(command.c_str());
  RunResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.output = ReadText(log_path);
  return r;
}

// The generated problem: m qdd = F - fv qd from rest at q = 0 under a constant force F, so
//   qd(t) = (F / fv) (1 - exp(-t / T)),  q(t) = (F / fv) (t - T (1 - exp(-t / T))),  T = m / fv.
inline constexpr double kTrueMass = 2.0;     // kg
inline constexpr double kTrueViscous = 4.0;  // N s/m
inline constexpr double kForce = 3.0;        // N
inline constexpr double kSampleTime = 0.01;  // s
inline constexpr int kSamples = 200;

inline double PushedPosition(double t) {
  const double tau = kTrueMass / kTrueViscous;
  return kForce / kTrueViscous * (t - tau * (1.0 - std::exp(-t / tau)));
}

/// CSV with columns time, force, pos; `corrupt` replaces pos at sample 3 by the given text.
inline std::string PushedCsv(const std::string& corrupt = "", bool reverse_time_at_5 = false) {
  std::ostringstream csv;
  csv << "time,force,pos\n";
  char buf[128];
  for (int k = 0; k < kSamples; ++k) {
    double t = k * kSampleTime;
    if (reverse_time_at_5 && k == 5) t = 3.5 * kSampleTime;
    std::snprintf(buf, sizeof buf, "%.10g,%.10g,%.17g", t, kForce, PushedPosition(k * kSampleTime));
    std::string line = buf;
    if (k == 3 && !corrupt.empty()) {
      line = line.substr(0, line.rfind(',') + 1) + corrupt;
    }
    csv << line << "\n";
  }
  return csv.str();
}

/// The problem text for pushed.csv; `estimation` replaces the [estimation] section.
inline std::string PushedProblem(const std::string& estimation =
                                     "[estimation]\n"
                                     "method = \"multiple_shooting\"\n"
                                     "solver = \"ipopt\"\n"
                                     "[estimation.multiple_shooting]\n"
                                     "segment_length = 25\n",
                                 const std::string& parameters =
                                     "\"load.mass\" = { value = 1.0, scale = 1.0 }\n"
                                     "\"friction.fv\" = { value = 1.0, scale = 1.0 }\n") {
  return "[problem]\n"
         "name = \"pushed\"\n"
         "\n"
         "[model]\n"
         "inputs = [{ name = \"force\", unit = \"N\" }]\n"
         "outputs = [\"load.q\"]\n"
         "\n"
         "[[model.blocks]]\n"
         "instance = \"load\"\n"
         "type = \"mechanics.mass\"\n"
         "inputs = [\"force\"]\n"
         "\n"
         "[[model.blocks]]\n"
         "instance = \"friction\"\n"
         "type = \"friction.viscous\"\n"
         "options = { motion = \"prismatic\" }\n"
         "inputs = [\"load.qd\"]\n"
         "outputs = [\"-force\"]\n"
         "\n"
         "[model.parameters]\n" +
         parameters +
         "\n"
         "[[data]]\n"
         "name = \"pushed\"\n"
         "file = \"pushed.csv\"\n"
         "time = \"time\"\n"
         "inputs = { force = \"force\" }\n"
         "outputs = { \"load.q\" = \"pos\" }\n"
         "splits = [{ name = \"first\", role = \"estimation\", end = 150 },\n"
         "          { name = \"last\", role = \"validation\", begin = 150 }]\n"
         "initial_state = { \"load.qd\" = 0.0 }\n"
         "\n" +
         estimation;
}

}  // namespace graybox::apps_testing
