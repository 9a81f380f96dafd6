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
// 15000 - 150 = 14850 as in the seed) and the scored channels c (all by default; eq. 7 applies
// [.]_[1:6], the positions, in its notation), with sigma_c the standard deviation (population)
// of channel c over all N samples of x. This is the seed's "average of the squared errors ...
// weighting the channels by 1/sigma_p" under a square root; eq. 7's printed form lost the square
// inside the norm and the averaging. eta is unitless; 0 is a perfect simulator. Per-channel
// values sqrt(mean over p, k) and per-step values sqrt(mean over p, c) come with it, and
// eta^2 = mean over channels of the per-channel eta_c^2.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/dataset.h"

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

struct MetricOptions {
  /// Rows ignored at the start (for example the 20-sample state initialisation window of the
  /// nonlinear_benchmarks EMPS convention). Must leave at least one row.
  int skip_samples = 0;
  /// Channel names and units for the report (empty, or one per column). Default names "y0", ...
  std::vector<std::string> channel_names;
  std::vector<std::string> channel_units;
};

struct MetricReport {
  std::vector<ChannelMetrics> channels;
  ChannelMetrics overall;  // name "overall"; see the file comment for how channels combine
  int samples = 0;         // rows used per channel
  int skipped = 0;         // rows ignored at the start

  /// "2 channels, 24821 samples: FIT 96.80 %, R^2 0.99898, NRMSE 0.0320, VAF 99.90 %"
  std::string BriefReport() const;
  /// The brief line, then one table row per channel and the overall row with all metrics.
  std::string FullReport() const;
};

/// Computes every metric per channel and overall. Throws std::invalid_argument on a size
/// mismatch, a non-finite measurement, or names/units of the wrong count.
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
  /// Scored columns of x (0-based); empty scores all.
  std::vector<int> channels;
};

struct NStepResult {
  double nrms = 0.0;             // eta_N
  Eigen::VectorXd channel_nrms;  // one per scored channel
  Eigen::VectorXd step_nrms;     // one per step k = 1..steps (error growth along the horizon)
  Eigen::VectorXd sigma;         // standard deviation of each scored channel
  std::vector<int> channels;     // the scored columns
  std::vector<int> starts;       // the start samples used
  int steps = 0;
  /// "150-step NRMS 0.0434 over 14850 starts, 12 channels".
  std::string BriefReport() const;
};

/// eta_N of a simulator over a measured state trajectory x (N x n). Throws std::invalid_argument
/// when the horizon or start range does not fit in N samples, a channel index is out of range,
/// x is not finite, or `simulate` returns a matrix other than steps x n.
NStepResult NStepNrms(const Eigen::MatrixXd& x, const SimulateFromState& simulate,
                      const NStepOptions& options = {});

/// eta_N from precomputed simulations: predictions[i] (steps x n) holds the simulation from
/// sample starts[i] for the samples starts[i] + 1 .. starts[i] + steps. All predictions must have
/// the same number of rows (the horizon) and n columns; every start + steps <= N - 1.
NStepResult NStepNrms(const Eigen::MatrixXd& x, const std::vector<int>& starts,
                      const std::vector<Eigen::MatrixXd>& predictions,
                      const std::vector<int>& channels = {});

}  // namespace graybox::estimators
