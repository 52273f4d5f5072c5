#pragma once
/// @file
/// URDF import for any humanoid: the paper's virtual heel and upper-body dofs are put
/// between the world and the chosen body root; leg subtrees are locked or dropped.

#include <array>
#include <limits>
#include <string>
#include <vector>

#include "wbm/model.hpp"

namespace wbm {

/// What to do with the leg subtrees (the paper: legs belong to the balance/walking
/// controller, section II).
enum class LegMode {
  kLock,  ///< Keep them welded at joint value 0 (frames and mass stay in the model).
  kDrop,  ///< Remove them with their mass.
};

/// A frame added to the model, fixed to a frame of the URDF (a link, or a link welded to
/// one) at a pose given in that frame: a hand point where the URDF has no link for it (H1's
/// elbow links carry its forearms, whose ends no link marks; a tool centre point). Tasks,
/// reports and the export treat it as any other named frame.
struct AddedFrame {
  std::string name;    ///< new, not a name of the model
  std::string parent;  ///< a frame of the imported model (a URDF link, kept or locked)
  Vector3 xyz = Vector3::Zero();  ///< position in `parent` [m]
  Vector3 rpy = Vector3::Zero();  ///< orientation in `parent`, URDF roll, pitch, yaw [rad]
};

/// "NAME:PARENT:X,Y,Z" or "NAME:PARENT:X,Y,Z:ROLL,PITCH,YAW" (m, rad), as the command-line
/// tools take it (--add-frame).
/// @throws ConfigError naming the text and the expected form.
AddedFrame parse_added_frame(const std::string& text);

struct UrdfImportOptions {
  /// Link that becomes the upper body (e.g. "pelvis", "torso"). Empty: the URDF's root
  /// link, or the child of a root link named "world".
  std::string root;
  /// First link of every leg subtree (e.g. "left_hip_pitch_link"); the subtree away from
  /// the root starting at this link is a leg. The link's own joint belongs to the leg.
  std::vector<std::string> legs;
  LegMode leg_mode = LegMode::kLock;  ///< kDrop needs `legs` (else ParseError).
  /// Height of the root link origin above the ground [m]. NaN: from the legs (their lowest
  /// point at zero joint values: a leg link's origin or the lowest point of its collision
  /// spheres, boxes, cylinders and capsules, or visual ones without collisions, e.g. a sole below the
  /// ankle); without legs, where `root` is not given and the
  /// URDF's root link is a massless link cut off below the root (a base_link or world on the
  /// ground), the root's height above it, or one at the root's origin named "world" or
  /// "base_footprint" (REP 120), 0; else 1 m. Given: > 0 with legs, >= 0 without (else
  /// ParseError).
  double root_height = std::numeric_limits<double>::quiet_NaN();
  /// Height of the upper body's pivot (where the virtual dofs end: upper_body_z's height, the
  /// centre of the upper-body roll and pitch) above the root link's origin [m], along the
  /// upper body's z axis. NaN: 0, unless the root link's origin lies at the feet (a CAD
  /// export's origin on the floor: the legs, which point down from their first links, reach
  /// less than a tenth of their length below it); then the height of the legs' first links
  /// (the hips). The root height stays the root link origin's; upper_body_z's range is
  /// taken from the pivot's height. Else finite and >= 0 (ParseError).
  double upper_body_pivot = std::numeric_limits<double>::quiet_NaN();
  /// Orientation of the root link in wbm's upper-body frame (x forward, y left, z up, REP
  /// 103), as URDF roll, pitch, yaw [rad]: zero for a root link that follows REP 103;
  /// (0, 0, pi) for one whose x axis points backward (iCub's root_link); (pi/2, 0, 0) for
  /// one whose y axis points up. It sets where the robot faces: the home pose's lean, the
  /// upright pose of a fixed base, the root height from the legs.
  Vector3 root_rpy = Vector3::Zero();
  /// Joints whose URDF lacks a position range (lower == upper) or, if not a mimic joint, a
  /// speed limit are an error unless this is set; then revolute joints get [-pi, pi] and
  /// 2 rad/s, prismatic joints [-1, 1] m and 0.5 m/s; continuous joints keep no position
  /// limits and get 2 rad/s where they have no speed limit.
  bool default_limits = false;
  /// Range [lower, upper] of the upper body's forward shift over the heel frame (upper_body_x)
  /// [m]; the heel frame's origin lies on the floor at the feet's back edge. It stands for how
  /// far the legs carry the upper body, and bounds where the balance module (section V) can
  /// move it: the default (-0.02, 0.14), home in its middle, suits feet about 0.22 m long;
  /// with longer feet the centre of mass may need the upper body further forward
  /// (BalanceFlag kShiftAtLimit, reported by `wbm run`). As for every dof, its weight in W
  /// (eq. 6) and the joint-limit criterion follow the range: without balance, a wider range
  /// lets the solver shift the upper body more. Values outside a dof's range are clamped, so
  /// on a fixed base (upright_base_configuration) a range without 0 moves the root off the
  /// base's origin.
  std::array<double, 2> upper_body_x_range = {-0.02, 0.14};
  /// Same for the sideways shift (upper_body_y) [m].
  std::array<double, 2> upper_body_y_range = {-0.08, 0.08};
  /// A file with xacro elements (`<xacro:include>`, `<xacro:macro>`, ...) directly below
  /// <robot> is an error unless this is set; then they are skipped, as urdfdom
  /// and kdl_parser skip what they do not know: for a .urdf whose links and joints are all
  /// written out beside a few xacro leftovers (e.g. NEXTAGE OPEN's, whose macros only add
  /// Gazebo and transmission tags). Still an error: such an element holding a <link> or
  /// <joint> (they would be missing), a xacro element inside a link, joint or material, and
  /// a `${...}` expression where wbm reads a name or number. An included file is not read.
  /// (Xacro elements inside other elements, e.g. <gazebo>, are passed over either way.)
  bool ignore_xacro_elements = false;
  /// Frames to add (AddedFrame), after the URDF's; a name the model has, a parent it lacks
  /// (or a dropped leg's link) or a pose that is not finite is a ParseError naming the frame.
  std::vector<AddedFrame> added_frames;
};

/// Loads a URDF file.
/// @throws ParseError naming the file, the line and the element for malformed XML,
///   unknown root/leg links, missing parents, kinematic loops, zero axes or axes more than
///   1 % from unit length (others are normalised), floating joints inside the tree, names
///   of the virtual dofs/bodies, negative masses, lower limit above upper, missing limits,
///   unexpanded xacro (see ignore_xacro_elements); for kDrop without legs, a given root height that is not > 0 and an
///   upper-body range that is not finite with lower < upper.
Model load_urdf(const std::string& path, const UrdfImportOptions& options = {});

/// Same from a string; `source` names it in error messages.
Model parse_urdf(const std::string& xml, const UrdfImportOptions& options = {},
                 const std::string& source = "<string>");

/// What export_urdf writes.
struct UrdfExportOptions {
  /// false (default): links and joints from the upper body down; the virtual heel and
  /// upper-body dofs are not URDF joints (import the file with root = the upper-body link
  /// and the same root height) and the heel body's mass becomes a fixed link below the
  /// upper body at the home pose.
  /// true: the whole tree, every dof of the model a URDF joint of the same name (the
  /// virtual ones prismatic/revolute, heel_yaw continuous) below a fixed, massless root
  /// link "world" (or "world_", ... if a body or frame has that name) whose frame is wbm's
  /// world frame. For other tools on exactly wbm's tree (e.g. KDL in bench/), not for
  /// load_urdf: its joints carry the names of the virtual dofs that load_urdf adds itself
  /// (a "duplicate dof" ParseError).
  bool virtual_dofs = false;
};

/// Writes a model as URDF (see UrdfExportOptions), named frames as fixed links.
/// @throws ModelError if a dof drives bodies only through a multiplier other than 1 or an
///   offset (possible in a ModelBuilder model, not in an imported URDF).
std::string export_urdf(const Model& model, const UrdfExportOptions& options = {});

}  // namespace wbm
