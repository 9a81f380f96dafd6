#include "graybox/estimators/metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace graybox::estimators {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

[[noreturn]] void Fail(const std::string& function, const std::string& what) {
  throw std::invalid_argument("metrics: " + function + ": " + what);
}

std::string Shape(const Eigen::MatrixXd& m) {
  return std::to_string(m.rows()) + "x" + std::to_string(m.cols());
}

void CheckPair(const std::string& function, const Eigen::MatrixXd& y,
               const Eigen::MatrixXd& y_hat) {
  if (y.rows() != y_hat.rows() || y.cols() != y_hat.cols()) {
    Fail(function, "expected y_hat of size " + Shape(y) + " (the size of y), got " + Shape(y_hat));
  }
  if (y.rows() < 1) Fail(function, "expected at least 1 sample, got 0");
  for (Eigen::Index j = 0; j < y.cols(); ++j) {
    for (Eigen::Index k = 0; k < y.rows(); ++k) {
      if (!std::isfinite(y(k, j))) {
        std::ostringstream os;
        os << "measured y(" << k << ", " << j << "): expected a finite value, got " << y(k, j);
        Fail(function, os.str());
      }
    }
  }
}

// Sums needed by every metric of one channel.
struct Sums {
  double n = 0.0;
  double sse = 0.0;        // sum e^2
  double sae = 0.0;        // sum |e|
  double sum_e = 0.0;      // sum e
  double sst = 0.0;        // sum (y - ybar)^2
  double sum_abs_y = 0.0;  // sum |y|
  double sum_y2 = 0.0;     // sum y^2
};

Sums ChannelSums(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat, Eigen::Index j) {
  Sums s;
  const Eigen::Index n = y.rows();
  s.n = static_cast<double>(n);
  const double mean = y.col(j).mean();
  for (Eigen::Index k = 0; k < n; ++k) {
    const double e = y(k, j) - y_hat(k, j);
    const double d = y(k, j) - mean;
    s.sse += e * e;
    s.sae += std::abs(e);
    s.sum_e += e;
    s.sst += d * d;
    s.sum_abs_y += std::abs(y(k, j));
    s.sum_y2 += y(k, j) * y(k, j);
  }
  return s;
}

double Ratio(double num, double den) { return den > 0.0 ? num / den : kNaN; }

ChannelMetrics FromSums(const Sums& s) {
  ChannelMetrics m;
  m.rmse = std::sqrt(s.sse / s.n);   // (3-8)
  m.mae = s.sae / s.n;               // (3-9)
  m.r2 = 1.0 - Ratio(s.sse, s.sst);  // (3-10)
  const double var_e = s.sse / s.n - (s.sum_e / s.n) * (s.sum_e / s.n);
  m.vaf_percent = 100.0 * (1.0 - Ratio(std::max(var_e, 0.0), s.sst / s.n));  // (3-11)
  m.fit_percent = 100.0 * (1.0 - std::sqrt(Ratio(s.sse, s.sst)));            // (3-12)
  m.nrmse = std::sqrt(Ratio(s.sse, s.sst));                                  // RMSE / std(y)
  m.nmae = Ratio(s.sae, s.sum_abs_y);                                        // seed 001 (2)
  m.nmse = Ratio(s.sse, s.sum_y2);                                           // seed 001 (3)
  if (!std::isfinite(s.sse) || !std::isfinite(s.sae)) {
    // NaN or Inf in the prediction: every metric of the channel is undefined.
    m.rmse = m.mae = m.r2 = m.vaf_percent = m.fit_percent = m.nrmse = m.nmae = m.nmse = kNaN;
  }
  return m;
}

template <typename Field>
Eigen::VectorXd PerChannel(const char* function, const Eigen::MatrixXd& y,
                           const Eigen::MatrixXd& y_hat, Field field) {
  CheckPair(function, y, y_hat);
  Eigen::VectorXd out(y.cols());
  for (Eigen::Index j = 0; j < y.cols(); ++j) out(j) = field(FromSums(ChannelSums(y, y_hat, j)));
  return out;
}

std::string Num(double v, const char* format) {
  if (std::isnan(v)) return "n/a";
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), format, v);
  return buffer;
}

std::string Pad(const std::string& s, size_t width) {
  return s.size() >= width ? s + " " : s + std::string(width - s.size(), ' ');
}

}  // namespace

