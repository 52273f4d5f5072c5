#include "model_notes.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "wbm/kinematics.hpp"

namespace wbm {
namespace {

/// A note when the locked legs point more forward, backward, sideways or up than down, or apart
/// at zero joint values in wbm's upper-body frame (x forward, z up; the base upright), or "":
/// the sign of a root link turned by pitch or roll pi/2 without --root-rpy. The import refuses
/// legs whose lowest link is less than a tenth of their length below the root, but legs turned
/// forward may still reach that far down (Poppy's by pitch pi/2: 7 of 39 cm), and a given root
/// height skips that check. The legs' vectors (first link to farthest link) are summed, so that
/// legs splayed to both sides cancel; legs bent at zero (a crouching robot's) can show too.
std::string legs_direction_note(const Model& model, const std::vector<std::string>& legs) {
  Data data(model);
  forward_kinematics(model, data, upright_base_configuration(model, model.home()));
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double length = 0.0;  // of the legs' vectors, summed
  int counted = 0;
  for (const std::string& leg : legs) {
    const int first = model.find_frame(leg);
    if (first < 0) continue;  // dropped (--drop-legs)
    const Eigen::Vector3d origin = frame_position(model, data, first);
    Eigen::Vector3d farthest = Eigen::Vector3d::Zero();
    for (int f = 0; f < model.num_frames(); ++f) {
      int above = f;
      while (above >= 0 && above != first) above = model.frame(above).parent;
      const Eigen::Vector3d d = frame_position(model, data, f) - origin;
      if (above == first && d.norm() > farthest.norm()) farthest = d;
    }
    sum += farthest;
    length += farthest.norm();
    ++counted;
  }
  if (counted == 0) return "";
  const Eigen::Vector3d mean = sum / counted;
  if (mean.norm() < 0.1 * length / counted) {  // no direction to name: e.g. both arms given as legs
    std::ostringstream note;
    note << std::fixed << std::setprecision(2) << "the legs point apart rather than down at zero joint values (from "
         << "their first link to their farthest, " << length / counted << " m long on average, their directions cancel): "
         << "if these are not the robot's legs, --legs (robot.legs) names the first link of each leg; if the root link's "
            "z axis is not up, give its orientation with --root-rpy (robot.root_rpy; docs/model.md)";
    return note.str();
  }
  const double horizontal = std::hypot(mean.x(), mean.y());
  if (!(horizontal > -mean.z())) return "";
  const char* where = mean.z() >= horizontal                     ? "up"  // upside down, or arms as legs
                      : std::abs(mean.x()) >= std::abs(mean.y()) ? (mean.x() > 0 ? "forward" : "backward")
                                                                 : (mean.y() > 0 ? "to the left" : "to the right");
  const Eigen::Vector3d shown = mean.unaryExpr([](double v) { return std::abs(v) < 0.005 ? 0.0 : v; });  // no "-0.00"
  std::ostringstream note;
  note << std::fixed << std::setprecision(2) << "the legs point " << where
       << " rather than down at zero joint values (from their first link to their farthest, on average " << shown.x()
       << " m forward, " << shown.y() << " m left, " << shown.z()
       << " m up, in wbm's upper-body frame: x forward, y left, z up): if the root link's x axis is not forward or "
          "its z axis not up, give its orientation with --root-rpy (in a scenario robot.root_rpy; docs/model.md); legs bent at "
          "zero can show this too"
       << (mean.z() >= horizontal ? "; if these are not the robot's legs, --legs (robot.legs) names the first link of each leg"
                                  : "");
  return note.str();
}

/// A note when speed limits look like placeholders, or "": a URDF's <limit velocity> taken at
/// its word (1e9 in ergoCub's files) leaves the speed limits, the braking before position
/// limits and the bound on the rates' change (all proportional to it) without effect.
std::string speed_limit_note(const Model& model) {
  constexpr double kImplausibleSpeed = 100.0;  // rad/s or m/s; G1's fastest joints: 37 rad/s
  int implausible = 0;
  int fastest = -1;
  for (int i = 0; i < model.num_dofs(); ++i)
    if (model.dof(i).max_speed >= kImplausibleSpeed) {  // 100 itself is a round placeholder (iCub's)
      ++implausible;
      if (fastest < 0 || model.dof(i).max_speed > model.dof(fastest).max_speed) fastest = i;
    }
  if (implausible == 0) return "";
  std::ostringstream note;
  note << implausible << " dof" << (implausible == 1 ? "" : "s") << " with a speed limit of " << kImplausibleSpeed
       << " rad/s or m/s or more (the largest: '" << model.dof(fastest).name << "', " << model.dof(fastest).max_speed
       << "): the speed limits, the braking before position limits and the bound on the rates' change are "
          "proportional to it and will hardly act; if the URDF's <limit velocity> is a placeholder, give the real "
          "speeds";
  return note.str();
}

/// A note when one leg is given, or "": a biped's other leg then moves with the arms as the
/// robot's own dofs (PNDbotics Adam Lite with one name: 28 dofs instead of 22, nothing said).
std::string one_leg_note(const std::vector<std::string>& legs) {
  if (legs.size() != 1) return "";
  return "one leg given ('" + legs[0] +
         "'): a robot with two legs names the first link of each (--legs L,R; robot.legs); the other leg's joints "
         "are dofs the solver moves";
}

/// A note when the model has no mass, or "": a URDF without <inertial> elements (a kinematic
/// description, as many fixed-base setups' are) loads, but a centre-of-mass task has nothing
/// to follow and balance nothing to balance.
std::string massless_note(const Model& model) {
  if (model.total_mass() > 0.0) return "";
  return "the model has no mass (no <inertial> with a mass in the URDF): centre-of-mass tasks and balance need the "
         "links' masses";
}

}  // namespace

/// A note when the URDF's world link ("world" or REP 120's "base_footprint", kept as a frame)
/// does not lie at wbm's world origin with its axes when the base stands upright (the pose of
/// a fixed base), or "": a world joint that turns the robot or shifts it sideways, which the
/// upright base does not keep, or a humanoid fixed to the world at its pelvis (its legs would
/// stand below that "ground": wbm keeps the default height). World-frame targets are wbm's.
std::string world_link_note(const Model& model) {
  const VirtualDofs& v = model.virtual_dofs();
  if (v.upper_body < 0) return "";
  for (const char* name : {"world", "base_footprint"}) {
    const int f = model.find_frame(name);
    if (f < 0 || model.frame(f).body != v.upper_body) continue;
    Data data(model);
    forward_kinematics(model, data, upright_base_configuration(model, model.home()));
    const Transform X_WF = frame_pose(model, data, f);
    const bool turned = !X_WF.R.isIdentity(1e-7);
    if (X_WF.p.norm() <= 1e-6 && !turned) return "";
    std::ostringstream note;
    const auto plain = [](double x) { return x + 0.0; };  // no "-0"
    note << std::setprecision(4) << "the URDF's " << name << " link is not wbm's world frame: with the base upright (as a "
         << "fixed base stands) it lies at (" << plain(X_WF.p.x()) << ", " << plain(X_WF.p.y()) << ", "
         << plain(X_WF.p.z()) << ") m";
    if (turned) {
      const Vector3 rpy = rpy_from_rotation(X_WF.R);
      // The root link's turn that puts the URDF's world axes on wbm's (R_UR' = R_WF^T R_UR).
      const Vector3 fix = rpy_from_rotation(X_WF.R.transpose() * model.body(v.upper_body).X_PJ.R);
      note << ", turned by roll, pitch, yaw " << plain(rpy.x()) << ", " << plain(rpy.y()) << ", " << plain(rpy.z())
           << " rad (--root-rpy " << std::setprecision(10) << plain(fix.x()) << "," << plain(fix.y()) << ","
           << plain(fix.z()) << " turns the robot as the file has it)";
    }
    note << "; world-frame targets and poses are in wbm's frame (docs/model.md)";
    return note.str();
  }
  return "";
}

std::vector<std::string> model_notes(const Model& model, bool from_urdf, const std::vector<std::string>& legs) {
  std::vector<std::string> notes;
  if (!from_urdf) return notes;
  for (const std::string& note :
       {speed_limit_note(model), one_leg_note(legs), legs_direction_note(model, legs), massless_note(model),
        world_link_note(model)})
    if (!note.empty()) notes.push_back(note);
  return notes;
}

}  // namespace wbm
