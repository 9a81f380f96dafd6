// Preprocessing: FFT low-pass and spectral derivatives (seed 000 eq. 8), Butterworth/Chebyshev-I
// design by the bilinear transform, zero-phase filtering, decimation, resampling and central
// differences. Each test compares with a closed form (sinusoids, polynomials, the analog
// prototypes' magnitude responses) or with published coefficients.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include <Eigen/LU>

#include "graybox/estimators/data/mat_file.h"
#include "graybox/estimators/data/preprocessing.h"

namespace graybox::estimators {
namespace {

constexpr double kPi = 3.14159265358979323846;

// An FFT round trip of N points loses about log2(N) * eps relative to the signal's largest
// component; 1e-12 leaves two orders of magnitude for N up to 25000 (Bluestein path included).
constexpr double kFftRoundoff = 1e-12;
// Spectral derivatives multiply the rounding of the kept bins by omega; relative to the largest
// derivative amplitude the error stays below N * eps ~ 1e-11 for the lengths used here.
constexpr double kSpectralDerivativeTolerance = 1e-9;
// The expanded second-order sections of a bilinear design reproduce the analog prototype's
// magnitude to rounding of the pole positions (measured below 1e-12 up to order 10).
constexpr double kDesignTolerance = 1e-9;
// Published scipy/MATLAB coefficients are quoted to 16 significant digits; allow 1e-12.
constexpr double kPublishedCoefficients = 1e-12;
// After a few hundred samples the edge transients of FiltFilt have decayed far below this
// (slowest pole radius 0.8 for a 4th-order 50 Hz design at 1 kHz: 0.8^150 ~ 1e-15).
constexpr double kSteadyStateTolerance = 1e-9;

std::uint32_t TestSeed(std::uint32_t fallback) {
  std::uint32_t seed = fallback;
  if (const char* env = std::getenv("GRAYBOX_TEST_SEED")) {
    seed = static_cast<std::uint32_t>(std::strtoul(env, nullptr, 10));
  }
  std::cout << "[ seed     ] " << seed << " (override with GRAYBOX_TEST_SEED)\n";
  return seed;
}

// Samples of sum_i a_i sin(2 pi m_i k / N + phase_i): periodic over the record for integer m_i.
Eigen::VectorXd Harmonics(int n, const std::vector<double>& amplitude, const std::vector<int>& bin,
                          const std::vector<double>& phase) {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  for (size_t i = 0; i < amplitude.size(); ++i) {
    for (int k = 0; k < n; ++k) {
      x(k) += amplitude[i] * std::sin(2.0 * kPi * bin[i] * k / n + phase[i]);
    }
  }
  return x;
}

double MaxAbs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

// ---- FFT ----------------------------------------------------------------------------------------

TEST(FftTest, LowPassRemovesExactlyTheHighSinusoid) {
  // 1000 points take kissfft's mixed-radix path; 1009 (prime) and 24841 (the EMPS length, prime)
  // take the Bluestein path.
  for (int n : {1000, 1009, 24841}) {
    SCOPED_TRACE(n);
    const Eigen::VectorXd low = Harmonics(n, {1.5}, {3}, {0.2});
    const Eigen::VectorXd high = Harmonics(n, {0.7}, {40}, {1.1});
    const Eigen::VectorXd x = (0.3 + low.array() + high.array()).matrix();
    const Eigen::VectorXd kept_low = (0.3 + low.array()).matrix();
    EXPECT_LT(MaxAbs(FftLowPass(x, 20) - kept_low), kFftRoundoff);
    // Bins at and above the cut-off index are zeroed: 40 removes bin 40, 41 keeps it.
    EXPECT_LT(MaxAbs(FftLowPass(x, 40) - kept_low), kFftRoundoff);
    EXPECT_LT(MaxAbs(FftLowPass(x, 41) - x), kFftRoundoff);
    // Only the mean survives a cut-off of 1.
    EXPECT_LT(MaxAbs(FftLowPass(x, 1).array() - 0.3), kFftRoundoff);
  }
}

TEST(FftTest, IdentityAboveNyquistOnBothPaths) {
  std::mt19937 rng(TestSeed(1234u));
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int n : {1000, 1009, 2018, 15000}) {
    SCOPED_TRACE(n);
    Eigen::MatrixXd x(n, 2);
    for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] = normal(rng);
    EXPECT_LT(MaxAbs(FftLowPass(x, n) - x), kFftRoundoff * MaxAbs(x));
  }
}

