#include "wbm/kinematics.hpp"

#include <cmath>

#include "fast_trig.hpp"
#include "zero_block.hpp"

namespace wbm {
namespace {

/// Rotation by angle about a unit axis (Rodrigues), without Eigen's AngleAxis overhead.
Matrix3 axis_rotation(const Vector3& u, double s, double c) {
  const double t = 1.0 - c;
  Matrix3 R;
  R << t * u.x() * u.x() + c, t * u.x() * u.y() - s * u.z(), t * u.x() * u.z() + s * u.y(),
      t * u.x() * u.y() + s * u.z(), t * u.y() * u.y() + c, t * u.y() * u.z() - s * u.x(),
      t * u.x() * u.z() - s * u.y(), t * u.y() * u.z() + s * u.x(), t * u.z() * u.z() + c;
  return R;
}

/// R = B * rotation(axis k, angle) for a coordinate axis k, straight from B: column k is
/// B's, the other two mix (no copy of B to rotate in place).
void rotated_about_axis(const Matrix3& B, int k, double s, double c, Matrix3& R) {
  static constexpr int kNext[3] = {1, 2, 0}, kNextButOne[3] = {2, 0, 1};  // (k + 1) % 3, (k + 2) % 3
  const int i = kNext[k], j = kNextButOne[k];
  const Vector3 bi = B.col(i), bj = B.col(j);
  R.col(k) = B.col(k);
  R.col(i) = c * bi + s * bj;
  R.col(j) = c * bj - s * bi;
}

/// R = B column by column: a plain copy moves 16-byte pieces that straddle the columns, and
/// the children's loads of a column then wait for failed store-to-load forwarding.
void copy_columns(const Matrix3& B, Matrix3& R) {
  for (int k = 0; k < 3; ++k) R.col(k) = B.col(k);
}

}  // namespace

Data::Data(const Model& model)
    : q(Eigen::VectorXd::Zero(model.num_dofs())), X_WB(model.num_bodies()), a_W(model.num_bodies(), Vector3::Zero()),
      mc_W(model.num_bodies(), Vector3::Zero()), angle_anchor(model.num_bodies()) {}

void forward_kinematics(const Model& model, Data& data, const Eigen::Ref<const Eigen::VectorXd>& q) {
  data.q = q;
  const Body* bodies = model.bodies().data();
  const int* axis_code = model.axis_codes().data();
  const char* plain = model.offset_without_rotation().data();
  // By depth rather than by index: consecutive bodies then mostly lie on different branches,
  // so the core overlaps their pose products instead of waiting on each parent's just
  // stored pose (forward kinematics alone 6-13 % faster on the shipped fixtures).
  Matrix3 offset_rotated;  // P.R * X_PJ.R where the offset turns
  for (const int b : model.depth_order()) {
    const Body& body = bodies[b];
    // Pose of the joint frame J in the world: X_WJ = X_WP * X_PJ (eq. 2 and 3), R_WJ = base.
    Transform& X = data.X_WB[b];
    const Matrix3* base = &body.X_PJ.R;
    if (body.parent < 0) {
      X.p = body.X_PJ.p;
    } else {
      const Transform& P = data.X_WB[body.parent];
      X.p = P.R * body.X_PJ.p + P.p;
      if (plain[b]) {
        base = &P.R;
      } else {
        offset_rotated.noalias() = P.R * body.X_PJ.R;
        base = &offset_rotated;
      }
    }
    const int code = axis_code[b];
    data.a_W[b] = code > 0 ? Vector3(base->col(code - 1))
                  : code < 0 ? Vector3(-base->col(-code - 1))
                             : Vector3(*base * body.axis);
    if (body.dof < 0 || body.joint_type == JointType::kPrismatic) {
      copy_columns(*base, X.R);
      if (body.dof >= 0) X.p += data.a_W[b] * (body.multiplier * q[body.dof] + body.offset);
      continue;
    }
    const double value = body.multiplier * q[body.dof] + body.offset;
    double s, c;
    internal::anchored_sin_cos(value, data.angle_anchor[b], s, c);
    // The rotation about the joint axis applied to the columns of the base (for a
    // coordinate axis, the axis column stays and the other two mix).
    if (code != 0)
      rotated_about_axis(*base, std::abs(code) - 1, code > 0 ? s : -s, c, X.R);
    else
      X.R.noalias() = *base * axis_rotation(body.axis, s, c);
  }
}

namespace {

/// Zeroes the 3 (or 6) rows of J starting at `row` and returns pointers to write columns.
/// Raw column access: the Jacobians are tiny and called every cycle, so Eigen's
/// dynamic-size expression overhead would dominate.
struct ColumnWriter {
  double* data;
  Eigen::Index stride;
  double* col(int c) const { return data + c * stride; }
};

ColumnWriter clear(Eigen::Ref<Eigen::MatrixXd>& J) {
  internal::zero_block(J);
  return {J.data(), J.outerStride()};
}

void add(double* col, double k, const Vector3& v) {
  col[0] += k * v.x();
  col[1] += k * v.y();
  col[2] += k * v.z();
}

}  // namespace

void point_jacobian(const Model& model, const Data& data, int body, const Vector3& p_WQ,
                    Eigen::Ref<Eigen::MatrixXd> J) {
  const ColumnWriter w = clear(J);
  const Body* bodies = model.bodies().data();
  for (const int b : model.moving_bodies(body)) {
    const Body& B = bodies[b];
    const Vector3& a = data.a_W[b];
    add(w.col(B.dof), B.multiplier, B.joint_type == JointType::kRevolute ? Vector3(a.cross(p_WQ - data.X_WB[b].p)) : a);
  }
}

void rotational_jacobian(const Model& model, const Data& data, int body, Eigen::Ref<Eigen::MatrixXd> J) {
  const ColumnWriter w = clear(J);
  const Body* bodies = model.bodies().data();
  for (const int b : model.moving_bodies(body)) {
    const Body& B = bodies[b];
    if (B.joint_type == JointType::kRevolute) add(w.col(B.dof), B.multiplier, data.a_W[b]);
  }
}

void frame_jacobian(const Model& model, const Data& data, int frame, Eigen::Ref<Eigen::MatrixXd> J) {
  const Frame& f = model.frames()[frame];
  const Vector3 p_WF = frame_position(model, data, frame);
  const ColumnWriter w = clear(J);
  const Body* bodies = model.bodies().data();
  for (const int b : model.moving_bodies(f.body)) {
    const Body& B = bodies[b];
    const Vector3& a = data.a_W[b];
    if (B.joint_type == JointType::kRevolute) {
      add(w.col(B.dof), B.multiplier, a.cross(p_WF - data.X_WB[b].p));
      add(w.col(B.dof) + 3, B.multiplier, a);
    } else {
      add(w.col(B.dof), B.multiplier, a);
    }
  }
}

Vector3 center_of_mass(const Model& model, Data& data) {
  const std::vector<Body>& bodies = model.bodies();
  const int nb = static_cast<int>(bodies.size());
  for (int b = 0; b < nb; ++b) data.mc_W[b] = bodies[b].inertial.mass * (data.X_WB[b] * bodies[b].inertial.com);
  // Subtree sums from the last body up (a child's index is above its parent's), each root's
  // into the total as the pass reaches it.
  Vector3 mc = Vector3::Zero();
  for (int b = nb - 1; b >= 0; --b) {
    const int parent = bodies[b].parent;
    if (parent >= 0)
      data.mc_W[parent] += data.mc_W[b];
    else
      mc += data.mc_W[b];
  }
  data.p_WCm = mc / model.total_mass();
  return data.p_WCm;
}

Vector3 center_of_mass_position(const Model& model, const Data& data) {
  Vector3 mc = Vector3::Zero();
  const Body* bodies = model.bodies().data();
  for (int b = 0; b < model.num_bodies(); ++b) mc += bodies[b].inertial.mass * (data.X_WB[b] * bodies[b].inertial.com);
  return mc / model.total_mass();
}

void com_jacobian(const Model& model, const Data& data, Eigen::Ref<Eigen::MatrixXd> J) {
  // Column of joint i: a_i x (sum over the subtree of m_k (c_k - p_i)) / M for revolute,
  // a_i * subtree mass / M for prismatic joints. Raw columns, as for the other Jacobians.
  const ColumnWriter w = clear(J);
  const double inv_mass = 1.0 / model.total_mass();
  const Body* bodies = model.bodies().data();
  const double* subtree_mass = model.subtree_mass().data();
  const int nb = model.num_bodies();
  for (int b = 0; b < nb; ++b) {
    const Body& B = bodies[b];
    if (B.dof < 0) continue;  // a welded body: no column
    const Vector3& a = data.a_W[b];
    if (B.joint_type == JointType::kRevolute)
      add(w.col(B.dof), B.multiplier * inv_mass, a.cross(data.mc_W[b] - subtree_mass[b] * data.X_WB[b].p));
    else
      add(w.col(B.dof), B.multiplier * inv_mass * subtree_mass[b], a);
  }
}

}  // namespace wbm
