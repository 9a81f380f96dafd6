#include "graybox/estimators/analysis/metrics.h"

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

// Statistics of one channel, as means: the error terms over the scored rows, the spread and
// magnitude of y over the reference rows (metrics.h, "Scoring part of a record").
struct Stats {
  double mse = 0.0;         // mean e^2 over the scored rows
  double mae = 0.0;         // mean |e|
  double mean_e = 0.0;      // mean e
  double var_y = 0.0;       // population variance of y over the reference rows
  double mean_abs_y = 0.0;  // mean |y|
  double mean_y2 = 0.0;     // mean y^2
};

// rows: the scored rows; reference: the rows defining the normalisation (both non-empty).
Stats ChannelStats(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat, Eigen::Index j,
                   const std::vector<Eigen::Index>& rows,
                   const std::vector<Eigen::Index>& reference) {
  Stats s;
  for (Eigen::Index k : rows) {
    const double e = y(k, j) - y_hat(k, j);
    s.mse += e * e;
    s.mae += std::abs(e);
    s.mean_e += e;
  }
  const double n = static_cast<double>(rows.size());
  s.mse /= n;
  s.mae /= n;
  s.mean_e /= n;
  double mean_y = 0.0;
  for (Eigen::Index k : reference) mean_y += y(k, j);
  const double n_ref = static_cast<double>(reference.size());
  mean_y /= n_ref;
  for (Eigen::Index k : reference) {
    const double d = y(k, j) - mean_y;
    s.var_y += d * d;
    s.mean_abs_y += std::abs(y(k, j));
    s.mean_y2 += y(k, j) * y(k, j);
  }
  s.var_y /= n_ref;
  s.mean_abs_y /= n_ref;
  s.mean_y2 /= n_ref;
  return s;
}

std::vector<Eigen::Index> AllRows(Eigen::Index n) {
  std::vector<Eigen::Index> rows(static_cast<std::size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k) rows[static_cast<std::size_t>(k)] = k;
  return rows;
}

double Ratio(double num, double den) { return den > 0.0 ? num / den : kNaN; }

ChannelMetrics FromStats(const Stats& s) {
  ChannelMetrics m;
  m.rmse = std::sqrt(s.mse);           // (3-8)
  m.mae = s.mae;                       // (3-9)
  m.r2 = 1.0 - Ratio(s.mse, s.var_y);  // (3-10)
  const double var_e = s.mse - s.mean_e * s.mean_e;
  m.vaf_percent = 100.0 * (1.0 - Ratio(std::max(var_e, 0.0), s.var_y));  // (3-11)
  m.fit_percent = 100.0 * (1.0 - std::sqrt(Ratio(s.mse, s.var_y)));      // (3-12)
  m.nrmse = std::sqrt(Ratio(s.mse, s.var_y));                            // RMSE / std(y)
  m.nmae = Ratio(s.mae, s.mean_abs_y);                                   // seed 001 (2)
  m.nmse = Ratio(s.mse, s.mean_y2);                                      // seed 001 (3)
  if (!std::isfinite(s.mse) || !std::isfinite(s.mae)) {
    // NaN or Inf in the prediction: every metric of the channel is undefined.
    m.rmse = m.mae = m.r2 = m.vaf_percent = m.fit_percent = m.nrmse = m.nmae = m.nmse = kNaN;
  }
  return m;
}

