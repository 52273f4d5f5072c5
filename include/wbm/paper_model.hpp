#pragma once
/// @file
/// The paper's 21-dof ASIMO-like model (section II, Fig. 1, eq. 1), built in.

#include "wbm/model.hpp"

namespace wbm {

/// The built-in model. State vector (eq. 1), in this order:
///  0-2  heel x, y [m], yaw [rad] (world frame)
///  3-8  upper body x, y, z [m] and Kardan angles roll, pitch, yaw [rad] relative to the heel
///        (R_heel,ub = Rx(roll) Ry(pitch) Rz(yaw))
///  9-13 left arm: shoulder pitch, roll, yaw, elbow, hand rotation about the forearm axis
/// 14-18 right arm: the same
/// 19-20 head pan, tilt
/// Frames: "l_hand_ref", "r_hand_ref" (hand reference points; z = grasp axis),
/// "head_camera" (z = view axis), "heel", "upper_body", and every body.
/// Dimensions, ranges, speeds and masses are documented in docs/model.md.
Model make_paper_model();

}  // namespace wbm