TEST(FftTest, SpectralDerivativeMatchesAnalytic) {
  // roblue's set-up: 15000 samples at 4 ms, bins >= 200 zeroed. The 7th and 150th harmonics are
  // kept, the 300th is removed; also the prime EMPS length at 1 ms.
  for (const auto& [n, dt] : {std::pair<int, double>{15000, 0.004}, {24841, 0.001}}) {
    SCOPED_TRACE(n);
    const double period = n * dt;
    Eigen::VectorXd x(n), v(n), a(n);
    for (int k = 0; k < n; ++k) {
      const double t = k * dt;
      const double w1 = 2.0 * kPi * 7 / period;
      const double w2 = 2.0 * kPi * 150 / period;
      const double w3 = 2.0 * kPi * 300 / period;
      x(k) = std::sin(w1 * t) + 0.2 * std::cos(w2 * t) + 0.05 * std::sin(w3 * t);
      v(k) = w1 * std::cos(w1 * t) - 0.2 * w2 * std::sin(w2 * t);
      a(k) = -w1 * w1 * std::sin(w1 * t) - 0.2 * w2 * w2 * std::cos(w2 * t);
    }
    const Eigen::VectorXd v_hat = FftDerivative(x, dt, 200, 1);
    const Eigen::VectorXd a_hat = FftDerivative(x, dt, 200, 2);
    EXPECT_LT(MaxAbs(v_hat - v), kSpectralDerivativeTolerance * MaxAbs(v));
    EXPECT_LT(MaxAbs(a_hat - a), kSpectralDerivativeTolerance * MaxAbs(a));
    // Order 0 is the low-pass itself.
    EXPECT_LT(MaxAbs(FftDerivative(x, dt, 200, 0) - FftLowPass(x, 200)), kFftRoundoff);
  }
}

TEST(FftTest, CutoffBinFromFrequency) {
  EXPECT_EQ(FftCutoffBin(3.0, 1000, 0.01), 30);  // 3 Hz * 10 s: exactly bin 30 despite rounding
  EXPECT_EQ(FftCutoffBin(3.01, 1000, 0.01), 31);
  EXPECT_EQ(FftCutoffBin(200.0 / 60.0, 15000, 0.004), 200);  // roblue: 200 bins of a 60 s record
  EXPECT_EQ(FftCutoffBin(1e6, 100, 0.01), 100);
  EXPECT_THROW(FftCutoffBin(-1.0, 100, 0.01), std::invalid_argument);
  EXPECT_THROW(FftLowPass(Eigen::MatrixXd::Zero(10, 1), 0), std::invalid_argument);
  EXPECT_THROW(FftDerivative(Eigen::MatrixXd::Zero(10, 1), 0.0, 3), std::invalid_argument);
}

TEST(FftTest, RoblueVelocitiesFromPositions) {
  // roblue's states are [q, qd] simulated in closed loop over a periodic reference, stored as
  // float32. The spectral derivative of q with the seed's filter (bins >= 200 zeroed) reproduces
  // the stored qd to about 1e-5 of its spread (measured: 4.1e-6 .. 2.7e-5 over the 6 joints; the
  // residual is the content above bin 200, the slightly non-periodic ends and float32 rounding).
  // The bound leaves a factor of about 4.
  const std::string path =
      std::string(GRAYBOX_SHARED_DATA_DIR) + "/roblue_elabee/elabee_robot_ftsd.mat";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared data missing: " << path;
  const Eigen::MatrixXd y = MatFile(path).ReadMatrix("y_training");
  const Eigen::MatrixXd q = y.leftCols(6);
  const Eigen::MatrixXd qd = y.rightCols(6);
  const Eigen::MatrixXd qd_hat = FftDerivative(q, 0.004, 200);
  for (int j = 0; j < 6; ++j) {
    const double spread = std::sqrt((qd.col(j).array() - qd.col(j).mean()).square().mean());
    const double rms = std::sqrt((qd_hat.col(j) - qd.col(j)).array().square().mean());
    std::cout << "joint " << j + 1 << ": rms(qd_fft - qd) / std(qd) = " << rms / spread << "\n";
    EXPECT_LT(rms / spread, 1e-4) << "joint " << j + 1;
  }
}

