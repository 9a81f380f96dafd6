// Transmission effects added to an existing elastic joint: a backlash on the deflection of a
// drive.two_mass (drives.h) that has none, as a block that leaves the joint unchanged at its
// neutral value, registered in BlockRegistry::Global() under the type name below.
//
// ---- Why a correction torque ------------------------------------------------------------------
// drive.two_mass computes its deflection delta = q_m - q_l inside the block, so no signal carries
// it for a dead zone to be put in series on (Model::InsertOnSignal); its "backlash" option is a
// different block configuration, not an augmentation. The difference between the joint torque
// with backlash and without,
//     Delta = Ke (DZ(delta) - delta) + d (DZ'(delta) - 1) d(delta)/dt,
// DZ the smooth dead zone of drive.backlash (half width b, smoothing eps), is what this block
// outputs; subtracted from the motor torque and added to the load torque it turns the joint
// torque tau_s into tau_s + Delta = Ke DZ(delta) + d DZ'(delta) d(delta)/dt, the two_mass with
// backlash = 1 EXACTLY when Ke and d equal the joint's. They are this block's options (the
// joint's values when the block is added): when the joint's Ke or d move afterwards (a re-fit
// that frees them), the result is Ke' delta + Ke (DZ(delta) - delta) + ..., a backlash whose
// gap is seen through the stiffness at which it was added. At b = 0, DZ(delta) = delta and
// DZ'(delta) = 1 exactly, so Delta = 0 exactly. The joint's own tau_s output does not include
// Delta: the third output carries it, written into the signal the joint's tau_s goes to, so that
// a measured joint torque (a torque sensor in the spring) is the backlash form's too. Without it
// the data's torque channel, which a backlash empties inside the gap, kept the first-order
// effect of b out of sight (a series elastic actuator with a hard backlash scored LM 0.0005).
//
// ---- Listing format ---------------------------------------------------------------------------
// "transmission.backlash"
//   inputs  q_m [rad] (-1, 1), q_l [rad] (-1, 1), qd_m [rad/s] (-20, 20), qd_l [rad/s] (-20, 20)
//           (the joint's states)
//   outputs tau_motor [N m] (-0.4, 0.4), tau_load [N m] (-0.4, 0.4) and tau_joint [N m]
//           (-0.4, 0.4), all three Delta: connect tau_motor as "-<the joint's tau_m signal>",
//           tau_load as "<its tau_ext signal>" and tau_joint as the joint's tau_s output is
//           connected ("" when it is not)
//   b [rad]  2e-3 (0, 0.5)  neutral 0   half width of the dead zone (total play 2b)
//   options "stiffness" Ke [N m/rad] (> 0, required), "damping" d [N m s/rad] (>= 0, default 0),
//   "smoothing" eps [rad] (> 0, default kDefaultBacklashSmoothing = 1e-4).
#pragma once

namespace graybox::models {

inline constexpr char kBacklashCorrection[] = "transmission.backlash";

}  // namespace graybox::models
