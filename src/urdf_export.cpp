#include <algorithm>
#include <array>
#include <charconv>
#include <functional>
#include <iomanip>
#include <set>
#include <sstream>
#include <utility>

#include "wbm/errors.hpp"
#include "wbm/kinematics.hpp"
#include "wbm/urdf_import.hpp"

namespace wbm {
namespace {

std::string vec(const Vector3& v) {
  std::ostringstream out;
  out << std::setprecision(17) << v.x() << " " << v.y() << " " << v.z();
  return out.str();
}

/// The shortest decimal that reads back as the same double (for the import options named
/// in the file's comment: exact, and 0.6 rather than 0.59999999999999998).
std::string shortest(double value) {
  char text[32];
  const auto result = std::to_chars(text, text + sizeof text, value);
  return std::string(text, result.ptr);
}

std::string origin(const Transform& X) {
  return "<origin xyz=\"" + vec(X.p) + "\" rpy=\"" + vec(rpy_from_rotation(X.R)) + "\"/>";
}

void write_inertial(std::ostream& out, const Inertial& in) {
  if (in.mass <= 0.0) return;
  const Matrix3& I = in.inertia;
  out << std::setprecision(17) << "    <inertial>\n      <origin xyz=\"" << vec(in.com)
      << "\" rpy=\"0 0 0\"/>\n      <mass value=\"" << in.mass << "\"/>\n      <inertia ixx=\"" << I(0, 0)
      << "\" ixy=\"" << I(0, 1) << "\" ixz=\"" << I(0, 2) << "\" iyy=\"" << I(1, 1) << "\" iyz=\"" << I(1, 2)
      << "\" izz=\"" << I(2, 2) << "\"/>\n    </inertial>\n";
}

/// `name`, or `name` with underscores appended until no body or frame has it.
std::string unused_link_name(const Model& model, std::string name) {
  auto taken = [&](const std::string& candidate) {
    for (int b = 0; b < model.num_bodies(); ++b)
      if (model.body(b).name == candidate) return true;
    for (const Frame& f : model.frames())
      if (f.name == candidate) return true;
    return false;
  };
  while (taken(name)) name += "_";
  return name;
}

}  // namespace

std::string export_urdf(const Model& model, const UrdfExportOptions& options) {
  const VirtualDofs& v = model.virtual_dofs();
  // Bodies after `root` are written with their joints; the root link has no joint. With the
  // virtual dofs, the root link is the world and every body (from body 0) has a joint.
  const bool whole_tree = options.virtual_dofs;
  const int root = whole_tree ? -1 : (v.upper_body >= 0 ? v.upper_body : 0);
  const std::string root_link = whole_tree ? unused_link_name(model, "world") : model.body(root).name;
  auto link_name = [&](int body) { return body < 0 ? root_link : model.body(body).name; };
  // The link a joint hangs from and the joint's origin in it: the frame given as Frame::parent
  // (a welded link of the source URDF) or, if none, the body's link. `X_B` is the origin in
  // the parent frame's body.
  auto hang = [&](const Frame& f, int body, const Transform& X_B) -> std::pair<std::string, Transform> {
    if (f.parent < 0) return {link_name(body), X_B};
    const Frame& p = model.frame(f.parent);
    return {model.is_body_frame(f.parent) ? link_name(p.body) : p.name, p.X_BF.inverse() * X_B};
  };
  std::ostringstream out;
  out << std::setprecision(17);
  out << "<?xml version=\"1.0\"?>\n<!-- Written by wbm from model '" << model.name() << "'. ";
  if (whole_tree)
    out << "Every dof is a joint, the virtual ones included; link '" << root_link << "' is the world frame. -->\n";
  else {
    // The import options that give this model back: the root, its height above the ground
    // (the top of upper_body_z's range less the pivot's height above the root: the legs'
    // length the import measured, or the height it was given; without it the import would
    // assume 1 m), the pivot where the root link's origin lies at the feet, and root_rpy where
    // turned.
    std::string import_options = "root '" + root_link + "'", flags = "--root " + root_link;
    const double pivot = upper_body_pivot_above_root(model);
    if (v.ub_z >= 0) {
      const std::string height = shortest(model.dof(v.ub_z).upper - pivot);
      import_options += ", root_height " + height;
      flags += " --root-height " + height;
    }
    if (pivot > 0.0) {  // the root link's origin at the feet: the pivot the import chose or was given
      import_options += ", upper_body_pivot " + shortest(pivot);
      flags += " --upper-body-pivot " + shortest(pivot);
    }
    // Upper-body shift ranges other than the import's defaults.
    const UrdfImportOptions defaults;
    const std::array<std::pair<int, std::array<double, 2>>, 2> ranges = {
        {{v.ub_x, defaults.upper_body_x_range}, {v.ub_y, defaults.upper_body_y_range}}};
    for (const auto& [dof, range] : ranges) {
      if (dof < 0 || (model.dof(dof).lower == range[0] && model.dof(dof).upper == range[1])) continue;
      const std::string name = dof == v.ub_x ? "upper_body_x_range" : "upper_body_y_range";
      const std::string lower = shortest(model.dof(dof).lower), upper = shortest(model.dof(dof).upper);
      std::string flag = name;
      std::replace(flag.begin(), flag.end(), '_', '-');
      import_options += ", " + name + " " + lower + " " + upper;
      flags += " --" + flag + " " + lower + "," + upper;
    }
    if (!model.body(root).X_PJ.R.isIdentity(0.0)) {  // turned by UrdfImportOptions::root_rpy
      const Vector3 rpy = rpy_from_rotation(model.body(root).X_PJ.R);
      const std::string r = shortest(rpy.x()), p = shortest(rpy.y()), y = shortest(rpy.z());
      import_options += " and root_rpy " + r + " " + p + " " + y;
      flags += " --root-rpy " + r + "," + p + "," + y;
    }
    out << "Import with " << import_options << " (" << flags << "). -->\n";
  }
  out << "<robot name=\"" << model.name() << "\">\n";
  out << "  <link name=\"" << root_link << "\">\n";
  if (!whole_tree) write_inertial(out, model.body(root).inertial);
  out << "  </link>\n";
  // Each dof's URDF joint (named as the dof, carrying its limits) is a body it drives with
  // multiplier 1 and offset 0; the other bodies it drives are <mimic> joints of it. Not
  // simply the first body: after re-rooting, a reversed mimic joint can come first; the body
  // whose joint was the dof's own in the source (Body::joint_name as the dof's) is preferred.
  std::vector<int> primary_body(model.num_dofs(), -1);
  for (int b = model.num_bodies() - 1; b > root; --b) {
    const Body& body = model.body(b);
    if (body.dof < 0 || body.multiplier != 1.0 || body.offset != 0.0) continue;
    const int current = primary_body[body.dof];
    if (current < 0 || model.body(current).joint_name != model.dof(body.dof).name) primary_body[body.dof] = b;
  }
  for (int b = root + 1; b < model.num_bodies(); ++b) {
    const Body& body = model.body(b);
    if (body.dof >= 0 && primary_body[body.dof] < 0)
      throw ModelError("export_urdf: dof '" + model.dof(body.dof).name + "' drives no body with multiplier 1 and offset "
                       "0 (body '" + body.name + "' has " + std::to_string(body.multiplier) + " and " +
                       std::to_string(body.offset) + "); a URDF joint cannot scale its own value");
  }
  // Joint names: the source's where the model kept them (mimic and fixed joints, Body and
  // Frame::joint_name), the dof's for its primary body; otherwise the child link's name with
  // "_joint", and underscores appended while another joint has that name.
  std::set<std::string> joint_names;
  for (int b = root + 1; b < model.num_bodies(); ++b) {
    const Body& body = model.body(b);
    if (body.dof >= 0 && primary_body[body.dof] == b) joint_names.insert(model.dof(body.dof).name);
    else if (!body.joint_name.empty()) joint_names.insert(body.joint_name);
  }
  for (const Frame& f : model.frames())
    if (!f.joint_name.empty()) joint_names.insert(f.joint_name);
  auto joint_name = [&](const std::string& kept, const std::string& link) {
    if (!kept.empty()) return kept;
    std::string name = link + "_joint";
    while (!joint_names.insert(name).second) name += "_";
    return name;
  };
  if (!whole_tree && v.heel_body >= 0 && model.body(v.heel_body).inertial.mass > 0.0) {
    // The heel body's mass, welded below the upper body at the home pose.
    Data data(model);
    forward_kinematics(model, data, model.home());
    const Transform X_UH = data.X_WB[root].inverse() * data.X_WB[v.heel_body];
    const std::string heel_link = unused_link_name(model, "heel_mass");
    out << "  <link name=\"" << heel_link << "\">\n";
    write_inertial(out, model.body(v.heel_body).inertial);
    out << "  </link>\n  <joint name=\"" << joint_name("", heel_link) << "\" type=\"fixed\">\n    <parent link=\""
        << root_link << "\"/>\n    <child link=\"" << heel_link << "\"/>\n    " << origin(X_UH) << "\n  </joint>\n";
  }
  // A welded link (a frame that is not a body's own) is written just before the first joint
  // that hangs from it, or at the end if none does. The import numbers the dofs depth-first,
  // taking a link's joints in file order; written after every body, a welded link with a
  // joint below it (a neck on a head mount) would put that joint's dof after the bodies that
  // follow it here, and the exported file would number the dofs differently from the model.
  std::vector<bool> frame_written(model.num_frames(), false);
  std::function<void(int)> write_frame = [&](int i) {
    const Frame& f = model.frame(i);
    if (frame_written[i] || model.is_body_frame(i) || f.body < root) return;
    frame_written[i] = true;
    if (f.parent >= 0) write_frame(f.parent);
    const auto [parent_link, X_PF] = hang(f, f.body, f.X_BF);
    out << "  <link name=\"" << f.name << "\"/>\n  <joint name=\"" << joint_name(f.joint_name, f.name)
        << "\" type=\"fixed\">\n    <parent link=\""
        << parent_link << "\"/>\n    <child link=\"" << f.name << "\"/>\n    " << origin(X_PF) << "\n  </joint>\n";
  };
  for (int b = root + 1; b < model.num_bodies(); ++b) {
    const Body& body = model.body(b);
    const Frame& body_frame = model.frame(model.frame_index(body.name));
    if (body_frame.parent >= 0) write_frame(body_frame.parent);
    out << "  <link name=\"" << body.name << "\">\n";
    write_inertial(out, body.inertial);
    out << "  </link>\n";
    const auto [parent_link, X_PJ] = hang(body_frame, body.parent, body.X_PJ);
    if (body.dof < 0) {  // welded to its parent
      out << "  <joint name=\"" << joint_name(body.joint_name, body.name) << "\" type=\"fixed\">\n    <parent link=\""
          << parent_link
          << "\"/>\n    <child link=\"" << body.name << "\"/>\n    " << origin(X_PJ) << "\n  </joint>\n";
      continue;
    }
    const Dof& dof = model.dof(body.dof);
    const bool primary = primary_body[body.dof] == b;
    const char* type = dof.continuous ? "continuous" : to_string(body.joint_type);
    out << "  <joint name=\"" << (primary ? dof.name : joint_name(body.joint_name, body.name)) << "\" type=\"" << type
        << "\">\n    <parent link=\"" << parent_link << "\"/>\n    <child link=\"" << body.name
        << "\"/>\n    " << origin(X_PJ) << "\n    <axis xyz=\"" << vec(body.axis) << "\"/>\n    <limit lower=\""
        << (dof.continuous ? 0.0 : dof.lower) << "\" upper=\"" << (dof.continuous ? 0.0 : dof.upper)
        << "\" effort=\"" << dof.max_effort << "\" velocity=\"" << dof.max_speed << "\"/>\n";
    if (!primary)
      out << "    <mimic joint=\"" << dof.name << "\" multiplier=\"" << body.multiplier << "\" offset=\""
          << body.offset << "\"/>\n";
    out << "  </joint>\n";
  }
  for (int i = 0; i < model.num_frames(); ++i) write_frame(i);
  out << "</robot>\n";
  return out.str();
}

}  // namespace wbm