// ---- Filter design ----------------------------------------------------------------------------

TEST(FilterDesignTest, ButterworthMatchesPublishedCoefficients) {
  // scipy.signal.butter(2, 0.2) / MATLAB butter(2, 0.2): cut-off 0.2 of Nyquist (fs = 1, fc = 0.1).
  const SosFilter f = ButterworthLowPass(2, 0.1, 1.0);
  Eigen::VectorXd b, a;
  f.TransferFunction(&b, &a);
  ASSERT_EQ(b.size(), 3);
  EXPECT_NEAR(b(0), 0.06745527388907189, kPublishedCoefficients);
  EXPECT_NEAR(b(1), 0.13491054777814378, kPublishedCoefficients);
  EXPECT_NEAR(b(2), 0.06745527388907189, kPublishedCoefficients);
  EXPECT_NEAR(a(0), 1.0, kPublishedCoefficients);
  EXPECT_NEAR(a(1), -1.1429805025399011, kPublishedCoefficients);
  EXPECT_NEAR(a(2), 0.41280159809618877, kPublishedCoefficients);
  // Numerator of any Butterworth low-pass: K * binomial(n, k).
  const SosFilter g = ButterworthLowPass(5, 30.0, 1e-3);
  g.TransferFunction(&b, &a);
  ASSERT_EQ(b.size(), 6);
  const double binomial[] = {1, 5, 10, 10, 5, 1};
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(b(k) / b(0), binomial[k], 1e-9);
  EXPECT_NEAR(b.sum() / a.sum(), 1.0, 1e-9);  // DC gain 1
}

TEST(FilterDesignTest, ButterworthMagnitudeIsThePrewarpedPrototype) {
  const double dt = 1e-3;
  for (int order = 1; order <= 10; ++order) {
    for (double fc : {10.0, 100.0, 450.0}) {
      const SosFilter f = ButterworthLowPass(order, fc, dt);
      EXPECT_EQ(f.order, order);
      EXPECT_EQ(f.NumSections(), (order + 1) / 2);
      for (int i = 0; i <= 50; ++i) {
        const double freq = 499.0 * i / 50.0;
        const double ratio = std::tan(kPi * freq * dt) / std::tan(kPi * fc * dt);
        const double expected = 1.0 / (1.0 + std::pow(ratio, 2 * order));
        EXPECT_NEAR(std::norm(f.Response(freq, dt)), expected, kDesignTolerance)
            << "order " << order << " fc " << fc << " f " << freq;
      }
      EXPECT_NEAR(std::norm(f.Response(fc, dt)), 0.5, kDesignTolerance);  // -3 dB at fc
      EXPECT_NEAR(std::abs(f.Response(0.5 / dt, dt)), 0.0, kDesignTolerance);
    }
  }
}

TEST(FilterDesignTest, ChebyshevMagnitudeIsThePrewarpedPrototype) {
  const double dt = 1e-3;
  auto chebyshev_t = [](int n, double x) {
    return std::abs(x) <= 1.0 ? std::cos(n * std::acos(x)) : std::cosh(n * std::acosh(std::abs(x)));
  };
  for (int order = 1; order <= 8; ++order) {
    for (double ripple : {0.05, 1.0}) {
      const double eps2 = std::pow(10.0, ripple / 10.0) - 1.0;
      const double fc = 40.0;
      const SosFilter f = Chebyshev1LowPass(order, ripple, fc, dt);
      for (int i = 0; i <= 50; ++i) {
        const double freq = 499.0 * i / 50.0;
        const double ratio = std::tan(kPi * freq * dt) / std::tan(kPi * fc * dt);
        const double tn = chebyshev_t(order, ratio);
        const double expected = 1.0 / (1.0 + eps2 * tn * tn);
        EXPECT_NEAR(std::norm(f.Response(freq, dt)), expected, kDesignTolerance)
            << "order " << order << " ripple " << ripple << " f " << freq;
      }
    }
  }
  EXPECT_THROW(Chebyshev1LowPass(4, 0.0, 10.0, dt), std::invalid_argument);
}