Eigen::VectorXd Rmse(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat) {
  return PerChannel("Rmse", y, y_hat, [](const ChannelMetrics& m) { return m.rmse; });
}
Eigen::VectorXd Nrmse(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat) {
  return PerChannel("Nrmse", y, y_hat, [](const ChannelMetrics& m) { return m.nrmse; });
}
Eigen::VectorXd RSquared(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat) {
  return PerChannel("RSquared", y, y_hat, [](const ChannelMetrics& m) { return m.r2; });
}
Eigen::VectorXd FitPercent(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat) {
  return PerChannel("FitPercent", y, y_hat, [](const ChannelMetrics& m) { return m.fit_percent; });
}
Eigen::VectorXd VafPercent(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat) {
  return PerChannel("VafPercent", y, y_hat, [](const ChannelMetrics& m) { return m.vaf_percent; });
}
Eigen::VectorXd Mae(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat) {
  return PerChannel("Mae", y, y_hat, [](const ChannelMetrics& m) { return m.mae; });
}
Eigen::VectorXd Nmae(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat) {
  return PerChannel("Nmae", y, y_hat, [](const ChannelMetrics& m) { return m.nmae; });
}
Eigen::VectorXd Nmse(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat) {
  return PerChannel("Nmse", y, y_hat, [](const ChannelMetrics& m) { return m.nmse; });
}

MetricReport ComputeMetrics(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat,
                            const MetricOptions& options) {
  if (y.rows() != y_hat.rows() || y.cols() != y_hat.cols()) {
    Fail("ComputeMetrics",
         "expected y_hat of size " + Shape(y) + " (the size of y), got " + Shape(y_hat));
  }
  if (options.skip_samples < 0 || options.skip_samples >= y.rows()) {
    Fail("ComputeMetrics", "expected 0 <= skip_samples < " + std::to_string(y.rows()) +
                               " (the number of samples), got " +
                               std::to_string(options.skip_samples));
  }
  const Eigen::Index m = y.cols();
  if (m == 0) Fail("ComputeMetrics", "expected at least 1 channel, got 0");
  for (const auto* labels : {&options.channel_names, &options.channel_units}) {
    if (!labels->empty() && static_cast<Eigen::Index>(labels->size()) != m) {
      Fail("ComputeMetrics", "expected channel names/units with " + std::to_string(m) +
                                 " entries (one per column) or none, got " +
                                 std::to_string(labels->size()));
    }
  }
  const Eigen::Index n = y.rows() - options.skip_samples;
  const Eigen::MatrixXd yk = y.bottomRows(n);
  const Eigen::MatrixXd yhk = y_hat.bottomRows(n);
  CheckPair("ComputeMetrics", yk, yhk);

  MetricReport report;
  report.samples = static_cast<int>(n);
  report.skipped = options.skip_samples;
  ChannelMetrics& all = report.overall;
  all = ChannelMetrics{};
  all.name = "overall";
  bool same_unit = !options.channel_units.empty();
  double rmse_sq = 0.0;
  for (Eigen::Index j = 0; j < m; ++j) {
    ChannelMetrics c = FromSums(ChannelSums(yk, yhk, j));
    const size_t sj = static_cast<size_t>(j);
    c.name = options.channel_names.empty() ? "y" + std::to_string(j) : options.channel_names[sj];
    c.unit = options.channel_units.empty() ? "" : options.channel_units[sj];
    if (same_unit && options.channel_units[sj] != options.channel_units[0]) same_unit = false;
    rmse_sq += c.rmse * c.rmse;
    all.mae += c.mae;
    all.nrmse += c.nrmse;
    all.r2 += c.r2;
    all.fit_percent += c.fit_percent;
    all.vaf_percent += c.vaf_percent;
    all.nmae += c.nmae;
    all.nmse += c.nmse;
    report.channels.push_back(c);
  }
  const double dm = static_cast<double>(m);
  all.rmse = std::sqrt(rmse_sq / dm);
  all.mae /= dm;
  all.nrmse /= dm;
  all.r2 /= dm;
  all.fit_percent /= dm;
  all.vaf_percent /= dm;
  all.nmae /= dm;
  all.nmse /= dm;
  all.unit = same_unit ? options.channel_units[0] : "";
  return report;
}

MetricReport ComputeMetrics(const Experiment& experiment, const Eigen::MatrixXd& y_hat,
                            const MetricOptions& options) {
  MetricOptions o = options;
  if (o.channel_names.empty()) {
    for (int j = 0; j < experiment.NumOutputs(); ++j) {
      o.channel_names.push_back(experiment.ChannelName(ChannelGroup::kOutput, j));
    }
  }
  if (o.channel_units.empty()) o.channel_units = experiment.y_units;
  return ComputeMetrics(experiment.y, y_hat, o);
}

