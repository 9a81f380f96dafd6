// Fit metrics between measured signals y and model predictions (simulated or predicted) y_hat.
//
//   MetricOptions options;
//   options.skip_samples = 20;
//   MetricReport report = ComputeMetrics(y_test, y_sim, options);
//   std::cout << report.BriefReport() << "\n" << report.FullReport();
//
// Signals are N x m (one row per sample, one column per channel); every metric is computed per
// channel over the rows skip_samples .. N-1. For channel j, with e_k = y_k - y_hat_k over the
// N' kept samples, ybar the mean of y over them, var the population variance (1/N') and std its
// square root:
//
//   RMSE   = sqrt(1/N' sum e_k^2)                                        seed 002 eq. (3-8)
//   MAE    = 1/N' sum |e_k|                                              seed 002 eq. (3-9)
//   R^2    = 1 - sum e_k^2 / sum (y_k - ybar)^2                          seed 002 eq. (3-10)
//   VAF %  = 100 (1 - var(e) / var(y))                                   seed 002 eq. (3-11)
//   FIT %  = 100 (1 - ||y - y_hat||_2 / ||y - ybar||_2)                  seed 002 eq. (3-12)
//   NRMSE  = RMSE / std(y)
//   nMAE   = sum |y_hat_k - y_k| / sum |y_k|                             seed 001 eq. (2)
//   nMSE   = sum (y_hat_k - y_k)^2 / sum y_k^2                           seed 001 eq. (3)
//
// Notes on the variants.
// - (3-10) is printed in seed 002 as the bare ratio; the coefficient of determination is 1 minus
//   it, as the seed's tables (R^2 close to 1 for good models) show.
// - (3-12) is printed with sums whose norm bars were lost in the text; the seed's own tables obey
//   the 2-norm form (ARX: R^2 = 0.897 gives 100 (1 - sqrt(1 - R^2)) = 67.9, printed 68.05; LuGre:
//   0.942 gives 75.9, printed 75.93), which is also MATLAB compare's NRMSE fit.
// - NRMSE is normalised by the standard deviation of the measurement (population, 1/N'), not by
//   its range or mean. With this choice NRMSE = sqrt(1 - R^2) = 1 - FIT/100 exactly.
// - VAF ignores a constant offset of the error (var removes the mean); FIT and R^2 do not.
// - nMAE and nMSE normalise by the magnitude of y, not its spread: they depend on offsets of y
//   (seed 001 applies them to joint torques, which swing around zero).
// Perfect prediction: RMSE = MAE = nMAE = nMSE = NRMSE = 0, R^2 = 1, FIT = VAF = 100.
// Predicting the mean ybar: R^2 = 0, FIT = 0, VAF = 0, NRMSE = 1.
//
// ---- Scoring part of a record: a window or a sample mask --------------------------------------
// MetricOptions::window_begin/window_end and MetricOptions::mask restrict the SCORED samples S
// (the error terms: RMSE, MAE, mean(e), sum e^2) to a subset of the kept rows R = skip_samples ..
// N-1. Written with means, every metric is a ratio of an error statistic over S to a spread or
// magnitude of y over a REFERENCE set:
//
//   RMSE = sqrt(mean_S e^2)                 MAE  = mean_S |e|
//   NRMSE = RMSE / std_ref(y)               R^2  = 1 - mean_S e^2 / var_ref(y)
//   FIT % = 100 (1 - RMSE / std_ref(y))     VAF % = 100 (1 - var_S(e) / var_ref(y))
//   nMAE = mean_S |e| / mean_ref |y|        nMSE = mean_S e^2 / mean_ref y^2
//
// which are exactly the formulas above when S = ref = R. The reference set is chosen by
// MetricOptions::normalization:
// - kRecord (default): ref = R, the whole kept record. A window's NRMSE is its RMS error in units
//   of the record's spread, so it is comparable with the whole-record NRMSE and with every other
//   window: for windows that partition R, NRMSE_record^2 = sum_w (N_w / N') NRMSE_w^2 (and R^2,
//   nMSE are the same weighted means). Normalising by the window instead would divide by the
//   window's own spread: a quiet window (a robot at rest, a plateau) has a small std, and a small
//   error there would score a large NRMSE, so per-window values would not be comparable with each
//   other nor with the whole record. This is the right choice for locating where in a record a
//   model fails.
// - kScoredSamples: ref = S. The metrics of the window as if it were a record of its own: equal
//   to ComputeMetrics of the sliced rows (e.g. a published test split cut out of a longer record).
// RMSE and MAE do not depend on the choice.
//
// Undefined values are NaN, never an exception: a constant measured channel has no spread (R^2,
// FIT, VAF, NRMSE are NaN), an all-zero one no magnitude (nMAE, nMSE are NaN), and a NaN in
// y_hat (a diverged simulation) makes that channel's metrics NaN. Bad arguments (size mismatch,
// NaN/Inf in the measurement, skip_samples leaving no sample) throw std::invalid_argument.
//
// Overall values (MetricReport::overall): the mean over channels of R^2, FIT, VAF, NRMSE, nMAE,
// nMSE and MAE, and the root mean square over channels of RMSE (= RMS over all entries). Overall
// RMSE and MAE mix units when the channels do; prefer the normalised ones then. A NaN in any
// channel makes the corresponding overall value NaN.
//
// ---- N-step NRMS (seed 000 eq. 7) -------------------------------------------------------------
// For a state trajectory x (N x n, measured or filtered) and a model simulated from the measured
// state at sample p for N_steps steps, predicting x_hat^(k,p) for sample p + k (k = 1..N_steps):
//
//   eta_N = sqrt( 1/(N_starts N_steps n_c) sum_p sum_k sum_c ((x_hat_c^(k,p) - x_c,p+k) /
//   sigma_c)^2 )
//
// over the starts p (by default every p = 0 .. N-1-N_steps, so N_starts = N - N_steps, e.g.
// 15000 - 150 = 14850 as in the seed) and the scored channels c (all columns by default;
// eq. 7 applies [.]_[1:6], the positions, in its notation; problem files default to the
// measured states, MetricsSpec::n_step_channels), with sigma_c the standard deviation
// (population) of channel c over all N samples of x. This is the seed's "average of the squared
// errors ... weighting the channels by 1/sigma_p" under a square root; eq. 7's printed form lost
// the square inside the norm and the averaging. eta is unitless; 0 is a perfect simulator.
// Per-channel values sqrt(mean over p, k) and per-step values sqrt(mean over p, c) come with it,
// and eta^2 = mean over channels of the per-channel eta_c^2.
//
// Names. "N-step NRMS" (eta_N, "150-step NRMS" for N = 150) is ALWAYS this mean over the steps
// k = 1..N. The error at one step k alone,
//
//   eta^(k) = sqrt( 1/(N_starts n_c) sum_p sum_c ((x_hat_c^(k,p) - x_c,p+k) / sigma_c)^2 ),
//
// is the "NRMS at step k" (NStepResult::step_nrms(k - 1), NStepResult::NrmsAtStep(k)); the
// "NRMS at step N" is its value at the end of the horizon. eta_N^2 is the mean of eta^(k)^2 over
// k = 1..N, so eta_N <= max_k eta^(k), and for an error that grows along the horizon
// eta_N < NRMS at step N (for an error growing linearly in k, eta_N ~ NRMS at step N / sqrt(3)).
// roblue's code (whose "150_step_nrms" output seed 000's tables are built from, by its README)
// reports the NRMS at step N of the positions squared, not eta_N (docs/problem-format.md).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/data/dataset.h"