TEST(FilterDesignTest, InvalidDesignsAreRejected) {
  auto message = [](auto f) {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message([] {
              ButterworthLowPass(4, 500.0, 1e-3);
            }).find("expected 0 < cutoff < Nyquist frequency 500 Hz, got 500 Hz"),
            std::string::npos);
  EXPECT_NE(message([] {
              ButterworthLowPass(0, 10.0, 1e-3);
            }).find("expected an order in [1, 20], got 0"),
            std::string::npos);
  EXPECT_THROW(ButterworthLowPass(4, 10.0, -1.0), std::invalid_argument);
}

// ---- Zero-phase filtering -------------------------------------------------------------------

TEST(FiltFiltTest, ZeroPhaseLagOnAPassbandSinusoid) {
  // fs = 1 kHz, 4th-order Butterworth at 50 Hz, a 5 Hz sinusoid over 2 s: FiltFilt scales it by
  // |H(5 Hz)|^2 without any shift; one causal pass delays it visibly.
  const double dt = 1e-3;
  const int n = 2000;
  const SosFilter f = ButterworthLowPass(4, 50.0, dt);
  Eigen::VectorXd x(n);
  for (int k = 0; k < n; ++k) x(k) = std::sin(2.0 * kPi * 5.0 * k * dt + 0.3);
  const double gain2 = std::norm(f.Response(5.0, dt));
  const Eigen::VectorXd y = FiltFilt(f, x);
  const Eigen::VectorXd interior_error = (y - gain2 * x).segment(200, n - 400);
  EXPECT_LT(MaxAbs(interior_error), kSteadyStateTolerance);
  // Edges included, odd reflection and the steady-state start keep the error small (measured
  // 0.017 at the first samples, against an amplitude of 1).
  EXPECT_LT(MaxAbs(y - gain2 * x), 0.03);
  // A single causal pass lags by the group delay (about 9 ms here): a large mismatch.
  const Eigen::VectorXd causal = FilterCausal(f, x);
  EXPECT_GT(MaxAbs((causal - std::abs(f.Response(5.0, dt)) * x).segment(200, n - 400)), 0.2);
  // ZeroPhaseLowPass is the same operation.
  EXPECT_EQ(ZeroPhaseLowPass(x, dt, 50.0, 4), y);
}

// MATLAB's filtfilt on the expanded transfer function, written independently of the library:
// direct form II transposed, odd reflection of 3 * order samples, and initial states
// zi = (I - A^T)^{-1} (b[1:] - a[1:] b0) (scipy's lfilter_zi) scaled by the first sample.
Eigen::VectorXd ReferenceFiltFilt(const Eigen::VectorXd& b, const Eigen::VectorXd& a,
                                  const Eigen::VectorXd& x) {
  const int order = static_cast<int>(a.size()) - 1;
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(order, order);
  companion.row(0) = -a.tail(order).transpose();
  for (int i = 1; i < order; ++i) companion(i, i - 1) = 1.0;
  const Eigen::MatrixXd i_minus_at =
      Eigen::MatrixXd::Identity(order, order) - companion.transpose();
  const Eigen::VectorXd zi = i_minus_at.partialPivLu().solve(b.tail(order) - a.tail(order) * b(0));
  auto pass = [&](const Eigen::VectorXd& in) {
    Eigen::VectorXd z = zi * in(0);
    Eigen::VectorXd out(in.size());
    for (Eigen::Index k = 0; k < in.size(); ++k) {
      out(k) = b(0) * in(k) + z(0);
      for (int i = 0; i < order - 1; ++i) z(i) = b(i + 1) * in(k)-a(i + 1) * out(k) + z(i + 1);
      z(order - 1) = b(order) * in(k)-a(order) * out(k);
    }
    return out;
  };
  const int pad = 3 * order;
  const Eigen::Index n = x.size();
  Eigen::VectorXd ext(n + 2 * pad);
  for (int i = 0; i < pad; ++i) {
    ext(i) = 2.0 * x(0) - x(pad - i);
    ext(pad + n + i) = 2.0 * x(n - 1) - x(n - 2 - i);
  }
  ext.segment(pad, n) = x;
  Eigen::VectorXd y = pass(ext).reverse();
  y = pass(y).reverse();
  return y.segment(pad, n);
}