std::string MetricReport::BriefReport() const {
  std::ostringstream os;
  os << channels.size() << (channels.size() == 1 ? " channel, " : " channels, ") << samples
     << " samples";
  if (skipped > 0) os << " (" << skipped << " skipped)";
  os << ": FIT " << Num(overall.fit_percent, "%.2f") << " %, R^2 " << Num(overall.r2, "%.5f")
     << ", NRMSE " << Num(overall.nrmse, "%.4f") << ", VAF " << Num(overall.vaf_percent, "%.2f")
     << " %";
  return os.str();
}

std::string MetricReport::FullReport() const {
  std::ostringstream os;
  os << BriefReport() << "\n";
  size_t width = 8;
  for (const ChannelMetrics& c : channels) {
    width = std::max(width, c.name.size() + (c.unit.empty() ? 0 : c.unit.size() + 3) + 2);
  }
  os << Pad("channel", width) << Pad("RMSE", 12) << Pad("MAE", 12) << Pad("NRMSE", 9)
     << Pad("R^2", 10) << Pad("FIT %", 9) << Pad("VAF %", 9) << Pad("nMAE", 9) << "nMSE\n";
  auto row = [&](const ChannelMetrics& c) {
    const std::string label = c.unit.empty() ? c.name : c.name + " [" + c.unit + "]";
    os << Pad(label, width) << Pad(Num(c.rmse, "%.4e"), 12) << Pad(Num(c.mae, "%.4e"), 12)
       << Pad(Num(c.nrmse, "%.4f"), 9) << Pad(Num(c.r2, "%.5f"), 10)
       << Pad(Num(c.fit_percent, "%.2f"), 9) << Pad(Num(c.vaf_percent, "%.2f"), 9)
       << Pad(Num(c.nmae, "%.4f"), 9) << Num(c.nmse, "%.3e") << "\n";
  };
  for (const ChannelMetrics& c : channels) row(c);
  if (channels.size() > 1) row(overall);
  return os.str();
}

// ---- N-step NRMS ----------------------------------------------------------------------------

namespace {

struct NStepSetup {
  std::vector<int> channels;
  Eigen::VectorXd sigma;
};

NStepSetup PrepareNStep(const char* function, const Eigen::MatrixXd& x,
                        const std::vector<int>& channels) {
  if (x.rows() < 2 || x.cols() < 1) {
    Fail(function,
         "expected a state trajectory with at least 2 samples and 1 channel, got " + Shape(x));
  }
  for (Eigen::Index j = 0; j < x.cols(); ++j) {
    for (Eigen::Index k = 0; k < x.rows(); ++k) {
      if (!std::isfinite(x(k, j))) {
        std::ostringstream os;
        os << "measured x(" << k << ", " << j << "): expected a finite value, got " << x(k, j);
        Fail(function, os.str());
      }
    }
  }
  NStepSetup s;
  if (channels.empty()) {
    for (int j = 0; j < static_cast<int>(x.cols()); ++j) s.channels.push_back(j);
  } else {
    for (int c : channels) {
      if (c < 0 || c >= x.cols()) {
        Fail(function, "expected channel indices in [0, " + std::to_string(x.cols()) + "), got " +
                           std::to_string(c));
      }
    }
    s.channels = channels;
  }
  s.sigma.resize(static_cast<Eigen::Index>(s.channels.size()));
  for (size_t i = 0; i < s.channels.size(); ++i) {
    const Eigen::VectorXd col = x.col(s.channels[i]);
    s.sigma(static_cast<Eigen::Index>(i)) = std::sqrt((col.array() - col.mean()).square().mean());
  }
  return s;
}

// Accumulates normalised squared errors of one simulation.
struct NStepAccumulator {
  Eigen::VectorXd channel_sum;  // per scored channel
  Eigen::VectorXd step_sum;     // per step

