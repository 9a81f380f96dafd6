#include "spectrum.h"

#include <cmath>
#include <complex>
#include <vector>

#include <unsupported/Eigen/FFT>

namespace graybox::diagnosis::internal {

int NextPowerOfTwo(int n) {
  int p = 1;
  while (p < n) p *= 2;
  return p;
}

Eigen::VectorXd Periodogram(const Eigen::VectorXd& x, int* nfft) {
  const int n = static_cast<int>(x.size());
  const int m = NextPowerOfTwo(n);
  *nfft = m;
  const double mean = n > 0 ? x.mean() : 0.0;
  std::vector<double> in(m, 0.0);
  const double pi = std::acos(-1.0);
  for (int k = 0; k < n; ++k) {
    const double w = n > 1 ? 0.5 - 0.5 * std::cos(2.0 * pi * k / (n - 1)) : 1.0;
    in[k] = w * (x[k] - mean);
  }
  std::vector<std::complex<double>> out;
  Eigen::FFT<double> fft;
  fft.fwd(out, in);
  Eigen::VectorXd p(m / 2 + 1);
  for (int k = 0; k <= m / 2; ++k) p[k] = std::norm(out[k]);
  return p;
}

}  // namespace graybox::diagnosis::internal