TEST(FiltFiltTest, MatchesTransferFunctionFiltFiltIncludingEdges) {
  std::mt19937 rng(TestSeed(4321u));
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd x(300);
  double walk = 0.0;
  for (Eigen::Index k = 0; k < x.size(); ++k) x(k) = (walk += normal(rng));  // a random walk
  for (int order : {1, 2, 3, 4, 6}) {
    SCOPED_TRACE(order);
    const SosFilter f = ButterworthLowPass(order, 100.0, 1e-3);
    Eigen::VectorXd b, a;
    f.TransferFunction(&b, &a);
    const Eigen::VectorXd expected = ReferenceFiltFilt(b, a, x);
    // The two forms differ only by rounding in the expanded polynomials (orders up to 6 at a
    // normalised cut-off of 0.2 are well conditioned).
    EXPECT_LT(MaxAbs(FiltFilt(f, x) - expected), 1e-9 * MaxAbs(x));
  }
}

TEST(FiltFiltTest, ConstantsPassUnchangedAndShortSignalsAreRejected) {
  const SosFilter f = ButterworthLowPass(4, 100.0, 1e-3);
  const Eigen::MatrixXd c = Eigen::MatrixXd::Constant(50, 2, 3.25);
  EXPECT_LT(MaxAbs(FiltFilt(f, c) - c), 1e-12);
  // Default padding 3 * order = 12 (MATLAB filtfilt): 12 samples are too few.
  EXPECT_THROW(FiltFilt(f, Eigen::MatrixXd::Zero(12, 1)), std::invalid_argument);
  EXPECT_NO_THROW(FiltFilt(f, Eigen::MatrixXd::Zero(13, 1)));
  EXPECT_NO_THROW(FiltFilt(f, Eigen::MatrixXd::Zero(5, 1), 0));
}

// ---- Decimation and resampling ----------------------------------------------------------------

TEST(DecimateTest, KeepsTheLowBandAndRemovesAliases) {
  const double dt = 1e-3;
  const int n = 5000;
  const int factor = 10;  // new Nyquist 50 Hz; the anti-alias passband ends at 40 Hz
  Eigen::MatrixXd x(n, 1);
  for (int k = 0; k < n; ++k) {
    x(k, 0) = std::sin(2.0 * kPi * 3.0 * k * dt) + 0.5 * std::sin(2.0 * kPi * 230.0 * k * dt);
  }
  const SosFilter aa = Chebyshev1LowPass(8, 0.05, 0.8 * 0.5 / (dt * factor), dt);
  const double gain2 = std::norm(aa.Response(3.0, dt));
  EXPECT_GT(gain2, 0.988);  // within twice the 0.05 dB ripple
  const Eigen::MatrixXd d = Decimate(x, dt, factor);
  ASSERT_EQ(d.rows(), 500);
  // The slowest poles of the 8th-order Chebyshev design (radius about 0.99 per input sample) leave
  // edge transients above 1e-6 for roughly the first and last 470 input samples (measured);
  // compare from 60 decimated rows (600 input samples) in.
  for (int i = 60; i < 440; ++i) {
    EXPECT_NEAR(d(i, 0), gain2 * std::sin(2.0 * kPi * 3.0 * i * factor * dt), 1e-6) << i;
  }
  DecimateOptions matlab_phase;
  matlab_phase.offset = (n - 1) % factor;  // ends at the last sample, like MATLAB's decimate
  const Eigen::MatrixXd e = Decimate(x, dt, factor, matlab_phase);
  ASSERT_EQ(e.rows(), 500);
  EXPECT_NEAR(e(100, 0), gain2 * std::sin(2.0 * kPi * 3.0 * (100 * factor + 9) * dt), 1e-6);

  Experiment ex;
  ex.name = "decimate_me";
  ex.dt = dt;
  ex.t0 = 1.0;
  ex.u = x;
  ex.y = 2.0 * x;
  const Experiment out = Decimate(ex, factor, matlab_phase);
  EXPECT_DOUBLE_EQ(out.dt, 0.01);
  EXPECT_DOUBLE_EQ(out.t0, 1.009);
  EXPECT_EQ(out.NumSamples(), 500);
  EXPECT_LT(MaxAbs(out.y - 2.0 * out.u), 1e-12);
  EXPECT_THROW(Decimate(x, dt, 0), std::invalid_argument);
  EXPECT_EQ(Decimate(x, dt, 1), x);
}