template <typename Field>
Eigen::VectorXd PerChannel(const char* function, const Eigen::MatrixXd& y,
                           const Eigen::MatrixXd& y_hat, Field field) {
  CheckPair(function, y, y_hat);
  const std::vector<Eigen::Index> rows = AllRows(y.rows());
  Eigen::VectorXd out(y.cols());
  for (Eigen::Index j = 0; j < y.cols(); ++j) {
    out(j) = field(FromStats(ChannelStats(y, y_hat, j, rows, rows)));
  }
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
  CheckPair("ComputeMetrics", y.bottomRows(y.rows() - options.skip_samples),
            y_hat.bottomRows(y.rows() - options.skip_samples));
  const Eigen::Index rows = y.rows();
  if (!options.mask.empty() && static_cast<Eigen::Index>(options.mask.size()) != rows) {
    Fail("ComputeMetrics", "expected a mask of " + std::to_string(rows) +
                               " entries (one per row of y), got " +
                               std::to_string(options.mask.size()));
  }
  const Eigen::Index window_end = options.window_end < 0 ? rows : options.window_end;
  if (options.window_begin < 0 || options.window_begin >= window_end || window_end > rows ||
      options.window_end < -1) {
    Fail("ComputeMetrics", "expected a window 0 <= window_begin < window_end <= " +
                               std::to_string(rows) + " (the number of rows; window_end = -1 " +
                               "for the end), got [" + std::to_string(options.window_begin) + ", " +
                               std::to_string(options.window_end) + ")");
  }
  // Reference rows: the kept record; scored rows: those the window and the mask admit too.
  std::vector<Eigen::Index> reference, scored;
  for (Eigen::Index k = options.skip_samples; k < rows; ++k) {
    reference.push_back(k);
    const bool in_window = k >= options.window_begin && k < window_end;
    const bool in_mask = options.mask.empty() || options.mask[static_cast<std::size_t>(k)];
    if (in_window && in_mask) scored.push_back(k);
  }
  if (scored.empty()) {
    Fail("ComputeMetrics",
         "expected at least 1 scored row, got none (skip_samples " +
             std::to_string(options.skip_samples) + ", window [" +
             std::to_string(options.window_begin) + ", " + std::to_string(window_end) + "), " +
             (options.mask.empty() ? std::string("no mask") : "a mask of " + std::to_string(rows)) +
             ")");
  }
  if (options.normalization == MetricNormalization::kScoredSamples) reference = scored;

  MetricReport report;
  report.samples = static_cast<int>(scored.size());
  report.skipped = options.skip_samples;
  report.reference_samples = static_cast<int>(reference.size());
  ChannelMetrics& all = report.overall;
  all = ChannelMetrics{};
  all.name = "overall";
  bool same_unit = !options.channel_units.empty();
  double rmse_sq = 0.0;
  for (Eigen::Index j = 0; j < m; ++j) {
    ChannelMetrics c = FromStats(ChannelStats(y, y_hat, j, scored, reference));
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
  if (reference_samples != samples) os << " normalised over " << reference_samples;
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
  std::vector<std::string> names;  // of the scored channels, or empty
  Eigen::VectorXd sigma;
};

NStepSetup PrepareNStep(const char* function, const Eigen::MatrixXd& x,
                        const std::vector<int>& channels, const std::vector<std::string>& names) {
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
    for (std::size_t i = 0; i < channels.size(); ++i) {
      const int c = channels[i];
      if (c < 0 || c >= x.cols()) {
        Fail(function, "expected channel indices in [0, " + std::to_string(x.cols()) + "), got " +
                           std::to_string(c));
      }
      if (std::find(channels.begin(), channels.begin() + static_cast<std::ptrdiff_t>(i), c) !=
          channels.begin() + static_cast<std::ptrdiff_t>(i)) {
        Fail(function, "expected distinct channel indices, got " + std::to_string(c) + " twice");
      }
    }
    s.channels = channels;
  }
  if (!names.empty()) {
    if (static_cast<Eigen::Index>(names.size()) != x.cols()) {
      Fail(function, "expected " + std::to_string(x.cols()) +
                         " channel names (one per column of x) or none, got " +
                         std::to_string(names.size()));
    }
    for (int c : s.channels) s.names.push_back(names[static_cast<std::size_t>(c)]);
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
  r.channel_names = setup.names;
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

double NStepResult::NrmsAtStep(int k) const {
  if (k < 1 || k > step_nrms.size()) {
    throw std::out_of_range("NStepResult::NrmsAtStep: expected 1 <= k <= " +
                            std::to_string(step_nrms.size()) + ", got " + std::to_string(k));
  }
  return step_nrms(k - 1);
}

std::string NStepResult::BriefReport() const {
  std::ostringstream os;
  os << steps << "-step NRMS " << Num(nrms, "%.6g");
  if (steps > 0 && step_nrms.size() == steps) {
    os << " (NRMS at step " << steps << ": " << Num(step_nrms(steps - 1), "%.6g") << ")";
  }
  os << " over " << starts.size() << " starts, " << channels.size()
     << (channels.size() == 1 ? " channel" : " channels");
  if (!evaluation.empty()) os << " (" << evaluation << ")";
  return os.str();
}

NStepResult NStepNrms(const Eigen::MatrixXd& x, const SimulateFromState& simulate,
                      const NStepOptions& options) {
  const char* function = "NStepNrms";
  const NStepSetup setup = PrepareNStep(function, x, options.channels, options.names);
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
                      const std::vector<int>& channels, const std::vector<std::string>& names) {
  const char* function = "NStepNrms";
  const NStepSetup setup = PrepareNStep(function, x, channels, names);
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
