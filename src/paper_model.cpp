#include "wbm/paper_model.hpp"

#include <cmath>

namespace wbm {
namespace {

// Every number below is an estimate for an ASIMO-sized robot (2005 ASIMO: 1.30 m tall,
// 0.45 m wide, 54 kg; Honda's published specification). Honda did not publish segment
// lengths, joint ranges, speeds or masses: these are our estimates from photographs and
// from typical humanoids of that size. docs/model.md lists them with their reasons.
constexpr double kUpperBodyHeight = 0.60;   // hip centre above the ground, knees straight [m]
constexpr double kShoulderHeight = 0.38;    // shoulder joints above the hip centre [m]
constexpr double kShoulderHalfWidth = 0.17; // [m]
constexpr double kUpperArm = 0.22;          // shoulder to elbow [m]
constexpr double kForearm = 0.20;           // elbow to wrist [m]
constexpr double kHandReference = 0.08;     // wrist to hand reference point (palm) [m]
constexpr double kNeckHeight = 0.52;        // pan joint above the hip centre [m]
constexpr double kTiltAbovePan = 0.06;      // [m]

/// Solid cylinder along z, com at `com`.
Inertial cylinder(double mass, double radius, double length, const Vector3& com) {
  Inertial in;
  in.mass = mass;
  in.com = com;
  const double ixx = mass * (3.0 * radius * radius + length * length) / 12.0;
  in.inertia = Eigen::Vector3d(ixx, ixx, 0.5 * mass * radius * radius).asDiagonal();
  return in;
}

/// Solid box with side lengths a, b, c.
Inertial box(double mass, double a, double b, double c, const Vector3& com) {
  Inertial in;
  in.mass = mass;
  in.com = com;
  in.inertia = Eigen::Vector3d(b * b + c * c, a * a + c * c, a * a + b * b).asDiagonal();
  in.inertia *= mass / 12.0;
  return in;
}

Dof revolute(const char* name, double lower, double upper, double speed) {
  Dof d;
  d.name = name;
  d.lower = lower;
  d.upper = upper;
  d.max_speed = speed;
  return d;
}

/// Adds one 5-dof arm; side = +1 for the left arm, -1 for the right arm.
void add_arm(ModelBuilder& builder, int upper_body, double side) {
  const std::string s = side > 0 ? "l_" : "r_";
  // Roll is mirrored: positive roll moves the left arm outwards (+y), the right arm inwards.
  const double roll_lower = side > 0 ? -0.35 : -1.05;
  const double roll_upper = side > 0 ? 1.05 : 0.35;
  struct Segment {
    const char* body;
    Dof dof;
    Vector3 offset;
    Vector3 axis;
    Inertial inertial;
  };
  const Segment segments[5] = {
      {"shoulder_1", revolute("shoulder_pitch", -2.6, 1.4, 3.0),
       {0.0, side * kShoulderHalfWidth, kShoulderHeight}, Vector3::UnitY(),
       cylinder(0.3, 0.04, 0.06, Vector3::Zero())},
      {"shoulder_2", revolute("shoulder_roll", roll_lower, roll_upper, 3.0), Vector3::Zero(),
       Vector3::UnitX(), cylinder(0.3, 0.04, 0.06, Vector3::Zero())},
      {"upper_arm", revolute("shoulder_yaw", -1.5, 1.5, 3.0), Vector3::Zero(), Vector3::UnitZ(),
       cylinder(1.6, 0.045, kUpperArm, {0.0, 0.0, -0.5 * kUpperArm})},
      {"forearm", revolute("elbow", -2.4, 0.0, 3.0), {0.0, 0.0, -kUpperArm}, Vector3::UnitY(),
       cylinder(1.2, 0.04, kForearm, {0.0, 0.0, -0.5 * kForearm})},
      {"hand", revolute("hand_rot", -1.7, 1.7, 4.0), {0.0, 0.0, -kForearm}, Vector3::UnitZ(),
       box(0.6, 0.08, 0.04, 0.12, {0.0, 0.0, -0.06})},
  };
  int parent = upper_body;
  for (const Segment& seg : segments) {
    Dof dof = seg.dof;
    dof.name = s + dof.name;
    Body body;
    body.name = s + seg.body;
    body.parent = parent;
    body.X_PJ.p = seg.offset;
    body.axis = seg.axis;
    body.dof = builder.add_dof(dof);
    body.inertial = seg.inertial;
    parent = builder.add_body(body);
  }
  // Hand reference point in the palm; its z-axis, the grasp axis, is perpendicular to the
  // forearm and points forward when the arm hangs down (Fig. 2).
  Frame ref;
  ref.name = s + "hand_ref";
  ref.body = parent;
  ref.X_BF.p = {0.0, 0.0, -kHandReference};
  ref.X_BF.R = Eigen::AngleAxisd(M_PI / 2, Vector3::UnitY()).toRotationMatrix();
  builder.add_frame(ref);
}

}  // namespace

Model make_paper_model() {
  ModelBuilder builder("paper_asimo_like");
  // Leg masses are lumped: shanks and feet in the heel body, thighs and pelvis in the
  // upper body (the paper's model has no legs, section II).
  const Inertial heel = box(10.0, 0.25, 0.30, 0.30, {0.0, 0.0, 0.15});
  const Inertial trunk = box(33.0, 0.30, 0.34, 0.50, {0.0, 0.0, 0.20});
  const int ub = add_virtual_base(builder, kUpperBodyHeight, "upper_body", heel, trunk);
  add_arm(builder, ub, +1.0);
  add_arm(builder, ub, -1.0);

  Body neck;
  neck.name = "neck";
  neck.parent = ub;
  neck.X_PJ.p = {0.0, 0.0, kNeckHeight};
  neck.axis = Vector3::UnitZ();
  neck.dof = builder.add_dof(revolute("head_pan", -1.5, 1.5, 3.0));
  neck.inertial = cylinder(0.5, 0.04, 0.06, {0.0, 0.0, 0.03});
  const int neck_body = builder.add_body(neck);

  Body head;
  head.name = "head";
  head.parent = neck_body;
  head.X_PJ.p = {0.0, 0.0, kTiltAbovePan};
  head.axis = Vector3::UnitY();
  head.dof = builder.add_dof(revolute("head_tilt", -0.6, 0.9, 3.0));
  head.inertial = box(2.5, 0.22, 0.20, 0.20, {0.02, 0.0, 0.08});
  const int head_body = builder.add_body(head);

  // Camera between the eyes; z = view axis, forward at zero tilt; x points down, y left.
  Frame camera;
  camera.name = "head_camera";
  camera.body = head_body;
  camera.X_BF.p = {0.08, 0.0, 0.08};
  camera.X_BF.R = Eigen::AngleAxisd(M_PI / 2, Vector3::UnitY()).toRotationMatrix();
  builder.add_frame(camera);
  return builder.build();
}

}  // namespace wbm