TEST(ResampleTest, LinearInterpolationIsExactOnLines) {
  Eigen::VectorXd t(5);
  t << 0.0, 0.1, 0.25, 0.3, 0.7;
  Eigen::MatrixXd x(5, 2);
  x.col(0) = 2.0 * t.array() - 1.0;
  x.col(1) = -t;
  Eigen::VectorXd q(4);
  q << 0.7, 0.05, 0.2999999, 0.0;  // unsorted on purpose
  const Eigen::MatrixXd y = InterpolateLinear(t, x, q);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(y(i, 0), 2.0 * q(i) - 1.0, 1e-15);
    EXPECT_NEAR(y(i, 1), -q(i), 1e-15);
  }
  EXPECT_THROW(InterpolateLinear(t, x, Eigen::VectorXd::Constant(1, 0.71)), std::invalid_argument);

  Experiment e;
  e.name = "jittery";
  e.time = t;
  e.u = x.col(0);
  e.y = x.col(1);
  const Experiment r = ResampleLinear(e, 0.05);
  EXPECT_TRUE(r.IsUniform());
  EXPECT_EQ(r.NumSamples(), 15);  // 0, 0.05, ..., 0.70
  EXPECT_NEAR(r.y(14, 0), -0.7, 1e-12);
  EXPECT_NEAR(r.u(3, 0), 2.0 * 0.15 - 1.0, 1e-12);
}

// ---- Finite differences ----------------------------------------------------------------------

TEST(CentralDifferenceTest, ExactOnQuadraticsInsideFirstOrderAtTheEnds) {
  const double dt = 0.01;
  const int n = 20;
  Eigen::MatrixXd x(n, 1);
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    x(k, 0) = 3.0 * t * t + 2.0 * t + 1.0;
  }
  const Eigen::MatrixXd d = CentralDifference(x, dt);
  for (int k = 1; k + 1 < n; ++k) EXPECT_NEAR(d(k, 0), 6.0 * k * dt + 2.0, 1e-10);
  EXPECT_NEAR(d(0, 0), 2.0 + 3.0 * dt, 1e-10);  // (x1 - x0) / dt
  EXPECT_NEAR(d(n - 1, 0), 6.0 * (n - 1) * dt + 2.0 - 3.0 * dt, 1e-10);

  Eigen::VectorXd t(6);
  t << 0.0, 0.1, 0.15, 0.4, 0.45, 0.9;
  Eigen::MatrixXd y(6, 1);
  y.col(0) = 3.0 * t.array().square() + 2.0 * t.array() + 1.0;
  const Eigen::MatrixXd dy = CentralDifference(y, t);
  for (int k = 1; k < 5; ++k) EXPECT_NEAR(dy(k, 0), 6.0 * t(k) + 2.0, 1e-10);
  EXPECT_THROW(CentralDifference(Eigen::MatrixXd::Zero(1, 1), dt), std::invalid_argument);
}

}  // namespace
}  // namespace graybox::estimators
