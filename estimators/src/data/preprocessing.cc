#include "graybox/estimators/data/preprocessing.h"

#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace graybox::estimators {
namespace {

using Complex = std::complex<double>;
constexpr double kPi = 3.14159265358979323846;

template <typename T>
std::string Str(const T& v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

[[noreturn]] void Fail(const std::string& function, const std::string& what) {
  throw std::invalid_argument("preprocessing: " + function + ": " + what);
}

void CheckDt(const std::string& function, double dt) {
  if (!(std::isfinite(dt) && dt > 0.0)) {
    Fail(function, "expected a sample time dt > 0 s, got " + Str(dt));
  }
}

// Signed frequency index of DFT bin k of an N-point transform.
long SignedIndex(long k, long n) { return k <= n / 2 ? k : k - n; }

long LargestPrimeFactor(long n) {
  long largest = 1;
  for (long p = 2; p * p <= n; ++p) {
    while (n % p == 0) {
      largest = p;
      n /= p;
    }
  }
  return n > 1 ? std::max(largest, n) : largest;
}

// The DFT of one length through Eigen's FFT (kissfft). kissfft handles a prime factor p with a
// generic O(N p) butterfly, so N = 24841 (prime) would take seconds; for lengths whose largest
// prime factor exceeds kChirpThreshold the DFT is rewritten with Bluestein's identity
//   k n = (k^2 + n^2 - (k - n)^2) / 2,  c_n = exp(-i pi n^2 / N),
//   X_k = c_k sum_n (x_n c_n) conj(c_{k-n}),
// a circular convolution that Eigen's FFT evaluates at a power-of-two length M >= 2N - 1.
class Dft {
 public:
  static constexpr long kChirpThreshold = 100;

  explicit Dft(long n) : n_(n), chirp_(LargestPrimeFactor(n) > kChirpThreshold) {
    if (!chirp_) return;
    m_ = 1;
    while (m_ < 2 * n_ - 1) m_ *= 2;
    c_.resize(static_cast<size_t>(n_));
    for (long k = 0; k < n_; ++k) {
      // n^2 mod 2N keeps the phase argument small and exact.
      const long long r = (static_cast<long long>(k) * k) % (2LL * n_);
      c_[static_cast<size_t>(k)] = std::polar(1.0, -kPi * static_cast<double>(r) / n_);
    }
    std::vector<Complex> kernel(static_cast<size_t>(m_), Complex(0.0, 0.0));
    kernel[0] = std::conj(c_[0]);
    for (long k = 1; k < n_; ++k) {
      kernel[static_cast<size_t>(k)] = std::conj(c_[static_cast<size_t>(k)]);
      kernel[static_cast<size_t>(m_ - k)] = std::conj(c_[static_cast<size_t>(k)]);
    }
    fft_.fwd(kernel_spectrum_, kernel);
  }

  // X_k = sum_n x_n exp(-2 pi i k n / N).
  void Forward(const std::vector<Complex>& in, std::vector<Complex>* out) {
    if (!chirp_) {
      fft_.fwd(*out, in);
      return;
    }
    std::vector<Complex> a(static_cast<size_t>(m_), Complex(0.0, 0.0));
    for (long k = 0; k < n_; ++k) {
      a[static_cast<size_t>(k)] = in[static_cast<size_t>(k)] * c_[static_cast<size_t>(k)];
    }
    std::vector<Complex> spectrum;
    fft_.fwd(spectrum, a);
    for (long k = 0; k < m_; ++k) spectrum[static_cast<size_t>(k)] *= kernel_spectrum_[k];
    fft_.inv(a, spectrum);  // scaled by 1/M: the circular convolution
    out->resize(static_cast<size_t>(n_));
    for (long k = 0; k < n_; ++k) {
      (*out)[static_cast<size_t>(k)] = a[static_cast<size_t>(k)] * c_[static_cast<size_t>(k)];
    }
  }

  // x_n = 1/N sum_k X_k exp(+2 pi i k n / N) = conj(Forward(conj(X)))_n / N.
  void Inverse(const std::vector<Complex>& in, std::vector<Complex>* out) {
    if (!chirp_) {
      fft_.inv(*out, in);
      return;
    }
    std::vector<Complex> conj_in(in.size());
    for (size_t k = 0; k < in.size(); ++k) conj_in[k] = std::conj(in[k]);
    Forward(conj_in, out);
    for (Complex& v : *out) v = std::conj(v) / static_cast<double>(n_);
  }

 private:
  long n_;
  bool chirp_;
  long m_ = 0;
  std::vector<Complex> c_;
  std::vector<Complex> kernel_spectrum_;
  Eigen::FFT<double> fft_;
};

// Applies `gain(m, n)` to the spectrum of every column; bins with |m| >= cutoff_bin are zeroed.
template <typename Gain>
Eigen::MatrixXd SpectralMap(const Eigen::MatrixXd& x, int cutoff_bin, Gain gain) {
  const long n = static_cast<long>(x.rows());
  Eigen::MatrixXd out(x.rows(), x.cols());
  if (n == 0) return out;
  Dft dft(n);
  std::vector<Complex> column(static_cast<size_t>(n));
  std::vector<Complex> spectrum;
  std::vector<Complex> back;
  for (Eigen::Index j = 0; j < x.cols(); ++j) {
    for (long k = 0; k < n; ++k) column[static_cast<size_t>(k)] = Complex(x(k, j), 0.0);
    dft.Forward(column, &spectrum);
    for (long k = 0; k < n; ++k) {
      const long m = SignedIndex(k, n);
      Complex& bin = spectrum[static_cast<size_t>(k)];
      bin = std::labs(m) >= cutoff_bin ? Complex(0.0, 0.0) : bin * gain(m, n);
    }
    dft.Inverse(spectrum, &back);
    for (long k = 0; k < n; ++k) out(k, j) = back[static_cast<size_t>(k)].real();
  }
  return out;
}

void CheckCutoffBin(const std::string& function, int cutoff_bin) {
  if (cutoff_bin < 1) {
    Fail(function, "expected cutoff_bin >= 1 (bins with |m| >= cutoff_bin are zeroed), got " +
                       std::to_string(cutoff_bin));
  }
}

// ---- IIR design ------------------------------------------------------------------------------

void CheckDesign(const std::string& function, int order, double cutoff_hz, double dt) {
  CheckDt(function, dt);
  if (order < 1 || order > 20) {
    Fail(function, "expected an order in [1, 20], got " + std::to_string(order));
  }
  const double nyquist = 0.5 / dt;
  if (!(std::isfinite(cutoff_hz) && cutoff_hz > 0.0 && cutoff_hz < nyquist)) {
    Fail(function, "expected 0 < cutoff < Nyquist frequency " + Str(nyquist) + " Hz, got " +
                       Str(cutoff_hz) + " Hz");
  }
}

// Digital low-pass from the poles of an analog prototype normalised to a cut-off of 1 rad/s (all
// zeros at infinity), by the pre-warped bilinear transform. Poles must come in conjugate pairs
// with at most one real pole; only the poles with Im >= 0 are passed (one per section). The
// sections' DC gains are each 1; `dc_gain` is applied to the first section.
SosFilter BilinearLowPass(const std::vector<Complex>& upper_poles, int order, double dc_gain,
                          double cutoff_hz, double dt) {
  const double fs = 1.0 / dt;
  const double warped = 2.0 * fs * std::tan(kPi * cutoff_hz * dt);  // analog cut-off [rad/s]
  SosFilter f;
  f.order = order;
  f.sos.resize(static_cast<Eigen::Index>(upper_poles.size()), 6);
  for (size_t s = 0; s < upper_poles.size(); ++s) {
    const Complex p = upper_poles[s] * warped;
    const Complex z = (2.0 * fs + p) / (2.0 * fs - p);
    Eigen::Matrix<double, 1, 6> row;
    if (std::abs(upper_poles[s].imag()) < 1e-14) {
      // First-order section: (1 + z^-1) / (1 - z_p z^-1).
      row << 1.0, 1.0, 0.0, 1.0, -z.real(), 0.0;
    } else {
      // Second-order section: (1 + z^-1)^2 / ((1 - z_p z^-1)(1 - conj(z_p) z^-1)).
      row << 1.0, 2.0, 1.0, 1.0, -2.0 * z.real(), std::norm(z);
    }
    const double gain = (row(3) + row(4) + row(5)) / (row(0) + row(1) + row(2));
    row.head<3>() *= gain;
    f.sos.row(static_cast<Eigen::Index>(s)) = row;
  }
  f.sos.row(0).head<3>() *= dc_gain;
  return f;
}

// Steady-state transposed-direct-form-II state of one section for a constant input of 1.
void SectionSteadyState(const Eigen::Ref<const Eigen::RowVectorXd>& s, double* z1, double* z2,
                        double* gain) {
  const double g = (s(0) + s(1) + s(2)) / (1.0 + s(4) + s(5));
  *z2 = s(2) - s(5) * g;
  *z1 = s(1) - s(4) * g + *z2;
  *gain = g;
}

// Runs the cascade over one signal in place. When `steady` is true the states start at the steady
// state for a constant input equal to the first sample; otherwise at zero.
void RunSections(const Eigen::MatrixXd& sos, bool steady, std::vector<double>* signal) {
  if (signal->empty()) return;
  double level = signal->front();
  for (Eigen::Index s = 0; s < sos.rows(); ++s) {
    const double b0 = sos(s, 0), b1 = sos(s, 1), b2 = sos(s, 2);
    const double a1 = sos(s, 4), a2 = sos(s, 5);
    double z1 = 0.0, z2 = 0.0;
    if (steady) {
      double u1, u2, g;
      SectionSteadyState(sos.row(s), &u1, &u2, &g);
      z1 = u1 * level;
      z2 = u2 * level;
      level *= g;
    }
    for (double& v : *signal) {
      const double in = v;
      const double out = b0 * in + z1;
      z1 = b1 * in - a1 * out + z2;
      z2 = b2 * in - a2 * out;
      v = out;
    }
  }
}

// Product of the section polynomials starting at column `offset` (0: numerators, 3: denominators).
// First-order sections carry a zero third coefficient, so the product's last entry is then 0.
std::vector<double> Polynomial(const Eigen::MatrixXd& sos, int offset) {
  std::vector<double> p = {1.0};
  for (Eigen::Index s = 0; s < sos.rows(); ++s) {
    std::vector<double> q(p.size() + 2, 0.0);
    for (size_t i = 0; i < p.size(); ++i) {
      for (int k = 0; k < 3; ++k) q[i + static_cast<size_t>(k)] += p[i] * sos(s, offset + k);
    }
    p = q;
  }
  return p;
}

// (i w)^order by repeated multiplication (std::pow would give 0^0 = NaN through log).
Complex IPower(double w, int order) {
  Complex r(1.0, 0.0);
  for (int i = 0; i < order; ++i) r *= Complex(0.0, w);
  return r;
}

}  // namespace

// ---- FFT ----------------------------------------------------------------------------------------

Eigen::MatrixXd FftLowPass(const Eigen::MatrixXd& x, int cutoff_bin) {
  CheckCutoffBin("FftLowPass", cutoff_bin);
  return SpectralMap(x, cutoff_bin, [](long, long) { return Complex(1.0, 0.0); });
}

Eigen::MatrixXd FftDerivative(const Eigen::MatrixXd& x, double dt, int cutoff_bin, int order) {
  CheckDt("FftDerivative", dt);
  CheckCutoffBin("FftDerivative", cutoff_bin);
  if (order < 0) Fail("FftDerivative", "expected order >= 0, got " + std::to_string(order));
  const double scale = 2.0 * kPi / (static_cast<double>(x.rows()) * dt);
  return SpectralMap(x, cutoff_bin, [&](long m, long n) {
    // The Nyquist bin of an even-length transform has no sign: drop it for odd orders.
    if (order % 2 == 1 && n % 2 == 0 && m == n / 2) return Complex(0.0, 0.0);
    return IPower(scale * static_cast<double>(m), order);
  });
}

int FftCutoffBin(double cutoff_hz, int n, double dt) {
  CheckDt("FftCutoffBin", dt);
  if (!(std::isfinite(cutoff_hz) && cutoff_hz > 0.0)) {
    Fail("FftCutoffBin", "expected a cut-off frequency > 0 Hz, got " + Str(cutoff_hz));
  }
  if (n < 1) Fail("FftCutoffBin", "expected n >= 1 samples, got " + std::to_string(n));
  // Guard against 0.1 * 30 * 1 = 3.0000000000000004 rounding up to 4.
  const double exact = cutoff_hz * static_cast<double>(n) * dt;
  const double nearest = std::round(exact);
  const double bin =
      std::abs(exact - nearest) < 1e-9 * std::max(1.0, exact) ? nearest : std::ceil(exact);
  return static_cast<int>(std::min(bin, static_cast<double>(n)));
}

// ---- IIR ----------------------------------------------------------------------------------------

void SosFilter::TransferFunction(Eigen::VectorXd* b, Eigen::VectorXd* a) const {
  const std::vector<double> pb = Polynomial(sos, 0);
  const std::vector<double> pa = Polynomial(sos, 3);
  const size_t len = static_cast<size_t>(order) + 1;
  b->setZero(static_cast<Eigen::Index>(len));
  a->setZero(static_cast<Eigen::Index>(len));
  for (size_t i = 0; i < std::min(len, pb.size()); ++i) (*b)(static_cast<Eigen::Index>(i)) = pb[i];
  for (size_t i = 0; i < std::min(len, pa.size()); ++i) (*a)(static_cast<Eigen::Index>(i)) = pa[i];
}

std::complex<double> SosFilter::Response(double frequency_hz, double dt) const {
  const Complex zinv = std::exp(Complex(0.0, -2.0 * kPi * frequency_hz * dt));
  Complex h(1.0, 0.0);
  for (Eigen::Index s = 0; s < sos.rows(); ++s) {
    const Complex num = sos(s, 0) + zinv * (sos(s, 1) + zinv * sos(s, 2));
    const Complex den = sos(s, 3) + zinv * (sos(s, 4) + zinv * sos(s, 5));
    h *= num / den;
  }
  return h;
}

SosFilter ButterworthLowPass(int order, double cutoff_hz, double dt) {
  CheckDesign("ButterworthLowPass", order, cutoff_hz, dt);
  // Prototype poles exp(i pi (2k + n + 1) / (2n)), k = 0..n-1, on the left unit half circle.
  std::vector<Complex> upper;
  for (int k = 0; k < order; ++k) {
    const Complex p = std::polar(1.0, kPi * (2.0 * k + order + 1) / (2.0 * order));
    if (p.imag() > 1e-14) upper.push_back(p);
    if (std::abs(p.imag()) <= 1e-14) upper.push_back(Complex(-1.0, 0.0));
  }
  return BilinearLowPass(upper, order, 1.0, cutoff_hz, dt);
}

SosFilter Chebyshev1LowPass(int order, double ripple_db, double cutoff_hz, double dt) {
  CheckDesign("Chebyshev1LowPass", order, cutoff_hz, dt);
  if (!(std::isfinite(ripple_db) && ripple_db > 0.0)) {
    Fail("Chebyshev1LowPass", "expected a passband ripple > 0 dB, got " + Str(ripple_db));
  }
  const double eps = std::sqrt(std::pow(10.0, ripple_db / 10.0) - 1.0);
  const double mu = std::asinh(1.0 / eps) / order;
  std::vector<Complex> upper;
  for (int k = 0; k < order; ++k) {
    const double theta = kPi * (2.0 * k + 1.0) / (2.0 * order);
    const Complex p(-std::sinh(mu) * std::sin(theta), std::cosh(mu) * std::cos(theta));
    if (p.imag() > 1e-14) upper.push_back(p);
    if (std::abs(p.imag()) <= 1e-14) upper.push_back(Complex(p.real(), 0.0));
  }
  const double dc_gain = order % 2 == 0 ? 1.0 / std::sqrt(1.0 + eps * eps) : 1.0;
  return BilinearLowPass(upper, order, dc_gain, cutoff_hz, dt);
}

Eigen::MatrixXd FilterCausal(const SosFilter& filter, const Eigen::MatrixXd& x) {
  if (filter.sos.cols() != 6 || filter.sos.rows() == 0) {
    Fail("FilterCausal", "expected sos with 6 columns and at least one row, got " +
                             std::to_string(filter.sos.rows()) + "x" +
                             std::to_string(filter.sos.cols()));
  }
  Eigen::MatrixXd out(x.rows(), x.cols());
  std::vector<double> column(static_cast<size_t>(x.rows()));
  for (Eigen::Index j = 0; j < x.cols(); ++j) {
    for (Eigen::Index k = 0; k < x.rows(); ++k) column[static_cast<size_t>(k)] = x(k, j);
    RunSections(filter.sos, false, &column);
    for (Eigen::Index k = 0; k < x.rows(); ++k) out(k, j) = column[static_cast<size_t>(k)];
  }
  return out;
}

Eigen::MatrixXd FiltFilt(const SosFilter& filter, const Eigen::MatrixXd& x, int padding) {
  if (filter.sos.cols() != 6 || filter.sos.rows() == 0) {
    Fail("FiltFilt", "expected sos with 6 columns and at least one row, got " +
                         std::to_string(filter.sos.rows()) + "x" +
                         std::to_string(filter.sos.cols()));
  }
  const long pad = padding < 0 ? 3L * filter.order : padding;
  const long n = static_cast<long>(x.rows());
  if (n <= pad) {
    Fail("FiltFilt", "expected more than " + std::to_string(pad) +
                         " samples (the edge padding), got " + std::to_string(n));
  }
  Eigen::MatrixXd out(x.rows(), x.cols());
  std::vector<double> ext(static_cast<size_t>(n + 2 * pad));
  for (Eigen::Index j = 0; j < x.cols(); ++j) {
    const double first = x(0, j);
    const double last = x(n - 1, j);
    for (long i = 0; i < pad; ++i) {
      ext[static_cast<size_t>(i)] = 2.0 * first - x(pad - i, j);             // x_{pad..1}
      ext[static_cast<size_t>(pad + n + i)] = 2.0 * last - x(n - 2 - i, j);  // x_{N-2..}
    }
    for (long k = 0; k < n; ++k) ext[static_cast<size_t>(pad + k)] = x(k, j);
    RunSections(filter.sos, true, &ext);
    std::reverse(ext.begin(), ext.end());
    RunSections(filter.sos, true, &ext);
    std::reverse(ext.begin(), ext.end());
    for (long k = 0; k < n; ++k) out(k, j) = ext[static_cast<size_t>(pad + k)];
  }
  return out;
}

Eigen::MatrixXd ZeroPhaseLowPass(const Eigen::MatrixXd& x, double dt, double cutoff_hz, int order) {
  return FiltFilt(ButterworthLowPass(order, cutoff_hz, dt), x);
}

// ---- Resampling ---------------------------------------------------------------------------

Eigen::MatrixXd InterpolateLinear(const Eigen::VectorXd& t, const Eigen::MatrixXd& x,
                                  const Eigen::VectorXd& t_new) {
  const Eigen::Index n = t.size();
  if (n < 2) Fail("InterpolateLinear", "expected at least 2 samples, got " + std::to_string(n));
  if (x.rows() != n) {
    Fail("InterpolateLinear", "expected x with " + std::to_string(n) +
                                  " rows (one per time), got " + std::to_string(x.rows()));
  }
  for (Eigen::Index k = 1; k < n; ++k) {
    if (!(t(k) > t(k - 1))) {
      Fail("InterpolateLinear", "expected strictly increasing time, got t[" + std::to_string(k) +
                                    "] = " + Str(t(k)) + " after t[" + std::to_string(k - 1) +
                                    "] = " + Str(t(k - 1)));
    }
  }
  const double lo = t(0);
  const double hi = t(n - 1);
  const double slack = 1e-9 * (hi - lo);
  Eigen::MatrixXd out(t_new.size(), x.cols());
  Eigen::Index seg = 0;
  for (Eigen::Index i = 0; i < t_new.size(); ++i) {
    double q = t_new(i);
    if (!(q >= lo - slack && q <= hi + slack)) {
      Fail("InterpolateLinear", "expected query times inside [" + Str(lo) + ", " + Str(hi) +
                                    "] s (no extrapolation), got t_new[" + std::to_string(i) +
                                    "] = " + Str(q));
    }
    q = std::clamp(q, lo, hi);
    // Queries are usually increasing: move the segment forward, or search when they are not.
    if (q < t(seg)) {
      seg = std::upper_bound(t.data(), t.data() + n, q) - t.data() - 1;
      seg = std::max<Eigen::Index>(seg, 0);
    }
    while (seg + 2 < n && q >= t(seg + 1)) ++seg;
    const double w = (q - t(seg)) / (t(seg + 1) - t(seg));
    out.row(i) = (1.0 - w) * x.row(seg) + w * x.row(seg + 1);
  }
  return out;
}

Experiment ResampleLinear(const Experiment& experiment, double new_dt) {
  CheckDt("ResampleLinear", new_dt);
  experiment.Validate();
  if (experiment.NumSamples() < 2) {
    Fail("ResampleLinear",
         "expected at least 2 samples, got " + std::to_string(experiment.NumSamples()));
  }
  const Eigen::VectorXd t = experiment.Time();
  const double t0 = t(0);
  const double span = t(t.size() - 1) - t0;
  const long count = static_cast<long>(std::floor(span / new_dt + 1e-9)) + 1;
  Eigen::VectorXd grid(count);
  for (long k = 0; k < count; ++k) grid(k) = t0 + static_cast<double>(k) * new_dt;
  Experiment out = experiment;
  out.time.resize(0);
  out.dt = new_dt;
  out.t0 = t0;
  auto resample = [&](const Eigen::MatrixXd& m) -> Eigen::MatrixXd {
    if (m.cols() == 0) return Eigen::MatrixXd(0, 0);
    return InterpolateLinear(t, m, grid);
  };
  out.u = resample(experiment.u);
  out.y = resample(experiment.y);
  out.x = resample(experiment.x);
  out.dx = resample(experiment.dx);
  out.Validate();
  return out;
}

Eigen::MatrixXd Decimate(const Eigen::MatrixXd& x, double dt, int factor,
                         const DecimateOptions& options) {
  CheckDt("Decimate", dt);
  if (factor < 1) Fail("Decimate", "expected a factor >= 1, got " + std::to_string(factor));
  if (options.offset < 0 || options.offset >= factor) {
    Fail("Decimate", "expected 0 <= offset < factor = " + std::to_string(factor) + ", got " +
                         std::to_string(options.offset));
  }
  if (factor == 1) return x;
  if (!(options.cutoff_fraction > 0.0 && options.cutoff_fraction < 1.0)) {
    Fail("Decimate", "expected 0 < cutoff_fraction < 1, got " + Str(options.cutoff_fraction));
  }
  const double cutoff_hz = options.cutoff_fraction * 0.5 / (dt * factor);
  const SosFilter filter =
      Chebyshev1LowPass(options.filter_order, options.ripple_db, cutoff_hz, dt);
  const Eigen::MatrixXd filtered = FiltFilt(filter, x);
  const Eigen::Index kept =
      x.rows() > options.offset ? (x.rows() - options.offset + factor - 1) / factor : 0;
  Eigen::MatrixXd out(kept, x.cols());
  for (Eigen::Index i = 0; i < kept; ++i) out.row(i) = filtered.row(options.offset + i * factor);
  return out;
}

Experiment Decimate(const Experiment& experiment, int factor, const DecimateOptions& options) {
  experiment.Validate();
  if (!experiment.IsUniform()) {
    Fail("Decimate", "experiment '" + experiment.name +
                         "': expected uniform sampling (dt > 0), got an explicit time vector; "
                         "hint: ResampleLinear it first");
  }
  Experiment out = experiment;
  auto decimate = [&](const Eigen::MatrixXd& m) -> Eigen::MatrixXd {
    if (m.cols() == 0) return Eigen::MatrixXd(0, 0);
    return Decimate(m, experiment.dt, factor, options);
  };
  out.u = decimate(experiment.u);
  out.y = decimate(experiment.y);
  out.x = decimate(experiment.x);
  out.dx = decimate(experiment.dx);
  out.dt = experiment.dt * factor;
  out.t0 = experiment.t0 + options.offset * experiment.dt;
  return out;
}

// ---- Finite differences ----------------------------------------------------------------------

Eigen::MatrixXd CentralDifference(const Eigen::MatrixXd& x, double dt) {
  CheckDt("CentralDifference", dt);
  const Eigen::Index n = x.rows();
  if (n < 2) Fail("CentralDifference", "expected at least 2 samples, got " + std::to_string(n));
  Eigen::MatrixXd d(n, x.cols());
  d.row(0) = (x.row(1) - x.row(0)) / dt;
  d.row(n - 1) = (x.row(n - 1) - x.row(n - 2)) / dt;
  if (n > 2) d.middleRows(1, n - 2) = (x.bottomRows(n - 2) - x.topRows(n - 2)) / (2.0 * dt);
  return d;
}

Eigen::MatrixXd CentralDifference(const Eigen::MatrixXd& x, const Eigen::VectorXd& t) {
  const Eigen::Index n = x.rows();
  if (n < 2) Fail("CentralDifference", "expected at least 2 samples, got " + std::to_string(n));
  if (t.size() != n) {
    Fail("CentralDifference", "expected " + std::to_string(n) +
                                  " time instants (one per row), got " + std::to_string(t.size()));
  }
  for (Eigen::Index k = 1; k < n; ++k) {
    if (!(t(k) > t(k - 1))) {
      Fail("CentralDifference", "expected strictly increasing time, got t[" + std::to_string(k) +
                                    "] = " + Str(t(k)) + " after t[" + std::to_string(k - 1) +
                                    "] = " + Str(t(k - 1)));
    }
  }
  Eigen::MatrixXd d(n, x.cols());
  d.row(0) = (x.row(1) - x.row(0)) / (t(1) - t(0));
  d.row(n - 1) = (x.row(n - 1) - x.row(n - 2)) / (t(n - 1) - t(n - 2));
  for (Eigen::Index k = 1; k + 1 < n; ++k) {
    const double hl = t(k) - t(k - 1);
    const double hr = t(k + 1) - t(k);
    d.row(k) = (hl * hl * x.row(k + 1) - hr * hr * x.row(k - 1) + (hr * hr - hl * hl) * x.row(k)) /
               (hl * hr * (hl + hr));
  }
  return d;
}

}  // namespace graybox::estimators
