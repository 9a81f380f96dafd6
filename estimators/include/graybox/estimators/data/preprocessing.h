// Preprocessing of sampled signals: FFT low-pass and spectral differentiation of periodic records,
// zero-phase IIR filtering (Butterworth/Chebyshev-I, forward-backward like MATLAB's filtfilt),
// resampling and decimation, and central-difference derivatives.
//
// Signals are N x m matrices, one row per sample and one column per channel; every function
// treats the columns independently. Sample times are in seconds, frequencies in Hz.
// Invalid arguments (sizes, orders, cut-offs outside (0, Nyquist), non-positive dt, too short
// signals) throw std::invalid_argument with "expected X, got Y". NaN/Inf samples are not checked
// here and propagate (validate the Experiment first).
//
// ---- FFT filtering and differentiation (Retzler et al. 2024, seed 000 eq. 8) ----------------
// With the DFT  X_k = sum_n x_n exp(-2 pi i k n / N)  (Eigen's and numpy's convention), bin k has
// the signed frequency index m_k = k for k <= N/2 and m_k = k - N above (the negative
// frequencies), angular frequency  omega_k = 2 pi m_k / (N dt).
//   FftLowPass:     X_k <- 0 for every bin with |m_k| >= cutoff_bin (both the positive-frequency
//                   bin and its mirror), i.e. an ideal low-pass keeping |m| < cutoff_bin.
//   FftDerivative:  X_k <- (i omega_k)^order X_k on the kept bins, then the inverse DFT.
// Eq. 8 of seed 000 keeps the bins i <= 200 (cutoff_bin = 201 here); roblue's code, as described
// in ../shared/data/roblue_elabee/SOURCE.md, zeroes the bins >= 200 (`filter_from = 200`,
// cutoff_bin = 200 here). With
// the e^{-i...} forward transform the derivative factor is +i omega; the "-j omega" printed in
// eq. 8 belongs to the opposite sign convention and gives the same derivative.
// The methods assume the N samples are one period of a periodic signal: a record whose ends do
// not meet (a torque record, a ramp) rings near its ends (spectral leakage). For an even N the
// Nyquist bin (|m| = N/2) has no sign; odd derivative orders set it to 0.
// The transforms are Eigen's FFT module (kissfft), O(N log N) for N with small prime factors.
// kissfft treats a prime factor p with an O(N p) butterfly, and N = 24841 (EMPS) is prime (about
// 6 s per column), so a length whose largest prime factor exceeds 100 is evaluated through
// Bluestein's identity k n = (k^2 + n^2 - (k - n)^2) / 2 as a circular convolution computed with
// Eigen's FFT at a power-of-two length >= 2N - 1 (EMPS: about 25 ms per column). Both paths agree
// to rounding (tested).
//
// ---- Zero-phase IIR filtering ---------------------------------------------------------------
// Butterworth and Chebyshev-I low-pass filters are designed from their analog prototypes by the
// bilinear transform s = 2 fs (z - 1)/(z + 1) with pre-warping, so the digital response at the
// cut-off equals the analog prototype's at its cut-off: |H(fc)|^2 = 1/2 for Butterworth and
// 1/(1 + eps^2) (the ripple edge) for Chebyshev-I. In closed form, with w = 2 pi f dt and
// wc = 2 pi fc dt,
//     Butterworth:  |H(f)|^2 = 1 / (1 + (tan(w/2) / tan(wc/2))^(2 n)),
//     Chebyshev-I:  |H(f)|^2 = 1 / (1 + eps^2 T_n(tan(w/2) / tan(wc/2))^2),
//                   eps = sqrt(10^(ripple_db/10) - 1), T_n the Chebyshev polynomial.
// The analog zeros at infinity map to z = -1. The filter is kept as second-order sections (the
// layout of MATLAB's/scipy's "sos": one row b0 b1 b2 a0 a1 a2 per section, a0 = 1), which stays
// accurate at high orders and low cut-offs where the expanded polynomial does not; the DC gain
// is 1 (Butterworth, odd-order Chebyshev) or 1/sqrt(1 + eps^2) (even-order Chebyshev), exactly as
// MATLAB's butter/cheby1 and scipy.signal.butter/cheby1 with the same normalised cut-off
// Wn = fc / (fs / 2).
//
// FiltFilt runs the filter forward, then backward over the reversed output, so the phase shifts
// cancel (zero phase) and the magnitude is squared: |H|^2, i.e. -6 dB at a Butterworth cut-off.
// Edges follow MATLAB's filtfilt: the signal is extended at each end by `padding` samples of odd
// reflection (2 x_0 - x_{i} before the start, 2 x_{N-1} - x_{N-1-i} after the end; default
// 3 * order, e.g. 12 for order 4 — note scipy's default is 3 * (order + 1)), and each pass starts
// from the filter's steady state for a constant input equal to its first sample (lfilter_zi).
// Requires N > padding.
#pragma once

#include <complex>

#include <Eigen/Core>

#include "graybox/estimators/data/dataset.h"

namespace graybox::estimators {

// ---- FFT ----------------------------------------------------------------------------------------

/// Ideal periodic low-pass: keeps the bins with |m| < cutoff_bin (see above). cutoff_bin >= 1;
/// cutoff_bin > N/2 keeps everything (returns x up to rounding).
Eigen::MatrixXd FftLowPass(const Eigen::MatrixXd& x, int cutoff_bin);

/// Spectral derivative of order `order` (1 = velocity, 2 = acceleration) of the low-passed signal:
/// inverse DFT of (i omega_k)^order X_k over the bins with |m| < cutoff_bin. Units: [x] / s^order.
Eigen::MatrixXd FftDerivative(const Eigen::MatrixXd& x, double dt, int cutoff_bin, int order = 1);

/// The bin index of a cut-off frequency: the smallest m with m / (N dt) >= cutoff_hz, i.e.
/// ceil(cutoff_hz N dt), so FftLowPass keeps exactly the frequencies below cutoff_hz.
int FftCutoffBin(double cutoff_hz, int n, double dt);

// ---- IIR filters ----------------------------------------------------------------------------

/// A digital IIR filter as cascaded second-order sections.
struct SosFilter {
  /// sections x 6: b0 b1 b2 a0 a1 a2 per row, a0 = 1. A first-order section has b2 = a2 = 0.
  Eigen::MatrixXd sos;
  int order = 0;

