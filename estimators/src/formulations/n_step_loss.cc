#include "graybox/estimators/formulations/n_step_loss.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include "graybox/estimators/nlp/weights.h"

namespace graybox::estimators {

void NStepLossOptions::Validate() const {
  if (steps < 1) {
    throw std::invalid_argument("NStepLossOptions.steps: expected >= 1, got " +
                                std::to_string(steps));
  }
  if (stride < 1) {
    throw std::invalid_argument("NStepLossOptions.stride: expected >= 1, got " +
                                std::to_string(stride));
  }
  if (first_start < 0) {
    throw std::invalid_argument("NStepLossOptions.first_start: expected >= 0, got " +
                                std::to_string(first_start));
  }
  if (num_threads < 1) {
    throw std::invalid_argument("NStepLossOptions.num_threads: expected >= 1, got " +
                                std::to_string(num_threads));
  }
  std::vector<int> sorted = channels;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
    throw std::invalid_argument("NStepLossOptions.channels: expected distinct state indices");
  }
  if (weights.size() > 0 && !(weights.array() >= 0.0).all()) {
    throw std::invalid_argument("NStepLossOptions.weights: expected every weight >= 0");
  }
  integrator.Validate();
}

void NStepLossProblem::SetFixedValue(int parameter, double value) {
  parameters.SetFixedValue(parameter, value);
  (*shared_values)[parameter] = value;
  nlp.ClearCaches();
}

double NStepLossProblem::Nrms(double cost) const {
  return num_scored > 0 ? std::sqrt(2.0 * cost / static_cast<double>(num_scored)) : 0.0;
}

namespace {

// All windows of one experiment; z = the scaled free parameters.
class WindowsResidual final : public ResidualBlock {
 public:
  WindowsResidual(std::shared_ptr<const Integrator> integrator, std::string name,
                  const Eigen::MatrixXd& u, const Eigen::MatrixXd& x, std::vector<int> starts,
                  const ParameterMap& map, std::shared_ptr<const Eigen::VectorXd> values,
                  std::vector<int> channels, Eigen::VectorXd weights, int steps, int num_threads)
      : integrator_(std::move(integrator)),
        name_(std::move(name)),
        u_(u),
        x_(x),
        starts_(std::move(starts)),
        map_(map),
        values_(std::move(values)),
        channels_(std::move(channels)),
        weights_(std::move(weights)),
        steps_(steps),
        num_threads_(num_threads) {}

  int NumResiduals() const override {
    return static_cast<int>(starts_.size() * channels_.size()) * steps_;
  }

  NlpEvalStatus Evaluate(const Eigen::VectorXd& z, Eigen::VectorXd* r,
                         Eigen::MatrixXd* jacobian) const override {
    const int nf = map_.NumFree();
    Eigen::VectorXd p = *values_;  // fixed values shared with the problem (SetFixedValue)
    for (int i = 0; i < nf; ++i) p[map_.free[i]] = map_.scale[i] * z[i];
    const int per_window = static_cast<int>(channels_.size()) * steps_;
    r->resize(NumResiduals());
    if (jacobian != nullptr) jacobian->resize(NumResiduals(), nf);
    const int n_windows = static_cast<int>(starts_.size());
    const int threads = std::max(1, std::min(num_threads_, n_windows));
    std::vector<NlpEvalStatus> status(static_cast<std::size_t>(threads));
    // Windows are dealt out in contiguous ranges; each thread writes its own rows only.
    auto work = [&](int t) {
      const int begin = static_cast<int>(static_cast<long>(n_windows) * t / threads);
      const int end = static_cast<int>(static_cast<long>(n_windows) * (t + 1) / threads);
      for (int w = begin; w < end; ++w) {
        const int k = starts_[static_cast<std::size_t>(w)];
        const Eigen::VectorXd x0 = x_.row(k).transpose();
        const Eigen::MatrixXd u = u_.middleRows(k, steps_ + 1);
        SensitivityTrajectory s;
        if (jacobian != nullptr) {
          s = integrator_->SimulateWithSensitivities(x0, u, p, map_.free);
        } else {
          static_cast<Trajectory&>(s) = integrator_->Simulate(x0, u, p);
        }
        if (!s.summary.ok()) {
          status[static_cast<std::size_t>(t)] = {
              false, "n-step loss, experiment '" + name_ + "', window from sample " +
                         std::to_string(k) + ": " + s.summary.BriefReport()};
          return;
        }
        const Eigen::Index row0 = static_cast<Eigen::Index>(w) * per_window;
        for (int j = 1; j <= steps_; ++j) {
          for (std::size_t c = 0; c < channels_.size(); ++c) {
            const Eigen::Index row =
                row0 +
                static_cast<Eigen::Index>(j - 1) * static_cast<Eigen::Index>(channels_.size()) +
                static_cast<Eigen::Index>(c);
            const double wc = weights_[static_cast<Eigen::Index>(c)];
            const int ch = channels_[c];
            r->coeffRef(row) = wc * (s.x(j, ch) - x_(k + j, ch));
            if (jacobian == nullptr) continue;
            for (int i = 0; i < nf; ++i) {
              (*jacobian)(row, i) =
                  wc * s.dx_dp[static_cast<std::size_t>(j)](ch, i) * map_.scale[i];
            }
          }
        }
      }
    };
    if (threads == 1) {
      work(0);
    } else {
      std::vector<std::thread> pool;
      for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
      work(0);
      for (auto& th : pool) th.join();
    }
    for (const NlpEvalStatus& s : status) {
      if (!s.ok) return s;
    }
    return {};
  }