namespace graybox::estimators {

// ---- Per-channel metrics (one entry per column) ----------------------------------------------
// Each takes measured y and predicted y_hat of equal size (N x m, N >= 1) and returns m values.

Eigen::VectorXd Rmse(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat);
Eigen::VectorXd Nrmse(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat);
Eigen::VectorXd RSquared(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat);
Eigen::VectorXd FitPercent(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat);
Eigen::VectorXd VafPercent(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat);
Eigen::VectorXd Mae(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat);
Eigen::VectorXd Nmae(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat);
Eigen::VectorXd Nmse(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat);

/// All metrics of one channel (or their overall combination).
struct ChannelMetrics {
  std::string name;
  std::string unit;  // of RMSE and MAE ("" when unknown or mixed)
  double rmse = 0.0;
  double nrmse = 0.0;
  double r2 = 0.0;
  double fit_percent = 0.0;
  double vaf_percent = 0.0;
  double mae = 0.0;
  double nmae = 0.0;
  double nmse = 0.0;
};

/// Which samples define the spread and magnitude of y that NRMSE, R^2, FIT, VAF, nMAE and nMSE
/// divide by when only part of the record is scored (see "Scoring part of a record" above).
enum class MetricNormalization {
  kRecord,         // every kept row (skip_samples .. N-1): windows comparable with the record
  kScoredSamples,  // only the scored rows: the metrics of the sliced data
};

struct MetricOptions {
  /// Rows ignored at the start (for example the 20-sample state initialisation window of the
  /// nonlinear_benchmarks EMPS convention). Must leave at least one row.
  int skip_samples = 0;
  /// Scored window [window_begin, window_end) in rows of y (0-based, counting the skipped rows);
  /// window_end = -1 means N. Rows before skip_samples are never scored.
  int window_begin = 0;
  int window_end = -1;
  /// Scored rows: empty scores every row, else one entry per row of y (true = scored). Combined
  /// with the window and skip_samples: a row is scored when all three admit it.
  std::vector<bool> mask;
  /// The normalisation when a window or mask is given (irrelevant otherwise).
  MetricNormalization normalization = MetricNormalization::kRecord;
  /// Channel names and units for the report (empty, or one per column). Default names "y0", ...
  std::vector<std::string> channel_names;
  std::vector<std::string> channel_units;
};

struct MetricReport {
  std::vector<ChannelMetrics> channels;
  ChannelMetrics overall;     // name "overall"; see the file comment for how channels combine
  int samples = 0;            // rows scored per channel
  int skipped = 0;            // rows ignored at the start
  int reference_samples = 0;  // rows that define the normalisation (= samples unless masked)

