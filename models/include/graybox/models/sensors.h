// Sensor and actuator error blocks: a sensor offset, a sensor scale error and an actuator dead
// zone, each a one-input one-output block made to be put in series on a signal (Model::
// InsertOnOutput for a sensor, Model::InsertOnSignal for an actuator command), registered in
// BlockRegistry::Global() under the type names below. This header is their reference: equations,
// units, parameters (nominal, bounds, neutral), options and the smoothing.
//
// ---- Units and ranges -------------------------------------------------------------------------
// The blocks are generic over the quantity they act on: option "unit" (a word, default "1") names
// the unit of the input u and output y (and of the parameters that share it), option
// "typical_range" = {min, max} (min < max, default {-1, 1}) their typical range. No signal has a
// role (SignalRole::kNone): a measured copy of a position is not the axis' position.
//
// ---- Listing format ---------------------------------------------------------------------------
// Parameters name [unit] nominal (lower, upper) neutral.
//
// "sensor.offset"  (additive sensor bias)
//     y = u + b
//   input u [unit] the true signal, output y [unit] the measured signal
//   b [unit]  0 (-inf, inf)  neutral 0   offset of the sensor reading
//   At b = 0, y = u exactly (u + 0.0 is u in IEEE arithmetic).
//
// "sensor.scale"  (sensor gain error)
//     y = (1 + s) u
//   s [1]  0 (-0.5, 0.5)  neutral 0   relative gain error of the sensor (0.01 = reads 1 % high)
//   The parameter is the relative error, not the gain, so that the neutral value is 0 like every
//   other candidate's and the bounds say plainly that a sensor reading half or 1.5 times the
//   truth is a wrong sensor, not a calibration error. At s = 0, y = 1.0 * u = u exactly.
//
// "actuator.deadzone"  (smooth dead zone on an actuator command)
//     y = DZ(u) = u - (sqrt((u + b)^2 + eps^2) - sqrt((u - b)^2 + eps^2)) / 2
//   The exact dead zone is u - clamp(u, -b, b) = u - (|u + b| - |u - b|)/2 (no output for
//   |u| <= b, the command less b beyond); the smoothing replaces |x| by sqrt(x^2 + eps^2) (the
//   same function as drive.backlash, drives.h). DZ is odd and C-infinity; for |u| > b it is
//   u -+ b to within eps^2 b / (2 (u^2 - b^2)); inside the zone its slope at 0 is
//   1 - b / sqrt(b^2 + eps^2) ~ eps^2 / (2 b^2); the corners round over a width ~eps. At b = 0
//   the two square roots are the same number and DZ(u) = u EXACTLY (in floating point too). Its
//   derivative with respect to b at b = 0 is -u / sqrt(u^2 + eps^2), a smoothed -sign(u): to
//   first order a dead zone removes a constant b against the command's sign (what the score test
//   sees).
//   input u [unit] the command, output y [unit] the command the actuator acts on
//   b [unit]  0.02 max(|min|, |max|) (0, inf)  neutral 0   half width of the dead zone
//   option "smoothing" eps [unit] (> 0; default 1e-3 max(|min|, |max|) of the typical range:
//   1e-3 V on a +-1 V command).
#pragma once

namespace graybox::models {

inline constexpr char kSensorOffset[] = "sensor.offset";
inline constexpr char kSensorScale[] = "sensor.scale";
inline constexpr char kActuatorDeadzone[] = "actuator.deadzone";

/// Default smoothing width of actuator.deadzone relative to the command's typical magnitude.
inline constexpr double kDefaultDeadzoneSmoothing = 1e-3;

}  // namespace graybox::models