 private:
  std::shared_ptr<const Integrator> integrator_;
  std::string name_;
  Eigen::MatrixXd u_, x_;
  std::vector<int> starts_;
  ParameterMap map_;
  std::shared_ptr<const Eigen::VectorXd> values_;
  std::vector<int> channels_;
  Eigen::VectorXd weights_;
  int steps_;
  int num_threads_;
};

}  // namespace

NStepLossProblem BuildNStepLoss(const models::StateSpaceModel& model,
                                const std::vector<Experiment>& experiments,
                                const NStepLossOptions& options) {
  options.Validate();
  const int nx = model.NumStates(), nu = model.NumInputs();
  if (experiments.empty()) {
    throw std::invalid_argument("BuildNStepLoss: expected at least one experiment, got 0");
  }
  std::vector<int> channels = options.channels;
  if (channels.empty()) {
    for (int c = 0; c < nx; ++c) channels.push_back(c);
  }
  for (int c : channels) {
    if (c < 0 || c >= nx) {
      throw std::invalid_argument("NStepLossOptions.channels: expected state indices in [0, " +
                                  std::to_string(nx) + "), got " + std::to_string(c));
    }
  }
  NStepLossProblem problem{Nlp(Eigen::VectorXd(), Eigen::VectorXd(), Eigen::VectorXd()),
                           ParameterMap::FromModel(model.parameters),
                           channels,
                           Eigen::VectorXd(),
                           {},
                           0,
                           nullptr};
  problem.shared_values = std::make_shared<Eigen::VectorXd>(problem.parameters.values);
  std::vector<const Eigen::MatrixXd*> scored;
  std::vector<Eigen::MatrixXd> scored_columns;
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    const Experiment& ex = experiments[e];
    const Eigen::MatrixXd& x = ex.x;
    const std::string where = "experiment '" + ex.name + "'";
    if (!(ex.dt > 0.0) || std::fabs(ex.dt - experiments[0].dt) > 1e-12 * experiments[0].dt) {
      throw std::invalid_argument(where + ": expected the sample time " +
                                  std::to_string(experiments[0].dt) + " s (> 0), got " +
                                  std::to_string(ex.dt));
    }
    if (ex.u.cols() != nu || x.cols() != nx || x.rows() != ex.u.rows()) {
      throw std::invalid_argument(where + ": expected inputs of N x " + std::to_string(nu) +
                                  " and measured states of N x " + std::to_string(nx) + ", got " +
                                  std::to_string(ex.u.rows()) + "x" + std::to_string(ex.u.cols()) +
                                  " and " + std::to_string(x.rows()) + "x" +
                                  std::to_string(x.cols()));
    }
    if (x.rows() <= options.first_start + options.steps) {
      throw std::invalid_argument(where + ": expected more than first_start + steps = " +
                                  std::to_string(options.first_start + options.steps) +
                                  " samples, got " + std::to_string(x.rows()));
    }
    if (!ex.u.allFinite() || !x.allFinite()) {
      throw std::invalid_argument(where + ": inputs or measured states contain NaN or Inf");
    }
    std::vector<int> starts;
    for (int k = options.first_start; k + options.steps <= x.rows() - 1; k += options.stride)
      starts.push_back(k);
    problem.num_scored +=
        static_cast<long>(starts.size()) * options.steps * static_cast<long>(channels.size());
    problem.starts.push_back(std::move(starts));
    Eigen::MatrixXd cols(x.rows(), static_cast<Eigen::Index>(channels.size()));
    for (std::size_t c = 0; c < channels.size(); ++c) {
      cols.col(static_cast<Eigen::Index>(c)) = x.col(channels[c]);
    }
    scored_columns.push_back(std::move(cols));
  }
  for (const auto& m : scored_columns) scored.push_back(&m);
  if (options.weights.size() > 0 &&
      options.weights.size() != static_cast<Eigen::Index>(channels.size())) {
    throw std::invalid_argument(
        "NStepLossOptions.weights: expected " + std::to_string(channels.size()) +
        " entries (one per scored channel), got " + std::to_string(options.weights.size()));
  }
  // Given weights, and 1 / std for the channels without one (all when none are given).
  problem.weights = InverseStdWeights(scored);
  for (std::size_t c = 0; c < channels.size(); ++c) {
    const Eigen::Index i = static_cast<Eigen::Index>(c);
    if (options.weights.size() > 0 && options.weights[i] > 0.0) {
      problem.weights[i] = options.weights[i];
      continue;
    }
    const double mean = scored_columns[0].col(i).mean();
    bool constant = true;
    for (const auto& m : scored_columns) constant = constant && (m.col(i).array() == mean).all();
    if (constant) {
      throw std::invalid_argument(
          "BuildNStepLoss: measured state '" + model.states[channels[c]].name +
          "' is constant: expected a nonzero standard deviation for its default weight 1/std "
          "(give NStepLossOptions.weights or leave the channel out)");
    }
  }

  std::vector<double> w0, lbw, ubw;
  std::vector<std::string> names;
  problem.parameters.AppendVariables(&w0, &lbw, &ubw, &names);
  auto vec = [](std::vector<double>& v) {
    return Eigen::VectorXd(
        Eigen::Map<Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
  };
  problem.nlp = Nlp(vec(w0), vec(lbw), vec(ubw), names);
  const std::shared_ptr<const Integrator> integrator =
      MakeIntegrator(model, experiments[0].dt, options.integrator);
  std::vector<int> variables;
  for (int i = 0; i < problem.parameters.NumFree(); ++i) variables.push_back(i);
  std::vector<int> channel_label;
  for (int c : channels) channel_label.push_back(problem.nlp.ResidualChannel(model.states[c].name));
  for (std::size_t e = 0; e < experiments.size(); ++e) {
    if (problem.starts[e].empty()) continue;
    int row = problem.nlp.NumResiduals();
    problem.nlp.AddResidualBlock(
        "n_step_" + experiments[e].name, variables,
        std::make_shared<WindowsResidual>(integrator, experiments[e].name, experiments[e].u,
                                          experiments[e].x, problem.starts[e], problem.parameters,
                                          problem.shared_values, channels, problem.weights,
                                          options.steps, options.num_threads));
    // Rows: window (start k), step j = 1..N, channel: the prediction of sample k + j.
    for (int k : problem.starts[e]) {
      for (int j = 1; j <= options.steps; ++j) {
        for (int c : channel_label)
          problem.nlp.LabelResidual(row++, {static_cast<int>(e), k + j, c});
      }
    }
  }
  return problem;
}

}  // namespace graybox::estimators
