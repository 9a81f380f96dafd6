// Private helpers of the localization: periodograms and the normal quantile.
#pragma once

#include <Eigen/Core>

namespace graybox::diagnosis::internal {

/// Smallest power of two >= n (n >= 1).
int NextPowerOfTwo(int n);

/// Periodogram |X_m|^2, m = 0 .. nfft/2, of x with its mean removed, a Hann window applied and
/// zeros padded to nfft = NextPowerOfTwo(x.size()). Bin m is at frequency m fs / nfft.
Eigen::VectorXd Periodogram(const Eigen::VectorXd& x, int* nfft);

}  // namespace graybox::diagnosis::internal
