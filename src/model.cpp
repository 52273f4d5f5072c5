#include "wbm/model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <unordered_set>

#include "wbm/errors.hpp"

#include "closest_names.hpp"

namespace wbm {
namespace {

constexpr double kAxisTolerance = 1e-5;
constexpr double kInf = std::numeric_limits<double>::infinity();

std::string quoted(const std::string& s) { return "'" + s + "'"; }

/// "(x, y, z)" for messages.
std::string text(const Vector3& v) {
  std::ostringstream out;
  out << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return out.str();
}

void check_inertial(const std::string& what, const Inertial& in) {
  if (!(in.mass >= 0.0 && in.mass <= kMaxMass)) {
    std::ostringstream msg;
    msg << what << ": mass must be in [0, " << kMaxMass << "] kg, got " << in.mass;
    throw ModelError(msg.str());
  }
  if (!in.com.allFinite() || !in.inertia.allFinite())
    throw ModelError(what + ": centre of mass and inertia must be finite");
  if (in.com.lpNorm<Eigen::Infinity>() > kMaxLength) {
    std::ostringstream msg;
    msg << what << ": centre of mass " << text(in.com) << " m reaches beyond " << kMaxLength << " m";
    throw ModelError(msg.str());
  }
}

/// Up to 40 names after `what`, for the errors of a name lookup.
std::string listed(const char* what, const std::vector<std::string>& names) {
  std::string text = std::string("; ") + what + " are:";
  for (std::size_t k = 0; k < names.size() && k < 40; ++k) text += " " + names[k];
  if (names.size() > 40)
    text += " ... (" + std::to_string(names.size() - 40) + " more of " + std::to_string(names.size()) +
            "; `wbm model info` lists them all)";
  return text;
}

}  // namespace

Vector3 rpy_from_rotation(const Matrix3& R) {
  // R = Rz(yaw) Ry(pitch) Rx(roll). Take yaw from the first column, then roll and pitch
  // from Rz(yaw)^T R = Ry(pitch) Rx(roll). At pitch = +-pi/2 (gimbal lock) the first
  // column's x and y are rounding noise and yaw is arbitrary, but roll computed this way
  // still matches it, so the angles always reproduce R (atan2(R21, R22) for roll would
  // divide noise by noise there).
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  const double c = std::cos(yaw);
  const double s = std::sin(yaw);
  const double pitch = std::atan2(-R(2, 0), c * R(0, 0) + s * R(1, 0));
  const double roll = std::atan2(s * R(0, 2) - c * R(1, 2), c * R(1, 1) - s * R(0, 1));
  return {roll, pitch, yaw};
}

const char* to_string(JointType type) {
  return type == JointType::kRevolute ? "revolute" : "prismatic";
}

const char* to_string(DofRole role) {
  switch (role) {
    case DofRole::kJoint: return "joint";
    case DofRole::kHeelX: return "heel_x";
    case DofRole::kHeelY: return "heel_y";
    case DofRole::kHeelYaw: return "heel_yaw";
    case DofRole::kUpperBodyX: return "upper_body_x";
    case DofRole::kUpperBodyY: return "upper_body_y";
    case DofRole::kUpperBodyZ: return "upper_body_z";
    case DofRole::kUpperBodyRoll: return "upper_body_roll";
    case DofRole::kUpperBodyPitch: return "upper_body_pitch";
    case DofRole::kUpperBodyYaw: return "upper_body_yaw";
  }
  return "?";
}

int Model::find_dof(const std::string& name) const {
  for (int i = 0; i < num_dofs(); ++i)
    if (dofs_[i].name == name) return i;
  return -1;
}

int Model::find_frame(const std::string& name) const {
  for (int i = 0; i < num_frames(); ++i)
    if (frames_[i].name == name) return i;
  return -1;
}

int Model::dof_index(const std::string& name) const {
  const int i = find_dof(name);
  if (i >= 0) return i;
  std::vector<std::string> names;
  for (const Dof& d : dofs_) names.push_back(d.name);
  // A joint of the robot's description that is not a dof: say which kind, since its name is
  // in the user's URDF (a leg joint that --legs locked, NimbRo's or Atlas's knee, say).
  std::string kind;
  for (const Frame& f : frames_)
    if (f.joint_name == name && !name.empty())
      kind = " (" + quoted(name) + " is a fixed joint of the model: a welded link's, or a locked leg's (legs, --legs))";
  for (const Body& b : bodies_)  // a mimic joint's body is driven by its master's dof
    if (b.joint_name == name && !name.empty() && b.dof >= 0 && dofs_[b.dof].name != name)
      kind = " (" + quoted(name) + " is a mimic joint: it follows dof " + quoted(dofs_[b.dof].name) + ")";
  throw ModelError("model " + quoted(name_) + " has no dof named " + quoted(name) + kind +
                   (kind.empty() ? internal::did_you_mean(name, names) : "") + listed("dofs", names));
}

int Model::frame_index(const std::string& name) const {
  const int i = find_frame(name);
  if (i >= 0) return i;
  std::vector<std::string> names;
  for (const Frame& f : frames_) names.push_back(f.name);
  throw ModelError("model " + quoted(name_) + " has no frame named " + quoted(name) + internal::did_you_mean(name, names) +
                   listed("frames", names));
}

void Model::check_configuration(const Eigen::VectorXd& q) const {
  if (q.size() != num_dofs())
    throw ModelError("configuration has " + std::to_string(q.size()) + " values, model " +
                     quoted(name_) + " has " + std::to_string(num_dofs()) + " dofs");
  for (int i = 0; i < num_dofs(); ++i) {
    const Dof& d = dofs_[i];
    if (!std::isfinite(q[i]))
      throw ModelError("configuration value of dof " + quoted(d.name) + " is not finite");
    if (q[i] < d.lower - 1e-9 || q[i] > d.upper + 1e-9) {
      std::ostringstream msg;
      msg << "configuration value " << q[i] << " of dof " << quoted(d.name) << " is outside ["
          << d.lower << ", " << d.upper << "]";
      throw ModelError(msg.str());
    }
  }
}

int ModelBuilder::add_dof(const Dof& dof) {
  model_.dofs_.push_back(dof);
  return static_cast<int>(model_.dofs_.size()) - 1;
}

int ModelBuilder::add_body(const Body& body) {
  const int index = static_cast<int>(model_.bodies_.size());
  if (body.parent < -1 || body.parent >= index)
    throw ModelError("body " + quoted(body.name) + ": parent index " +
                     std::to_string(body.parent) + " is not an earlier body");
  model_.bodies_.push_back(body);
  model_.frames_.push_back({body.name, index, Transform::Identity()});
  return index;
}

int ModelBuilder::add_frame(const Frame& frame) {
  model_.frames_.push_back(frame);
  return static_cast<int>(model_.frames_.size()) - 1;
}

void ModelBuilder::set_frame_parent(int frame, int parent) {
  if (frame < 0 || frame >= num_frames())
    throw ModelError("set_frame_parent: frame index " + std::to_string(frame) + " is not an added frame");
  model_.frames_[frame].parent = parent;
}

Model ModelBuilder::build() {
  Model& m = model_;
  const int nq = m.num_dofs();
  const int nb = m.num_bodies();
  std::unordered_set<std::string> names;
  std::vector<int> driven(nq, 0);
  for (int d = 0; d < nq; ++d) {
    Dof& dof = m.dofs_[d];
    const std::string what = "dof " + quoted(dof.name);
    if (!names.insert(dof.name).second) throw ModelError("duplicate " + what);
    if (dof.continuous) {
      dof.lower = -kInf;
      dof.upper = kInf;
      if (dof.type != JointType::kRevolute) throw ModelError(what + ": only revolute joints can be continuous");
      if (!(dof.work_range > 0.0)) dof.work_range = 2.0 * M_PI;
    } else {
      if (!std::isfinite(dof.lower) || !std::isfinite(dof.upper))
        throw ModelError(what + ": position limits must be finite (or the joint continuous)");
      if (dof.lower > dof.upper) {
        std::ostringstream msg;
        msg << what << ": lower limit " << dof.lower << " is above upper limit " << dof.upper;
        throw ModelError(msg.str());
      }
      if (dof.type == JointType::kPrismatic && std::max(-dof.lower, dof.upper) > kMaxLength) {
        std::ostringstream msg;
        msg << what << ": prismatic limits [" << dof.lower << ", " << dof.upper << "] m reach beyond " << kMaxLength
            << " m";
        throw ModelError(msg.str());
      }
      if (!(dof.work_range > 0.0)) dof.work_range = dof.upper - dof.lower;
      if (!(dof.work_range > 0.0))
        throw ModelError(what + ": zero motion range (lower == upper); lock the joint instead");
    }
    if (!std::isfinite(dof.work_range)) {  // upper - lower overflowed, or set so
      std::ostringstream msg;
      msg << what << ": work range must be finite, got " << dof.work_range << " (limits [" << dof.lower << ", "
          << dof.upper << "]; make a joint without limits continuous)";
      throw ModelError(msg.str());
    }
    if (!std::isfinite(dof.max_speed) || dof.max_speed <= 0.0)
      throw ModelError(what + ": speed limit must be finite and > 0, got " + std::to_string(dof.max_speed));
    if (!(std::isfinite(dof.max_effort) && dof.max_effort >= 0.0))
      throw ModelError(what + ": effort limit must be finite and >= 0 (0: not given), got " +
                       std::to_string(dof.max_effort));
  }
  names.clear();
  for (int b = 0; b < nb; ++b) {
    Body& body = m.bodies_[b];
    const std::string what = "body " + quoted(body.name);
    if (!names.insert(body.name).second) throw ModelError("duplicate " + what);
    if (body.dof >= nq) throw ModelError(what + ": dof index out of range");
    if (body.dof >= 0) {
      driven[body.dof] += 1;
      const double n = body.axis.norm();
      if (!std::isfinite(n) || n < 1e-12) throw ModelError(what + ": joint axis is zero");
      if (std::abs(n - 1.0) > kAxisTolerance) {
        std::ostringstream msg;
        msg << what << ": joint axis " << text(body.axis) << " is not a unit vector (norm " << n << ")";
        throw ModelError(msg.str());
      }
      body.axis /= n;
      if (!std::isfinite(body.multiplier) || !std::isfinite(body.offset))
        throw ModelError(what + ": mimic multiplier and offset must be finite");
    }
    if (!body.X_PJ.R.allFinite() || !body.X_PJ.p.allFinite())
      throw ModelError(what + ": joint offset is not finite");
    if (body.X_PJ.p.lpNorm<Eigen::Infinity>() > kMaxLength) {
      std::ostringstream msg;
      msg << what << ": joint offset " << text(body.X_PJ.p) << " m reaches beyond " << kMaxLength << " m";
      throw ModelError(msg.str());
    }
    if (!(body.X_PJ.R.transpose() * body.X_PJ.R).isIdentity(1e-6))
      throw ModelError(what + ": joint offset rotation is not orthonormal");
    check_inertial(what, body.inertial);
  }
  for (int d = 0; d < nq; ++d)
    if (driven[d] == 0) throw ModelError("dof " + quoted(m.dofs_[d].name) + " drives no body");
  names.clear();
  for (const Frame& f : m.frames_) {
    if (!names.insert(f.name).second) throw ModelError("duplicate frame " + quoted(f.name));
    if (f.body < 0 || f.body >= nb) throw ModelError("frame " + quoted(f.name) + ": body index out of range");
    if (!f.X_BF.R.allFinite() || !f.X_BF.p.allFinite() || f.X_BF.p.lpNorm<Eigen::Infinity>() > kMaxLength) {
      std::ostringstream msg;
      msg << "frame " << quoted(f.name) << ": offset is not finite or reaches beyond " << kMaxLength << " m";
      throw ModelError(msg.str());
    }
  }
  // Joint names kept for the export (Body and Frame::joint_name) name one joint each: a
  // dof's own, a mimic or a fixed joint; a body's may be its dof's name (the dof's joint).
  std::map<std::string, std::string> joint_owner;
  auto claim = [&](const std::string& joint, const std::string& owner) {
    const auto [at, inserted] = joint_owner.emplace(joint, owner);
    if (!inserted && at->second != owner)
      throw ModelError("joint name " + quoted(joint) + " is given to " + owner + " and to " + at->second +
                       " (a joint name, Body or Frame::joint_name, must name one joint)");
  };
  for (const Dof& dof : m.dofs_) claim(dof.name, "dof " + quoted(dof.name));
  for (const Body& body : m.bodies_)
    if (!body.joint_name.empty())
      claim(body.joint_name, body.dof >= 0 && body.joint_name == m.dofs_[body.dof].name
                                 ? "dof " + quoted(body.joint_name)
                                 : "body " + quoted(body.name));
  for (const Frame& f : m.frames_)
    if (!f.joint_name.empty()) claim(f.joint_name, "frame " + quoted(f.name));
  const int nf = m.num_frames();
  for (int i = 0; i < nf; ++i) {
    const Frame& f = m.frames_[i];
    if (f.parent == -1) continue;
    if (f.parent < -1 || f.parent >= nf || f.parent == i)
      throw ModelError("frame " + quoted(f.name) + ": parent frame index " + std::to_string(f.parent) +
                       " is not -1 or the index of another frame");
    // A body's own frame hangs from a frame of the parent body, any other from one of its body.
    const bool own = m.is_body_frame(i);
    const int expected = own ? m.bodies_[f.body].parent : f.body;
    const Frame& p = m.frames_[f.parent];
    if (p.body != expected)
      throw ModelError("frame " + quoted(f.name) + ": parent frame " + quoted(p.name) + " is on body " +
                       quoted(m.bodies_[p.body].name) + ", expected a frame on " +
                       (expected < 0 ? std::string("no body (the root body's frame has no parent)")
                                     : quoted(m.bodies_[expected].name) +
                                           (own ? " (the parent of the frame's body)" : " (the frame's body)")));
  }

  m.axis_code_.assign(nb, 0);
  m.offset_without_rotation_.assign(nb, 0);
  for (int b = 0; b < nb; ++b) {
    const Body& body = m.bodies_[b];
    for (int k = 0; k < 3; ++k) {
      if (body.axis == Vector3::Unit(k)) m.axis_code_[b] = k + 1;
      if (body.axis == -Vector3::Unit(k)) m.axis_code_[b] = -(k + 1);
    }
    m.offset_without_rotation_[b] = body.X_PJ.R == Matrix3::Identity();
  }
  {
    std::vector<int> depth(nb, 0);
    for (int b = 0; b < nb; ++b) depth[b] = m.bodies_[b].parent < 0 ? 0 : depth[m.bodies_[b].parent] + 1;
    m.depth_order_.resize(nb);
    for (int b = 0; b < nb; ++b) m.depth_order_[b] = b;
    std::stable_sort(m.depth_order_.begin(), m.depth_order_.end(), [&](int a, int b) { return depth[a] < depth[b]; });
  }
  m.chain_offset_.assign(nb + 1, 0);
  m.chain_bodies_.clear();
  for (int b = 0; b < nb; ++b) {
    m.chain_offset_[b] = static_cast<int>(m.chain_bodies_.size());
    for (int a = b; a >= 0; a = m.bodies_[a].parent)
      if (m.bodies_[a].dof >= 0) m.chain_bodies_.push_back(a);
  }
  m.chain_offset_[nb] = static_cast<int>(m.chain_bodies_.size());
  m.subtree_mass_.assign(nb, 0.0);
  for (int b = nb - 1; b >= 0; --b) {
    m.subtree_mass_[b] += m.bodies_[b].inertial.mass;
    if (m.bodies_[b].parent >= 0) m.subtree_mass_[m.bodies_[b].parent] += m.subtree_mass_[b];
  }
  m.total_mass_ = 0.0;
  for (const Body& b : m.bodies_) m.total_mass_ += b.inertial.mass;

  m.lower_.resize(nq);
  m.upper_.resize(nq);
  m.max_speed_.resize(nq);
  for (int d = 0; d < nq; ++d) {
    m.lower_[d] = m.dofs_[d].lower;
    m.upper_[d] = m.dofs_[d].upper;
    m.max_speed_[d] = m.dofs_[d].max_speed;
  }
  if (home_.size() == 0) {
    home_.resize(nq);
    for (int d = 0; d < nq; ++d) home_[d] = m.dofs_[d].center();
  }
  m.home_ = home_;
  m.check_configuration(m.home_);
  return std::move(m);
}

std::array<Dof, 9> default_virtual_dofs(double height) {
  const double pi = M_PI;
  // Ranges of the virtual dofs are not given by the paper (see ERRATA.md). The heel may
  // slide anywhere on a 20 m x 20 m floor and turn freely (it is frozen by b_C while
  // standing); its work range (1 m) only sets its weight in W. The upper-body ranges
  // approximate what a humanoid's legs allow: 8 cm sideways shift, forward shift from 2 cm
  // behind to 14 cm ahead of the heel edge (centre 6 cm: about above the ankles, so that the
  // centre of mass starts over the middle of the feet), crouching by
  // 20 % of the standing height, and moderate trunk tilts.
  // The heel's speed, 0.5 m/s for the paper model's 0.6 m, scales with the square root of
  // the height, as walking's step length over its duration does (scaled_walking_parameters,
  // equal Froude numbers), so that the heel keeps the paper model's 1.2 times the feet's
  // best pace at every size: at 0.5 m/s a 0.26 m robot's heel ran at 1.8 times its feet's
  // 0.28 m/s and the body up to 0.45 m beyond them.
  const double heel_speed = height > 0.05 ? 0.5 * std::sqrt(height / 0.6) : 0.5;
  std::array<Dof, 9> d;
  d[0] = {"heel_x", JointType::kPrismatic, DofRole::kHeelX, false, -10.0, 10.0, heel_speed, 1.0};
  d[1] = {"heel_y", JointType::kPrismatic, DofRole::kHeelY, false, -10.0, 10.0, heel_speed, 1.0};
  d[2] = {"heel_yaw", JointType::kRevolute, DofRole::kHeelYaw, true, -pi, pi, 0.8, 2.0 * pi};
  d[3] = {"upper_body_x", JointType::kPrismatic, DofRole::kUpperBodyX, false, -0.02, 0.14, 0.3, 0.0};
  d[4] = {"upper_body_y", JointType::kPrismatic, DofRole::kUpperBodyY, false, -0.08, 0.08, 0.3, 0.0};
  // A root at ground level (height 0: a fixed-base robot whose base link stands on the
  // world's origin) crouches by the 0.2 m a 1 m root would (the default height before such
  // robots kept theirs): a range, not a point, though a fixed base freezes the dof.
  const double crouch = height > 0.0 ? 0.2 * height : 0.2;
  d[5] = {"upper_body_z", JointType::kPrismatic, DofRole::kUpperBodyZ, false, height - crouch, height,
          0.3, 0.0};
  d[6] = {"upper_body_roll", JointType::kRevolute, DofRole::kUpperBodyRoll, false, -0.2, 0.2, 1.0, 0.0};
  d[7] = {"upper_body_pitch", JointType::kRevolute, DofRole::kUpperBodyPitch, false, -0.2, 0.5, 1.0, 0.0};
  d[8] = {"upper_body_yaw", JointType::kRevolute, DofRole::kUpperBodyYaw, false, -0.7, 0.7, 1.0, 0.0};
  return d;
}

Eigen::VectorXd upright_base_configuration(const Model& model, const Eigen::VectorXd& q) {
  if (q.size() != model.num_dofs())
    throw ModelError("upright_base_configuration: q has " + std::to_string(q.size()) + " entries, the model " +
                     std::to_string(model.num_dofs()) + " dofs");
  Eigen::VectorXd upright = q;
  const VirtualDofs& v = model.virtual_dofs();
  for (const int i : v.all()) {
    if (i < 0) continue;
    const Dof& d = model.dof(i);
    const double value = i == v.ub_z ? d.upper : 0.0;  // upright: full height, all else zero
    upright[i] = d.continuous ? value : std::clamp(value, d.lower, d.upper);
  }
  return upright;
}

int add_virtual_base(ModelBuilder& builder, double height, const std::string& upper_body_name,
                     const Inertial& heel, const Inertial& upper_body, const Matrix3& R_UR) {
  if (!std::isfinite(height) || height < 0.0)
    throw ModelError("upper-body height above the heel must be >= 0 m, got " + std::to_string(height));
  return add_virtual_base(builder, default_virtual_dofs(height), upper_body_name, heel, upper_body, R_UR);
}

int add_virtual_base(ModelBuilder& builder, const std::array<Dof, 9>& dofs, const std::string& upper_body_name,
                     const Inertial& heel, const Inertial& upper_body, const Matrix3& R_UR, double pivot_above_root) {
  if (!std::isfinite(pivot_above_root) || pivot_above_root < 0.0)
    throw ModelError("the upper body's pivot above the root link must be finite and >= 0 m, got " +
                     std::to_string(pivot_above_root));
  const std::array<const char*, 9> body_names = {"heel_x", "heel_y", "heel", "upper_body_x",
                                                 "upper_body_y", "upper_body_z", "upper_body_roll",
                                                 "upper_body_pitch", ""};
  const std::array<Vector3, 9> axes = {Vector3::UnitX(), Vector3::UnitY(), Vector3::UnitZ(),
                                       Vector3::UnitX(), Vector3::UnitY(), Vector3::UnitZ(),
                                       Vector3::UnitX(), Vector3::UnitY(), Vector3::UnitZ()};
  VirtualDofs v;
  int* dof_slots[9] = {&v.heel_x, &v.heel_y, &v.heel_yaw, &v.ub_x, &v.ub_y, &v.ub_z,
                       &v.ub_roll, &v.ub_pitch, &v.ub_yaw};
  int parent = -1;
  for (int k = 0; k < 9; ++k) {
    Body body;
    body.name = k == 8 ? upper_body_name : body_names[k];
    body.parent = parent;
    body.joint_type = dofs[k].type;
    body.axis = axes[k];
    if (k == 8) {  // the root link, turned by R_UR; its yaw axis stays the vertical
      body.X_PJ.R = R_UR;
      // Hung below the pivot along the pitch body's z axis: the yaw axis through the root
      // link's origin is the vertical through the pivot too, so the offset commutes with it.
      body.X_PJ.p = Vector3(0.0, 0.0, -pivot_above_root);
      body.axis = R_UR.transpose() * axes[k];
    }
    body.dof = builder.add_dof(dofs[k]);
    if (k == 2) body.inertial = heel;
    if (k == 8) body.inertial = upper_body;
    *dof_slots[k] = body.dof;
    parent = builder.add_body(body);
    if (k == 2) v.heel_body = parent;
  }
  v.upper_body = parent;
  builder.set_virtual_dofs(v);
  return parent;
}

double upper_body_pivot_above_root(const Model& model) {
  const int ub = model.virtual_dofs().upper_body;
  return ub >= 0 ? -model.body(ub).X_PJ.p.z() : 0.0;
}

}  // namespace wbm
