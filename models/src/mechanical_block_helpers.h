// Private helpers of the friction and drive block families (friction_blocks.cc, drive_blocks.cc):
// option readers that explain what is wrong, metadata shorthands, and the smooth replacements of
// sign, |.|, the Stribeck curve and the dead zone, each written once for double and expr::Expr.
// The formulas and their error bounds are documented in friction.h and drives.h.
#pragma once

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "graybox/models/block.h"
#include "graybox/util/did_you_mean.h"

namespace graybox::models::internal {

inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kNoNeutral = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kPi = 3.14159265358979323846;

inline ParameterInfo MakeParameter(std::string name, std::string unit, std::string description,
                                   double nominal, double lower, double upper,
                                   double neutral = kNoNeutral) {
  ParameterInfo p;
  p.name = std::move(name);
  p.unit = std::move(unit);
  p.description = std::move(description);
  p.nominal = nominal;
  p.lower = lower;
  p.upper = upper;
  p.neutral = neutral;
  return p;
}

inline std::string FormatNumber(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

/// True when the number option `key` is present.
inline bool HasNumber(const BlockOptions& options, const std::string& key) {
  return options.numbers.count(key) > 0;
}

/// The single finite number of option `key`, or `fallback` when absent. Throws
/// std::invalid_argument naming the block type otherwise.
inline double NumberOption(const std::string& type, const BlockOptions& options,
                           const std::string& key, double fallback) {
  auto it = options.numbers.find(key);
  if (it == options.numbers.end()) return fallback;
  if (it->second.size() != 1 || !std::isfinite(it->second[0])) {
    throw std::invalid_argument(
        "block '" + type + "': option '" + key + "' expected one finite number, got " +
        std::to_string(it->second.size()) + " value(s)" +
        (it->second.size() == 1 ? " (" + FormatNumber(it->second[0]) + ")" : ""));
  }
  return it->second[0];
}

/// NumberOption restricted to values > 0.
inline double PositiveOption(const std::string& type, const BlockOptions& options,
                             const std::string& key, double fallback) {
  const double v = NumberOption(type, options, key, fallback);
  if (!(v > 0.0)) {
    throw std::invalid_argument("block '" + type + "': option '" + key +
                                "' expected a number > 0, got " + FormatNumber(v));
  }
  return v;
}

/// NumberOption restricted to the integers lo..hi.
inline int IntegerOption(const std::string& type, const BlockOptions& options,
                         const std::string& key, int fallback, int lo, int hi) {
  const double v = NumberOption(type, options, key, fallback);
  if (v != std::floor(v) || v < lo || v > hi) {
    throw std::invalid_argument("block '" + type + "': option '" + key +
                                "' expected an integer in [" + std::to_string(lo) + ", " +
                                std::to_string(hi) + "], got " + FormatNumber(v));
  }
  return static_cast<int>(v);
}

/// A 0/1 switch.
inline bool FlagOption(const std::string& type, const BlockOptions& options, const std::string& key,
                       bool fallback) {
  return IntegerOption(type, options, key, fallback ? 1 : 0, 0, 1) == 1;
}

/// The word option `key` (one of `allowed`), or `fallback` when absent.
inline std::string WordOption(const std::string& type, const BlockOptions& options,
                              const std::string& key, const std::string& fallback,
                              const std::vector<std::string>& allowed) {
  auto it = options.words.find(key);
  if (it == options.words.end()) return fallback;
  for (const auto& a : allowed) {
    if (it->second == a) return a;
  }
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "'" : ", '") + a + "'";
  const std::string hint = util::DidYouMean(it->second, allowed);
  throw std::invalid_argument("block '" + type + "': option '" + key + "' expected one of " + list +
                              ", got '" + it->second + "'" +
                              (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
}

/// Option "motion" of the friction blocks: "rotational" (default; units rad, rad/s, N m) or
/// "prismatic" (a sliding axis: m, m/s, N). The equations are the same; only the units of the
/// signals and parameters in `info` are rewritten (N m -> N, kg m^2 -> kg, rad -> m).
inline void ApplyMotionUnits(const std::string& type, const BlockOptions& options,
                             BlockInfo* info) {
  if (WordOption(type, options, "motion", "rotational", {"rotational", "prismatic"}) ==
      "rotational") {
    return;
  }
  auto linear = [](std::string u) {
    for (const auto& [from, to] :
         {std::pair<std::string, std::string>{"kg m^2", "kg"}, {"N m", "N"}, {"rad", "m"}}) {
      for (std::size_t at = u.find(from); at != std::string::npos; at = u.find(from, at)) {
        u.replace(at, from.size(), to);
        at += to.size();
      }
    }
    return u;
  };
  for (auto* signals : {&info->inputs, &info->outputs, &info->states}) {
    for (auto& s : *signals) s.unit = linear(s.unit);
  }
  for (auto& p : info->parameters) p.unit = linear(p.unit);
}

// ---- Smooth functions (see friction.h, "Smoothing") ---------------------------------------------

/// tanh(s x): sign(x) for |x| >> 1/s, slope s at 0.
template <typename Scalar>
Scalar SmoothSign(const Scalar& x, const Scalar& steepness) {
  using std::tanh;
  return tanh(steepness * x);
}

/// x tanh(s x): even, >= 0, zero at 0, C-infinity; |x| - 0.28/s <= result <= |x|.
template <typename Scalar>
Scalar SmoothAbs(const Scalar& x, const Scalar& steepness) {
  using std::tanh;
  return x * tanh(steepness * x);
}

/// Stribeck level g(v) = fc + (fs - fc) exp(-|v/vs|^exponent) [seed 002 eq. 5-2]. For exponent 2
/// the power is the exact square; otherwise |r|^a is evaluated as (r^2 + kStribeckEpsilon^2)^(a/2),
/// which is smooth at r = 0 (and has a finite derivative with respect to vs there).
inline constexpr double kStribeckEpsilon = 1e-3;
template <typename Scalar>
Scalar StribeckLevel(const Scalar& v, const Scalar& fc, const Scalar& fs, const Scalar& vs,
                     double exponent) {
  using std::exp;
  using std::pow;
  using std::sqrt;
  const Scalar r = v / vs;
  Scalar power;
  if (exponent == 2.0) {
    power = r * r;
  } else if (exponent == 1.0) {
    power = sqrt(r * r + kStribeckEpsilon * kStribeckEpsilon);
  } else {
    power = pow(r * r + kStribeckEpsilon * kStribeckEpsilon, Scalar(0.5 * exponent));
  }
  return fc + (fs - fc) * exp(-power);
}

/// Smooth dead zone of half-width b >= 0 and smoothing width eps > 0:
///   DZ(x) = x - (sqrt((x + b)^2 + eps^2) - sqrt((x - b)^2 + eps^2)) / 2,
/// i.e. x - clamp(x, -b, b) with |.| replaced by sqrt(.^2 + eps^2). Odd, C-infinity, DZ(x) = x
/// exactly (in floating point too) when b = 0.
template <typename Scalar>
Scalar SmoothDeadZone(const Scalar& x, const Scalar& b, double eps) {
  using std::sqrt;
  const Scalar up = x + b, down = x - b;
  return x - 0.5 * (sqrt(up * up + eps * eps) - sqrt(down * down + eps * eps));
}

/// d DZ / dx (between 0 and 1; exactly 1 when b = 0).
template <typename Scalar>
Scalar SmoothDeadZoneSlope(const Scalar& x, const Scalar& b, double eps) {
  using std::sqrt;
  const Scalar up = x + b, down = x - b;
  return 1.0 - 0.5 * (up / sqrt(up * up + eps * eps) - down / sqrt(down * down + eps * eps));
}

}  // namespace graybox::models::internal
