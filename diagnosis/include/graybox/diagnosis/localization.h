// Localize: where the sim-to-real gap lies. The residual of a fitted model's simulation on its
// validation and test splits is decomposed by output channel, time window, operating regime of the
// model's own signals and frequency band, tested for whiteness and for correlation with the inputs
// (as MATLAB's `resid` reports them), and the pieces are ranked by how much of the error they
// concentrate in how few samples.
//
//   const estimators::FitResult fit = estimators::Fit(problem, splits);
//   const Localization loc = Localize(problem.built, fit.values, fit.evaluations);
//   std::cout << loc.BriefReport() << "\n" << loc.FullReport();
//   for (const LocalizationEntry& e : loc.entries) ...   // ranked, most telling first
//
// ---- Splits ------------------------------------------------------------------------------------
// The splits whose role is validation or test are used. When there is none, every split is used
// and Localization::used_all_splits says so (the estimation data then localise an in-sample gap).
//
// ---- The normalised residual --------------------------------------------------------------------
// For output channel j of the model (StateSpaceModel::outputs[j], in its unit) and every used
// sample k (all used splits pooled),
//
//   e_kj = (y_kj - yhat_kj) / s_j,        s_j = std(y_.j) over the used samples (population, 1/N),
//
// with y the measured and yhat the simulated output: a dimensionless residual in units of the
// measured channel's spread, so channels of different units are comparable and sum e_kj^2 / N is
// the channel's NRMSE^2 (metrics.h, normalised over the used samples). A constant measured channel
// (s_j = 0) is normalised by 1 instead and Localization::notes says so. The residual energy of a
// set S of samples of channel j is E_j(S) = sum_{k in S} e_kj^2. A sample is used when its residual
// on every channel and every regime signal below are finite (a diverged simulation's NaN tail is
// dropped, counted in Localization::num_dropped).
//
// ---- Decompositions (entries) -------------------------------------------------------------------
// Every decomposition is a partition: its entries' energy shares sum to 1 (within rounding) and so
// do their sample shares. An entry has
//
//   energy_share  = E_j(S) / E_j(all)    (kind "channel": E_j / sum_i E_i)
//   sample_share  = |S| / N              (kind "band": frequency bins in the band / all bins;
//                                         kind "channel": 1 / ny)
//   concentration = energy_share / sample_share   (1: the error is spread like the samples)
//
// and belongs to one partition, named in LocalizationEntry::partition:
// - kind "channel", partition "channels": one entry per output channel.
// - kind "window", partition "windows": each used split cut into num_windows windows of equal
//   sample count (the last takes the remainder), labelled with the split and the time range [s].
// - kind "regime": the model's signals (StateSpaceModel::signals) whose role is velocity,
//   position, acceleration, force or pressure, evaluated along the SIMULATED trajectory
//   (SplitEvaluation::states and the measured SplitEvaluation::inputs, with `values`) by
//   StateSpaceModel::EvaluateSignals: the regime in which the model believes it is. Bins come from
//   the data, labelled with their numeric range and the signal's unit.
//   * velocity v, partition "<signal> speed": with the band half-width b = near_zero_fraction *
//     max|v|, a sample is in
//       "reversal"  if it lies between two samples outside the band on opposite sides (v > b,
//                   then v < -b or the reverse) or within reversal_samples of such a transit:
//                   the approach to, passage through and departure from a change of direction;
//       "near zero" else if |v| <= b: rest and slow creeping without a change of direction;
//       else one of num_bins quantile bins of |v| over the remaining samples.
//   * velocity v, partition "<signal> direction": v > 0 and v <= 0.
//   * position, acceleration, force, pressure, partition "<signal> level": num_bins quantile bins
//     of the value. Equal quantiles (a signal dwelling on one value) merge bins; a constant signal
//     gives no partition (noted).
// - kind "band", partition "bands": each channel's residual and measured output, per used split,
//   mean removed, Hann-windowed and zero-padded to a power of two, give periodograms |X(f)|^2 on
//   the bins f_m = m fs / nfft, m = 0 .. nfft/2 (fs from the split's mean sample interval). The
//   bins are grouped into num_bands bands with log-spaced edges from the lowest non-zero bin
//   frequency to the Nyquist frequency (the DC bin joins the first band). Per band:
//   energy_share = the band's share of the residual's periodogram (all splits summed) and
//   BandEnergy::power_ratio = residual power / measured-output power in the band (> 1: the model
//   adds more than the signal has there; ~1 at low frequency: the model misses the signal).
//   The shares are of the windowed, mean-removed spectrum, not of E_j: a constant offset of the
//   residual does not appear here (it shows in the windows).
//
// Ranking. The entries are sorted by the score
//
//   score = energy_share * ln(concentration)      (descending; ties by energy share)
//
// which is the entry's term of the Kullback-Leibler divergence KL(energy || samples) of its
// partition, sum_S p_E(S) ln(p_E(S) / p_S(S)) >= 0. It is positive only where energy is
// concentrated (concentration > 1), grows with both how much of the error an entry holds and how
// few samples hold it, and is comparable across partitions of different sizes. The plain excess
// energy_share - sample_share favours broad entries more; energy_share alone ignores how many
// samples carry it. Entries with no energy or no samples score 0.
//
// ---- Whiteness and input correlation (MATLAB resid) ---------------------------------------------
// With e the channel's residual and u_i an input, each mean-removed per split, and sums running
// within each split (pairs never straddle two splits), over the N used samples:
//
//   r_ee(tau) = sum_k e_k e_{k+tau} / sum_k e_k^2,                         tau = 1 .. max_lag
//   r_eu(tau) = sum_k e_{k+tau} u_k / sqrt(sum_k e_k^2 sum_k u_k^2),       tau = -max_lag ..
//   max_lag
//
// Positive tau: the residual follows the input by tau samples (a residual equal to the input
// delayed by d samples peaks at tau = d). Both are tested against the band +-z / sqrt(N) with z
// the two-sided normal quantile of `confidence` (2.576 for 0.99), the approximate bound for a
// white residual independent of the input; fraction_outside counts the lags beyond it. A white
// residual leaves about (1 - confidence) of the lags outside.
//
// Failure behaviour. Bad sizes (a split whose time, measured, simulated, states or inputs disagree
// with each other or with the model, a parameter vector of the wrong length), no split, or splits
// too short for the options throw std::invalid_argument: "split 'test': simulated has 3 columns;
// expected 2 (the model's outputs)". Invalid options throw from LocalizationOptions::Validate.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/estimators/fit/fit.h"
#include "graybox/models/model.h"

