#include "excitation.h"

#include <algorithm>
#include <cmath>

namespace graybox::bench::internal {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kFadeSeconds = 0.3;

void FadeIn(double dt, Eigen::VectorXd* s) {
  for (int k = 0; k < s->size(); ++k) {
    const double t = k * dt;
    if (t >= kFadeSeconds) break;
    (*s)(k) *= 0.5 * (1.0 - std::cos(kPi * t / kFadeSeconds));
  }
}

void ScaleToRms(double rms, Eigen::VectorXd* s) {
  const double now = std::sqrt(s->squaredNorm() / static_cast<double>(s->size()));
  if (now > 0.0) *s *= rms / now;
}

}  // namespace

double Rng::Normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  double u1 = Uniform();
  while (u1 <= 0.0) u1 = Uniform();
  const double u2 = Uniform();
  const double r = std::sqrt(-2.0 * std::log(u1));
  spare_ = r * std::sin(2.0 * kPi * u2);
  has_spare_ = true;
  return r * std::cos(2.0 * kPi * u2);
}

std::uint64_t CaseSeed(const std::string& text, unsigned seed) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h ^ (0x9e3779b97f4a7c15ull * (static_cast<std::uint64_t>(seed) + 1));
}

Eigen::VectorXd Multisine(int n, double dt, double f_lo, double f_hi, int count, double rms,
                          Rng* rng) {
  Eigen::VectorXd s = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < count; ++i) {
    const double f = f_lo * std::pow(f_hi / f_lo, count > 1 ? double(i) / (count - 1) : 0.0);
    const double phase = rng->Uniform(0.0, 2.0 * kPi);
    for (int k = 0; k < n; ++k) s(k) += std::sin(2.0 * kPi * f * k * dt + phase);
  }
  ScaleToRms(rms, &s);
  FadeIn(dt, &s);
  return s;
}

Eigen::VectorXd FilteredRandom(int n, double dt, double f_cut, double rms, Rng* rng) {
  const double a = std::exp(-2.0 * kPi * f_cut * dt);
  Eigen::VectorXd s(n);
  double y1 = 0.0, y2 = 0.0;
  for (int k = 0; k < n; ++k) {
    y1 = a * y1 + (1.0 - a) * rng->Normal();
    y2 = a * y2 + (1.0 - a) * y1;
    s(k) = y2;
  }
  s.array() -= s.mean();
  ScaleToRms(rms, &s);
  FadeIn(dt, &s);
  return s;
}

Eigen::VectorXd TrapezoidalPulses(int n, double dt, double amp, Rng* rng) {
  Eigen::VectorXd s = Eigen::VectorXd::Zero(n);
  const double ramp = 0.1;
  double t = rng->Uniform(0.2, 0.8);
  const double end = n * dt;
  while (t < end) {
    const double a = (rng->Uniform() < 0.5 ? -1.0 : 1.0) * rng->Uniform(0.5, 1.0) * amp;
    const double hold = rng->Uniform(0.2, 0.6);
    for (int k = 0; k < n; ++k) {
      const double tau = k * dt - t;
      double w = 0.0;
      if (tau >= 0.0 && tau < ramp) {
        w = tau / ramp;
      } else if (tau >= ramp && tau < ramp + hold) {
        w = 1.0;
      } else if (tau >= ramp + hold && tau < 2.0 * ramp + hold) {
        w = 1.0 - (tau - ramp - hold) / ramp;
      }
      s(k) += a * w;
    }
    t += 2.0 * ramp + hold + rng->Uniform(0.2, 0.8);
  }
  return s;
}

Eigen::VectorXd TrapezoidalMoves(int n, double dt, double q0, double q_lo, double q_hi, double v_lo,
                                 double v_hi, double acc, Rng* rng) {
  Eigen::VectorXd v = Eigen::VectorXd::Zero(n);
  double q = q0;
  int k = 0;
  while (k < n) {
    k += static_cast<int>(std::lround(rng->Uniform(0.1, 0.4) / dt));  // dwell
    const double target = rng->Uniform(q_lo, q_hi);
    const double dist = std::fabs(target - q);
    const double dir = target > q ? 1.0 : -1.0;
    const double vmax = rng->Uniform(v_lo, v_hi);
    double ta = vmax / acc, tc = 0.0, vpeak = vmax;
    if (dist < vmax * ta) {
      vpeak = std::sqrt(dist * acc);
      ta = vpeak / acc;
    } else {
      tc = (dist - vmax * ta) / vmax;
    }
    const double duration = 2.0 * ta + tc;
    const int steps = static_cast<int>(std::ceil(duration / dt));
    for (int j = 0; j < steps && k < n; ++j, ++k) {
      const double t = (j + 0.5) * dt;
      double speed = vpeak;
      if (t < ta) {
        speed = acc * t;
      } else if (t > ta + tc) {
        speed = std::max(0.0, vpeak - acc * (t - ta - tc));
      }
      v(k) = dir * speed;
      q += v(k) * dt;
    }
  }
  return v;
}

}  // namespace graybox::bench::internal
