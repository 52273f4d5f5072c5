#include "wbm/balance.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "wbm/errors.hpp"

namespace wbm {
namespace {

double cross(const Vector2& o, const Vector2& a, const Vector2& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

}  // namespace

SupportPolygon SupportPolygon::from_feet(std::span<const FootPose> feet, const FootGeometry& g) {
  if (feet.size() > static_cast<size_t>(kMaxFeet))
    throw ConfigError("support polygon: " + std::to_string(feet.size()) + " feet, at most " +
                      std::to_string(kMaxFeet));
  std::array<Vector2, kMaxVertices> points;  // the corners, on the stack: no allocation in the cycle
  int n = 0;
  for (const FootPose& f : feet) {
    const Eigen::Rotation2Dd R(f.yaw);
    for (const Vector2& corner : {Vector2(0.0, -0.5 * g.width), Vector2(g.length, -0.5 * g.width),
                                 Vector2(g.length, 0.5 * g.width), Vector2(0.0, 0.5 * g.width)})
      points[n++] = f.position + R * corner;
  }
  // Monotone chain convex hull, counter-clockwise: the lower chain, then the upper one from
  // its last point (which may hold points of the lower chain until later ones pop them: at
  // most 2 n points); the last point is the first again, dropped at the end.
  std::sort(points.begin(), points.begin() + n,
            [](const Vector2& a, const Vector2& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  SupportPolygon poly;
  if (n < 3) return poly;
  std::array<Vector2, 2 * kMaxVertices> hull;
  int k = 0;
  for (int i = 0; i < n; ++i) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  for (int i = n - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(hull[k - 2], hull[k - 1], points[i - 1]) <= 0) --k;
    hull[k++] = points[i - 1];
  }
  poly.num_vertices_ = k - 1;
  std::copy(hull.begin(), hull.begin() + poly.num_vertices_, poly.vertices_.begin());
  double area = 0.0;
  Vector2 c = Vector2::Zero();
  for (int i = 0; i < poly.num_vertices_; ++i) {
    const Vector2& a = poly.vertices_[i];
    const Vector2& b = poly.vertices_[(i + 1) % poly.num_vertices_];
    const double w = a.x() * b.y() - b.x() * a.y();
    area += w;
    c += w * (a + b);
  }
  poly.area_ = 0.5 * area;
  poly.centroid_ = std::abs(area) > 1e-12 ? Vector2(c / (3.0 * area))
                   : poly.num_vertices_ == 0 ? Vector2::Zero()
                                             : poly.vertices_[0];
  return poly;
}

FootPose standing_foot(bool left, const Vector2& heel, double heel_yaw, double spacing) {
  return {heel + Eigen::Rotation2Dd(heel_yaw) * Vector2(0.0, (left ? 0.5 : -0.5) * spacing), heel_yaw};
}

SupportPolygon SupportPolygon::standing(const Vector2& heel, double heel_yaw, const FootGeometry& g) {
  const std::array<FootPose, 2> feet = {standing_foot(true, heel, heel_yaw, g.spacing),
                                        standing_foot(false, heel, heel_yaw, g.spacing)};
  return from_feet(feet, g);
}

double SupportPolygon::signed_distance(const Vector2& p) const {
  if (num_vertices_ < 3) return -std::numeric_limits<double>::infinity();
  double inside = std::numeric_limits<double>::infinity();
  double outside = std::numeric_limits<double>::infinity();
  bool is_inside = true;
  for (int i = 0; i < num_vertices_; ++i) {
    const Vector2& a = vertices_[i];
    const Vector2& b = vertices_[(i + 1) % num_vertices_];
    const Vector2 e = b - a;
    const double len = e.norm();
    if (len < 1e-15) continue;
    const double side = (e.x() * (p.y() - a.y()) - e.y() * (p.x() - a.x())) / len;  // > 0: left = inside
    if (side < 0.0) is_inside = false;
    inside = std::min(inside, side);
    const double t = std::clamp((p - a).dot(e) / (len * len), 0.0, 1.0);
    outside = std::min(outside, (a + t * e - p).norm());
  }
  return is_inside ? inside : -outside;
}

CenterOfMassCentering::CenterOfMassCentering(double gain, double margin) : gain_(gain), margin_(margin) {
  if (!(std::isfinite(gain) && gain > 0.0)) throw ConfigError("balance: gain must be finite and > 0 [1/s]");
  if (!(std::isfinite(margin) && margin >= 0.0)) throw ConfigError("balance: margin must be finite and >= 0 [m]");
}

Vector2 CenterOfMassCentering::shift_velocity(const Vector2& com, const SupportPolygon& support, double) {
  if (margin_ > 0.0 && support.signed_distance(com) >= margin_) return Vector2::Zero();
  return gain_ * (support.centroid() - com);
}

BalanceModule::BalanceModule(const Model& model, std::unique_ptr<BalanceLaw> law, const FootGeometry& feet)
    : model_(model), law_(std::move(law)), feet_(feet), ub_x_(model.virtual_dofs().ub_x),
      ub_y_(model.virtual_dofs().ub_y), heel_body_(model.virtual_dofs().heel_body) {
  if (!law_) throw ConfigError("balance: no balance law");
  if (ub_x_ < 0 || ub_y_ < 0 || heel_body_ < 0)
    throw ConfigError("balance: model '" + model.name() + "' has no virtual heel and upper-body x/y dofs");
  if (!(feet.length > 0.0 && feet.width > 0.0 && feet.spacing >= 0.0))
    throw ConfigError("balance: foot length and width must be > 0 and spacing >= 0 [m]");
}

void BalanceModule::disable(Command& command) const {
  command.free_dofs[ub_x_] = true;
  command.free_dofs[ub_y_] = true;
  if (command.external_velocity.size() != 0) {
    command.external_velocity[ub_x_] = 0.0;
    command.external_velocity[ub_y_] = 0.0;
  }
}

std::uint32_t BalanceModule::update(const Data& data, const SupportPolygon& support, double dt, Command& command) {
  std::uint32_t flags = kBalanceOk;
  command.free_dofs[ub_x_] = false;
  command.free_dofs[ub_y_] = false;
  if (command.external_velocity.size() != model_.num_dofs()) return flags | kNoSupport;  // unsized command
  command.external_velocity[ub_x_] = 0.0;
  command.external_velocity[ub_y_] = 0.0;
  const Vector2 com = center_of_mass_position(model_, data).head<2>();
  last_margin_ = support.signed_distance(com);
  if (last_margin_ < 0.0) flags |= kComOutside;
  if (!(std::abs(support.area()) > 1e-6)) return flags | kNoSupport;
  const Vector2 v_W = law_->shift_velocity(com, support, dt);
  if (!v_W.allFinite()) return flags | kInvalidLawOutput;
  // The upper-body x/y dofs translate along the heel frame's axes.
  const Matrix3& R_WH = data.X_WB[heel_body_].R;
  Vector2 v_H = R_WH.topLeftCorner<2, 2>().transpose() * v_W;
  const double vx = model_.dof(ub_x_).max_speed, vy = model_.dof(ub_y_).max_speed;
  const double scale = std::min({1.0, vx / std::max(std::abs(v_H.x()), 1e-300), vy / std::max(std::abs(v_H.y()), 1e-300)});
  if (scale < 1.0) flags |= kShiftSaturated;
  v_H *= scale;
  // A dof at its limit cannot move further out (the controller clamps it there); within a
  // micrometre counts as at it, where braking and clamping leave it.
  auto pushes_out = [&](int dof, double v) {
    const Dof& d = model_.dof(dof);
    const double q = data.q[dof];
    return v > 0.0 && q >= d.upper - 1e-6 ? 1 : v < 0.0 && q <= d.lower + 1e-6 ? -1 : 0;
  };
  last_shift_at_limit_ = {pushes_out(ub_x_, v_H.x()), pushes_out(ub_y_, v_H.y())};
  if (last_shift_at_limit_[0] != 0 || last_shift_at_limit_[1] != 0) flags |= kShiftAtLimit;
  command.external_velocity[ub_x_] = v_H.x();
  command.external_velocity[ub_y_] = v_H.y();
  return flags;
}

}  // namespace wbm
