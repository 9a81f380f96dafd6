#include "graybox/estimators/analysis/n_step.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "graybox/estimators/integrators/integrators.h"

namespace graybox::estimators {

void NStepSimulationOptions::Validate() const {
  if (scoring.steps < 1 || scoring.stride < 1 || num_threads < 0 || chunk < 1) {
    throw std::invalid_argument(
        "NStepSimulationOptions: expected steps >= 1, stride >= 1, num_threads >= 0 and chunk >= "
        "1, got " +
        std::to_string(scoring.steps) + ", " + std::to_string(scoring.stride) + ", " +
        std::to_string(num_threads) + ", " + std::to_string(chunk));
  }
  step.Validate();
}

NStepResult NStepNrmsSimulated(const models::StateSpaceModel& model, const Eigen::MatrixXd& x,
                               const Eigen::MatrixXd& u, const Eigen::VectorXd& p, double dt,
                               const NStepSimulationOptions& options) {
  options.Validate();
  const int nx = model.NumStates(), nu = model.NumInputs();
  if (x.cols() != nx || u.cols() != nu || u.rows() != x.rows() ||
      p.size() != model.NumParameters()) {
    throw std::invalid_argument("NStepNrmsSimulated: expected x of N x " + std::to_string(nx) +
                                ", u of N x " + std::to_string(nu) + " and " +
                                std::to_string(model.NumParameters()) + " parameters, got " +
                                std::to_string(x.rows()) + "x" + std::to_string(x.cols()) + ", " +
                                std::to_string(u.rows()) + "x" + std::to_string(u.cols()) +
                                " and " + std::to_string(p.size()));
  }
  const int steps = options.scoring.steps;
  const int n = static_cast<int>(x.rows());
  const int last = options.scoring.last_start < 0 ? n - 1 - steps : options.scoring.last_start;
  if (options.scoring.first_start < 0 || last > n - 1 - steps ||
      last < options.scoring.first_start) {
    throw std::invalid_argument("NStepNrmsSimulated: expected starts in [0, " +
                                std::to_string(n - 1 - steps) + "] with " + std::to_string(steps) +
                                " steps, got [" + std::to_string(options.scoring.first_start) +
                                ", " + std::to_string(last) + "]");
  }
  for (std::size_t i = 0; i < options.scoring.channels.size(); ++i) {
    const int c = options.scoring.channels[i];
    const auto before = options.scoring.channels.begin() + static_cast<std::ptrdiff_t>(i);
    if (c < 0 || c >= nx || std::find(options.scoring.channels.begin(), before, c) != before) {
      throw std::invalid_argument("NStepNrmsSimulated: expected distinct state indices in [0, " +
                                  std::to_string(nx) + ") in scoring.channels, got " +
                                  std::to_string(c) + " at position " + std::to_string(i));
    }
  }
  std::vector<std::string> names = options.scoring.names;
  if (!names.empty() && static_cast<int>(names.size()) != nx) {
    throw std::invalid_argument("NStepNrmsSimulated: expected " + std::to_string(nx) +
                                " names in scoring.names (one per state) or none, got " +
                                std::to_string(names.size()));
  }
  if (names.empty()) {
    for (const auto& state : model.states) names.push_back(state.name);
  }
  std::vector<int> starts;
  for (int s = options.scoring.first_start; s <= last; s += options.scoring.stride) {
    starts.push_back(s);
  }
  const expr::Function step = MakeStepFunction(model, dt, options.step);
  std::unique_ptr<expr::CompiledFunction> native;
  std::string evaluation = "tape: generated code not asked for (generated_code = false)";
  if (options.generated_code) {
    native = std::make_unique<expr::CompiledFunction>(step, options.jit);
    evaluation = native->IsNative()
                     ? "generated code"
                     : "tape: no generated code: " +
                           native->FallbackReason().substr(0, native->FallbackReason().find('\n'));
    if (!native->IsNative()) native.reset();
  }
  const int num_chunks = static_cast<int>((starts.size() + options.chunk - 1) / options.chunk);
  std::vector<NStepResult> chunk_results(num_chunks);
  std::vector<std::string> errors(num_chunks);
  auto work = [&](int thread, int num_threads) {
    expr::Workspace ws = step.MakeWorkspace();
    std::vector<Eigen::MatrixXd> in(3), out;
    for (int c = thread; c < num_chunks; c += num_threads) {
      const int begin = c * options.chunk;
      const int m = std::min<int>(options.chunk, static_cast<int>(starts.size()) - begin);
      in[0].resize(nx, m);
      in[1].resize(nu, m);
      in[2] = p.replicate(1, m);
      for (int i = 0; i < m; ++i) in[0].col(i) = x.row(starts[begin + i]).transpose();
      std::vector<Eigen::MatrixXd> predictions(m, Eigen::MatrixXd(steps, nx));
      if (native) {
        // One start after another through the generated code (NaN/Inf surface in the score as
        // NaN, as on the tape).
        Eigen::VectorXd state(nx), next(nx), input(nu);
        const double* args[3] = {state.data(), input.data(), p.data()};
        double* results[1] = {next.data()};
        for (int i = 0; i < m; ++i) {
          state = x.row(starts[begin + i]).transpose();
          for (int k = 0; k < steps; ++k) {
            input = u.row(starts[begin + i] + k).transpose();
            native->Evaluate(args, results, &ws);
            predictions[i].row(k) = next.transpose();
            state.swap(next);
            args[0] = state.data();
            results[0] = next.data();
          }
        }
      } else {
        for (int k = 0; k < steps; ++k) {
          for (int i = 0; i < m; ++i) in[1].col(i) = u.row(starts[begin + i] + k).transpose();
          step.EvaluateBatch(in, &out, &ws);  // NaN/Inf surface in the score as NaN
          for (int i = 0; i < m; ++i) predictions[i].row(k) = out[0].col(i).transpose();
          in[0].swap(out[0]);
        }
      }
      try {
        chunk_results[c] =
            NStepNrms(x, std::vector<int>(starts.begin() + begin, starts.begin() + begin + m),
                      predictions, options.scoring.channels, names);
      } catch (const std::exception& e) {
        errors[c] = e.what();
      }
    }
  };
  int threads = options.num_threads == 0 ? static_cast<int>(std::thread::hardware_concurrency())
                                         : options.num_threads;
  threads = std::max(1, std::min(threads, num_chunks));
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work, t, threads);
  work(0, threads);
  for (auto& t : pool) t.join();
  for (const auto& e : errors) {
    if (!e.empty()) throw std::invalid_argument(e);
  }
  // Combine: every eta is the root of a mean over starts (and steps, channels), so squares
  // weighted by the number of starts add up.
  NStepResult total = chunk_results.front();
  total.starts = starts;
  double sum = 0.0;
  Eigen::VectorXd channel_sum = Eigen::VectorXd::Zero(total.channel_nrms.size());
  Eigen::VectorXd step_sum = Eigen::VectorXd::Zero(total.step_nrms.size());
  for (const auto& r : chunk_results) {
    const double w = static_cast<double>(r.starts.size());
    sum += w * r.nrms * r.nrms;
    channel_sum += w * r.channel_nrms.cwiseAbs2();
    step_sum += w * r.step_nrms.cwiseAbs2();
  }
  const double count = static_cast<double>(starts.size());
  total.nrms = std::sqrt(sum / count);
  total.channel_nrms = (channel_sum / count).cwiseSqrt();
  total.step_nrms = (step_sum / count).cwiseSqrt();
  total.evaluation = evaluation;
  return total;
}

}  // namespace graybox::estimators