  int NumSections() const { return static_cast<int>(sos.rows()); }
  /// The expanded transfer function B(z)/A(z), coefficients of z^0, z^-1, ... (order + 1 each,
  /// a(0) = 1). For display and comparison; filter with the sections.
  void TransferFunction(Eigen::VectorXd* b, Eigen::VectorXd* a) const;
  /// H(e^{i w}) at frequency `frequency_hz` for sample time dt (w = 2 pi f dt).
  std::complex<double> Response(double frequency_hz, double dt) const;
};

/// Butterworth low-pass of order `order` (1..20) with -3 dB cut-off `cutoff_hz`, for sample time
/// dt; requires 0 < cutoff_hz < 1 / (2 dt).
SosFilter ButterworthLowPass(int order, double cutoff_hz, double dt);

/// Chebyshev type I low-pass: equiripple passband of `ripple_db` (> 0) dB up to the passband edge
/// `cutoff_hz`, monotone stopband. Same ranges as ButterworthLowPass.
SosFilter Chebyshev1LowPass(int order, double ripple_db, double cutoff_hz, double dt);

/// One causal pass from zero initial state (MATLAB's filter / scipy's sosfilt). Introduces phase
/// lag; use FiltFilt for zero phase.
Eigen::MatrixXd FilterCausal(const SosFilter& filter, const Eigen::MatrixXd& x);

/// Zero-phase forward-backward filtering (see above). padding < 0 selects 3 * order.
Eigen::MatrixXd FiltFilt(const SosFilter& filter, const Eigen::MatrixXd& x, int padding = -1);

/// Convenience: FiltFilt(ButterworthLowPass(order, cutoff_hz, dt), x) — the EMPS recipe's
/// "zero-phase 4th-order Butterworth at 100 Hz" is ZeroPhaseLowPass(qm, 1e-3, 100.0, 4).
Eigen::MatrixXd ZeroPhaseLowPass(const Eigen::MatrixXd& x, double dt, double cutoff_hz,
                                 int order = 4);

// ---- Resampling ---------------------------------------------------------------------------

/// Piecewise-linear interpolation of the rows of x (sampled at strictly increasing t) at the
/// instants t_new, each inside [t(0), t(N-1)] (no extrapolation; a point outside by less than
/// 1e-9 of the time span is clamped, absorbing rounding in generated grids). N >= 2.
Eigen::MatrixXd InterpolateLinear(const Eigen::VectorXd& t, const Eigen::MatrixXd& x,
                                  const Eigen::VectorXd& t_new);

/// Resamples every channel of an experiment (uniform or explicit time) by linear interpolation
/// onto the uniform grid t0 + k new_dt, k = 0 .. floor((t_end - t0) / new_dt). No anti-alias
/// filtering: to go coarser by an integer factor use Decimate, otherwise low-pass first.
/// The result is named like the input and validated.
Experiment ResampleLinear(const Experiment& experiment, double new_dt);

struct DecimateOptions {
  /// Anti-alias filter: Chebyshev-I of this order (MATLAB decimate's default 8) ...
  int filter_order = 8;
  /// ... with this passband ripple [dB] ...
  double ripple_db = 0.05;
  /// ... and passband edge cutoff_fraction * (new Nyquist frequency) = 0.8 fs / (2 factor).
  double cutoff_fraction = 0.8;
  /// Keep rows offset, offset + factor, ... (0 <= offset < factor). scipy.signal.decimate keeps
  /// row 0 (offset 0); MATLAB's decimate ends at the last row: offset = (N - 1) % factor.
  int offset = 0;
};

/// Integer decimation: zero-phase anti-alias filtering (FiltFilt with the filter above, for sample
/// time dt) then every factor-th row. factor >= 1 (1 returns x unchanged).
Eigen::MatrixXd Decimate(const Eigen::MatrixXd& x, double dt, int factor,
                         const DecimateOptions& options = {});

/// Decimates u, y, x and dx of a uniformly sampled experiment alike ("parallel decimation");
/// dt becomes factor * dt and t0 the time of the first kept row.
Experiment Decimate(const Experiment& experiment, int factor, const DecimateOptions& options = {});

// ---- Finite differences ----------------------------------------------------------------------

/// d x / dt by central differences (x_{k+1} - x_{k-1}) / (2 dt) inside and one-sided first-order
/// differences at the two ends (MATLAB's gradient, numpy.gradient with edge_order 1). N >= 2.
Eigen::MatrixXd CentralDifference(const Eigen::MatrixXd& x, double dt);

/// The same for strictly increasing, possibly non-uniform sample instants t, with numpy.gradient's
/// second-order interior formula
///   d_k = (h_l^2 x_{k+1} - h_r^2 x_{k-1} + (h_r^2 - h_l^2) x_k) / (h_l h_r (h_l + h_r)),
/// h_l = t_k - t_{k-1}, h_r = t_{k+1} - t_k (equal to the uniform formula when h_l = h_r).
Eigen::MatrixXd CentralDifference(const Eigen::MatrixXd& x, const Eigen::VectorXd& t);

}  // namespace graybox::estimators