  /// "2 channels, 24821 samples: FIT 96.80 %, R^2 0.99898, NRMSE 0.0320, VAF 99.90 %"
  std::string BriefReport() const;
  /// The brief line, then one table row per channel and the overall row with all metrics.
  std::string FullReport() const;
};

/// Computes every metric per channel and overall. Throws std::invalid_argument on a size
/// mismatch, a non-finite measurement, names/units of the wrong count, a mask whose size is not
/// the number of rows ("expected a mask of N entries (one per row of y), got M"), a window
/// outside [0, N], or a selection that leaves no scored row.
MetricReport ComputeMetrics(const Eigen::MatrixXd& y, const Eigen::MatrixXd& y_hat,
                            const MetricOptions& options = {});

/// The same against an experiment's outputs, with its output names and units (options'
/// names/units, when given, take precedence).
MetricReport ComputeMetrics(const Experiment& experiment, const Eigen::MatrixXd& y_hat,
                            const MetricOptions& options = {});

// ---- N-step NRMS ----------------------------------------------------------------------------

/// Simulates the model from the measured state `state` (row `start` of x) for `steps` steps and
/// returns the predicted states of samples start + 1 .. start + steps as a steps x n matrix (all
/// n columns of x, in order). Called once per start, sequentially.
using SimulateFromState =
    std::function<Eigen::MatrixXd(int start, const Eigen::VectorXd& state, int steps)>;

struct NStepOptions {
  /// N_steps, the simulation horizon (150 in seed 000: 0.6 s at 4 ms).
  int steps = 150;
  /// Starts first_start, first_start + stride, ... up to last_start (inclusive); last_start < 0
  /// means the last possible, N - 1 - steps.
  int first_start = 0;
  int last_start = -1;
  int stride = 1;
  /// Scored columns of x (0-based, distinct, in the order given); empty scores all.
  std::vector<int> channels;
  /// Names of the columns of x (empty, or one per column): the result's channel_names are the
  /// scored ones, so a report can say which were scored.
  std::vector<std::string> names;
};

struct NStepResult {
  double nrms = 0.0;                       // eta_N, the N-step NRMS (mean over steps 1..N)
  Eigen::VectorXd channel_nrms;            // one per scored channel
  Eigen::VectorXd step_nrms;               // NRMS at step k, k = 1..steps (error growth)
  Eigen::VectorXd sigma;                   // standard deviation of each scored channel
  std::vector<int> channels;               // the scored columns of x
  std::vector<std::string> channel_names;  // their names (empty when no names were given)
  std::vector<int> starts;                 // the start samples used
  int steps = 0;
  /// How the simulation was evaluated (NStepNrmsSimulated): "generated code" or "tape: <why the
  /// generated code was not used>"; empty for NStepNrms.
  std::string evaluation;
  /// The NRMS at step k alone (1 <= k <= steps): step_nrms(k - 1). NrmsAtStep(steps) is the
  /// "NRMS at step N", not to be confused with nrms. Throws std::out_of_range otherwise.
  double NrmsAtStep(int k) const;
  /// "150-step NRMS 0.0434 (NRMS at step 150: 0.0861) over 14850 starts, 12 channels".
  std::string BriefReport() const;
};

/// eta_N of a simulator over a measured state trajectory x (N x n). Throws std::invalid_argument
/// when the horizon or start range does not fit in N samples, a channel index is out of range or
/// repeated, names are not one per column, x is not finite, or `simulate` returns a matrix other
/// than steps x n.
NStepResult NStepNrms(const Eigen::MatrixXd& x, const SimulateFromState& simulate,
                      const NStepOptions& options = {});

/// eta_N from precomputed simulations: predictions[i] (steps x n) holds the simulation from
/// sample starts[i] for the samples starts[i] + 1 .. starts[i] + steps. All predictions must have
/// the same number of rows (the horizon) and n columns; every start + steps <= N - 1. `channels`
/// and `names` as in NStepOptions.
NStepResult NStepNrms(const Eigen::MatrixXd& x, const std::vector<int>& starts,
                      const std::vector<Eigen::MatrixXd>& predictions,
                      const std::vector<int>& channels = {},
                      const std::vector<std::string>& names = {});

}  // namespace graybox::estimators