  void Add(const Eigen::MatrixXd& x, int start, const Eigen::MatrixXd& prediction,
           const NStepSetup& setup) {
    for (Eigen::Index k = 0; k < prediction.rows(); ++k) {
      for (size_t i = 0; i < setup.channels.size(); ++i) {
        const int c = setup.channels[i];
        const double e =
            (prediction(k, c) - x(start + 1 + k, c)) / setup.sigma(static_cast<Eigen::Index>(i));
        channel_sum(static_cast<Eigen::Index>(i)) += e * e;
        step_sum(k) += e * e;
      }
    }
  }
};

NStepResult Finish(const NStepSetup& setup, const NStepAccumulator& acc,
                   const std::vector<int>& starts, int steps) {
  NStepResult r;
  r.channels = setup.channels;
  r.sigma = setup.sigma;
  r.starts = starts;
  r.steps = steps;
  const double n_starts = static_cast<double>(starts.size());
  const double n_channels = static_cast<double>(setup.channels.size());
  r.channel_nrms = (acc.channel_sum / (n_starts * steps)).cwiseSqrt();
  r.step_nrms = (acc.step_sum / (n_starts * n_channels)).cwiseSqrt();
  r.nrms = std::sqrt(acc.channel_sum.sum() / (n_starts * steps * n_channels));
  return r;
}

void CheckPrediction(const char* function, const Eigen::MatrixXd& p, int start, int steps,
                     Eigen::Index n) {
  if (p.rows() != steps || p.cols() != n) {
    Fail(function, "simulation from start " + std::to_string(start) + ": expected " +
                       std::to_string(steps) + "x" + std::to_string(n) + " predicted states, got " +
                       Shape(p));
  }
}

}  // namespace

std::string NStepResult::BriefReport() const {
  std::ostringstream os;
  os << steps << "-step NRMS " << Num(nrms, "%.6g") << " over " << starts.size() << " starts, "
     << channels.size() << (channels.size() == 1 ? " channel" : " channels");
  return os.str();
}

NStepResult NStepNrms(const Eigen::MatrixXd& x, const SimulateFromState& simulate,
                      const NStepOptions& options) {
  const char* function = "NStepNrms";
  const NStepSetup setup = PrepareNStep(function, x, options.channels);
  const int n = static_cast<int>(x.rows());
  const int steps = options.steps;
  if (steps < 1 || steps > n - 1) {
    Fail(function, "expected 1 <= steps <= " + std::to_string(n - 1) + " (samples - 1), got " +
                       std::to_string(steps));
  }
  const int max_start = n - 1 - steps;
  const int last = options.last_start < 0 ? max_start : options.last_start;
  if (options.first_start < 0 || options.first_start > last || last > max_start) {
    Fail(function, "expected 0 <= first_start <= last_start <= " + std::to_string(max_start) +
                       " (samples - 1 - steps), got first_start " +
                       std::to_string(options.first_start) + ", last_start " +
                       std::to_string(last));
  }
  if (options.stride < 1) {
    Fail(function, "expected stride >= 1, got " + std::to_string(options.stride));
  }
  if (!simulate) Fail(function, "expected a simulate callback, got an empty std::function");
  NStepAccumulator acc;
  acc.channel_sum.setZero(static_cast<Eigen::Index>(setup.channels.size()));
  acc.step_sum.setZero(steps);
  std::vector<int> starts;
  for (int p = options.first_start; p <= last; p += options.stride) {
    const Eigen::MatrixXd prediction = simulate(p, x.row(p).transpose(), steps);
    CheckPrediction(function, prediction, p, steps, x.cols());
    acc.Add(x, p, prediction, setup);
    starts.push_back(p);
  }
  return Finish(setup, acc, starts, steps);
}

NStepResult NStepNrms(const Eigen::MatrixXd& x, const std::vector<int>& starts,
                      const std::vector<Eigen::MatrixXd>& predictions,
                      const std::vector<int>& channels) {
  const char* function = "NStepNrms";
  const NStepSetup setup = PrepareNStep(function, x, channels);
  if (starts.size() != predictions.size()) {
    Fail(function, "expected one prediction per start (" + std::to_string(starts.size()) +
                       "), got " + std::to_string(predictions.size()));
  }
  if (starts.empty()) Fail(function, "expected at least one start, got none");
  const int steps = static_cast<int>(predictions.front().rows());
  if (steps < 1) Fail(function, "expected predictions with at least 1 step, got 0 rows");
  NStepAccumulator acc;
  acc.channel_sum.setZero(static_cast<Eigen::Index>(setup.channels.size()));
  acc.step_sum.setZero(steps);
  for (size_t i = 0; i < starts.size(); ++i) {
    const int p = starts[i];
    if (p < 0 || p + steps > x.rows() - 1) {
      Fail(function, "start " + std::to_string(p) + " with " + std::to_string(steps) +
                         " steps: expected 0 <= start <= " + std::to_string(x.rows() - 1 - steps) +
                         " (samples - 1 - steps)");
    }
    CheckPrediction(function, predictions[i], p, steps, x.cols());
    acc.Add(x, p, predictions[i], setup);
  }
  return Finish(setup, acc, starts, steps);
}

}  // namespace graybox::estimators