namespace graybox::diagnosis {

struct LocalizationOptions {
  /// Equal windows per used split (>= 1).
  int num_windows = 10;
  /// Quantile bins of a regime signal (>= 1): of |v| outside the near-zero and reversal bands, of
  /// the value for positions, accelerations, forces and pressures.
  int num_bins = 4;
  /// |v| <= near_zero_fraction * max|v| is the near-zero band of a velocity (in [0, 1)).
  double near_zero_fraction = 0.02;
  /// Samples on each side of a transit through the near-zero band that still count as the
  /// reversal (>= 0).
  int reversal_samples = 5;
  /// Largest lag of the auto- and cross-correlations [samples] (>= 1).
  int max_lag = 50;
  /// Log-spaced frequency bands up to the Nyquist frequency (>= 1).
  int num_bands = 8;
  /// Two-sided confidence of the correlation bounds, in (0, 1).
  double confidence = 0.99;
  /// Throws std::invalid_argument naming the first invalid field and its value.
  void Validate() const;
};

/// One piece of the residual: a channel's share of the energy in a window, regime or band.
struct LocalizationEntry {
  std::string channel;    // output name
  std::string kind;       // "channel", "window", "regime", "band"
  std::string partition;  // "channels", "windows", "bands", "load.qd speed", "load.q level", ...
  std::string signal;     // the regime signal (kind "regime"), else empty
  std::string label;      // "load.qd in [-0.002, 0.002] m/s (near zero)"
  double energy_share = 0.0;
  double sample_share = 0.0;
  double concentration = 0.0;  // energy_share / sample_share (0 when sample_share is 0)
  double score = 0.0;          // energy_share * ln(concentration), 0 without energy
  /// Inclusive value range of the bin [lower, upper] in the signal's unit (regime, band [Hz]);
  /// window: its time range [s]. NaN where it does not apply.
  double lower = 0.0, upper = 0.0;
};

/// One output channel's residual.
struct ChannelResidual {
  std::string name, unit;
  double scale = 1.0;         // s_j, the measured channel's std [unit]
  double energy = 0.0;        // E_j = sum e_kj^2 (dimensionless)
  double energy_share = 0.0;  // E_j / sum_i E_i
  double nrmse = 0.0;         // sqrt(E_j / N)
};

/// One frequency band of one channel.
struct BandEnergy {
  std::string channel;
  double f_low = 0.0, f_high = 0.0;  // [Hz]
  double residual_share = 0.0;       // of the residual's periodogram
  double output_share = 0.0;         // of the measured output's periodogram
  double power_ratio = 0.0;          // residual power / output power in the band (NaN if 0/0)
  int num_bins = 0;
};

/// Autocorrelation of one channel's residual, lags 1 .. max_lag.
struct Whiteness {
  std::string channel;
  std::vector<double> correlation;  // r_ee(1 .. max_lag)
  double bound = 0.0;               // z / sqrt(N)
  double fraction_outside = 0.0;
  int worst_lag = 0;  // lag of max |r_ee|
};

/// Cross-correlation of one channel's residual with one input, lags -max_lag .. max_lag.
struct CrossCorrelation {
  std::string channel, input;
  std::vector<int> lags;
  std::vector<double> correlation;  // r_eu(lags[i])
  double bound = 0.0;
  double fraction_outside = 0.0;
  int peak_lag = 0;  // lag of max |r_eu|
  double peak = 0.0;
};

struct Localization {
  LocalizationOptions options;
  std::vector<std::string> splits;  // the used splits, in order
  bool used_all_splits = false;     // no validation or test split: every split was used
  int num_samples = 0;              // N, used samples
  int num_dropped = 0;              // samples with a non-finite residual or regime signal
  double z = 0.0;                   // the normal quantile of `confidence`
  std::vector<ChannelResidual> channels;
  std::vector<std::string> regime_signals;  // the signals the regimes were taken from
  /// Every entry of every partition, ranked by score (descending).
  std::vector<LocalizationEntry> entries;
  std::vector<BandEnergy> bands;  // per channel, low to high
  std::vector<Whiteness> whiteness;
  std::vector<CrossCorrelation> cross_correlations;  // channel-major, inputs in model order
  std::vector<std::string> notes;                    // skipped signals, fallbacks

  /// The entries of one kind ("regime", ...) in rank order, optionally of one channel.
  std::vector<LocalizationEntry> Entries(const std::string& kind,
                                         const std::string& channel = "") const;
  /// "gap on 'test': force carries 100 % of the residual energy (NRMSE 0.31); top: force, load.qd
  /// reversal ...: 41 % of the energy in 3.2 % of the samples (x12.8); residual not white (88 % of
  /// lags outside +-0.018)".
  std::string BriefReport() const;
  /// The brief line, the channels, the top entries of each kind, the bands, the whiteness and
  /// input-correlation summaries, and the notes.
  std::string FullReport(int max_entries_per_kind = 5) const;
};

/// Localizes the residual of `splits` (simulations of `model` with parameter values `values`, as
/// estimators::Simulate or FitResult::evaluations give them). See the file comment.
Localization Localize(const models::StateSpaceModel& model, const Eigen::VectorXd& values,
                      const std::vector<estimators::SplitEvaluation>& splits,
                      const LocalizationOptions& options = {});

/// The two-sided standard normal quantile: P(|Z| <= z) = confidence (2.5758 for 0.99).
/// std::invalid_argument unless 0 < confidence < 1.
double NormalQuantileTwoSided(double confidence);

}  // namespace graybox::diagnosis
