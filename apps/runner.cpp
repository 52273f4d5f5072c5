#include "runner.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <tuple>

#include <Eigen/SVD>

#include "closest_names.hpp"
#include "leg_poser.hpp"
#include "model_notes.hpp"
#include "task_notes.hpp"
#include "report_writer.hpp"
#include "wbm/balance.hpp"
#include "wbm/errors.hpp"
#include "wbm/paper_model.hpp"
#include "wbm/tasks/attitude_task.hpp"
#include "wbm/tasks/axis_task.hpp"
#include "wbm/tasks/com_task.hpp"
#include "wbm/tasks/joint_task.hpp"
#include "wbm/tasks/position_task.hpp"

namespace wbm {
namespace {

using nlohmann::json;

[[noreturn]] void fail(const Scenario& s, int line, const std::string& message) {
  throw ConfigError(s.source + ":" + std::to_string(line) + ": " + message);
}

/// Runs `bind` (which looks names of the scenario up in the model) and turns a library error
/// into "FILE:LINE: field: message".
template <class Bind>
auto bound(const Scenario& s, int line, const std::string& field, Bind bind) {
  try {
    return bind();
  } catch (const Error& e) {
    fail(s, line, field + ": " + e.what());
  }
}

std::unique_ptr<TaskElement> make_element(const Model& model, const ScenarioTask& t) {
  std::unique_ptr<TaskElement> e;
  if (t.type == "position") e = std::make_unique<PositionTask>(model, t.name, t.frame, t.reference);
  if (t.type == "axis") e = std::make_unique<AxisTask>(model, t.name, t.frame, t.reference, t.axis);
  if (t.type == "attitude") e = std::make_unique<AttitudeTask>(model, t.name, t.frame, t.reference);
  if (t.type == "com") e = std::make_unique<CenterOfMassTask>(model, t.name, t.reference);
  if (t.type == "joints") e = std::make_unique<JointTask>(model, t.name, t.dofs);
  e->set_gain(t.gain);
  return e;
}

/// "FIELD: " where a field is known (an event's), else "".
std::string where(const std::string& field) { return field.empty() ? "" : field + ": "; }

/// " (did you mean 'x'?)", or the element names when none is close.
std::string element_hint(const TaskStack& stack, const std::string& name) {
  std::vector<std::string> names;
  for (int i = 0; i < stack.num_elements(); ++i) names.push_back(stack.element(i).name());
  const std::string close = internal::did_you_mean(name, names);
  if (!close.empty() || names.empty()) return close;
  std::string all;
  for (const std::string& n : names) all += (all.empty() ? "" : ", ") + n;
  return " (the elements: " + all + ")";
}

/// Rows of the task vector named by "element" or "element.component".
std::vector<int> resolve_rows(const Scenario& s, const Controller& c, const RowSelection& sel) {
  const TaskStack& stack = c.tasks();
  const size_t dot = sel.text.find('.');
  const std::string name = sel.text.substr(0, dot);
  int element = -1;
  for (int i = 0; i < stack.num_elements(); ++i)
    if (stack.element(i).name() == name) element = i;
  if (element < 0) fail(s, sel.line, where(sel.field) + "no task element named '" + name + "'" + element_hint(stack, name));
  const int r0 = stack.row_offset(element), dim = stack.element(element).dim();
  std::vector<int> rows;
  if (dot == std::string::npos) {
    for (int r = 0; r < dim; ++r) rows.push_back(r0 + r);
    return rows;
  }
  const std::string component = sel.text.substr(dot + 1);
  const std::string& type = s.tasks[element].type;
  std::vector<std::string> names;
  if (type == "position" || type == "com") names = {"x", "y", "z"};
  if (type == "attitude") names = {"roll", "pitch", "yaw"};
  if (type == "axis") names = {"0", "1"};
  if (type == "joints") names = s.tasks[element].dofs;
  for (int r = 0; r < dim; ++r)
    if (names[r] == component || std::to_string(r) == component) return {r0 + r};
  std::string valid;
  for (int r = 0; r < dim; ++r) valid += (r ? ", " : "") + name + "." + names[r];
  fail(s, sel.line, where(sel.field) + "task element '" + name + "' has no row '" + component + "' (its rows: " + valid + ")");
}

/// Scalar distance between a value and a target of an element (m, rad). For elements whose
/// rows are the target's components, only the active rows count.
double distance(const std::string& type, const Eigen::Ref<const Eigen::VectorXd>& a,
                const Eigen::Ref<const Eigen::VectorXd>& b, const Eigen::Ref<const Mask>& rows) {
  if (type == "axis") {
    const Vector3 u = a.head<3>().normalized(), v = b.head<3>().normalized();
    return std::atan2(u.cross(v).norm(), u.dot(v));
  }
  const bool all = !rows.any();
  if (type == "attitude" && (all || rows.all()) && a.allFinite() && b.allFinite()) {
    // The angle of the rotation between the two (what the element's error is then): Kardan
    // angles past 90 degrees of pitch name the same rotation as others within.
    const Eigen::AngleAxisd between(AttitudeTask::kardan_rotation(a.head<3>()).transpose() *
                                    AttitudeTask::kardan_rotation(b.head<3>()));
    return between.angle();
  }
  // Attitude: of the angles, with the target's pitch within +-90 degrees (the same rotation).
  const Vector3 b_attitude = type == "attitude" ? AttitudeTask::canonical_angles(b.head<3>()) : Vector3::Zero();
  auto difference = [&](int i) {
    return type == "attitude" ? std::remainder(a[i] - b_attitude[i], 2.0 * M_PI) : a[i] - b[i];
  };
  double max = 0.0;
  for (int i = 0; i < a.size(); ++i) {
    if (!all && !rows[i]) continue;
    const double d = std::abs(difference(i));
    if (std::isnan(d)) return d;
    max = std::max(max, d);
  }
  if (type == "joints" || max == 0.0 || std::isinf(max)) return max;
  // Scaled by the largest entry: a target 1e308 m away is that far, not an overflow to inf.
  double sum = 0.0;
  for (int i = 0; i < a.size(); ++i)
    if (all || rows[i]) sum += (difference(i) / max) * (difference(i) / max);
  return max * std::sqrt(sum);
}

void progress_bar(double t, double duration, bool done) {
  const int width = 40;
  const double f = std::clamp(t / duration, 0.0, 1.0);
  const int fill = static_cast<int>(f * width);
  std::fprintf(stderr, "\r[%s%s] %3d%%  t = %.2f / %.2f s", std::string(fill, '#').c_str(),
               std::string(width - fill, ' ').c_str(), static_cast<int>(f * 100), t, duration);
  if (done) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

/// Records a cycle in which balance drove an upper-body shift dof at its limit further out
/// (BalanceModule::last_shift_at_limit): which dof, its limit, and the shift the centre of
/// mass would have needed: the dof's value plus the centre of mass's offset from the target's
/// centroid along the dof's axis (the heel frame's x or y), divided by the share of the mass
/// the dof moves (the heel body's own mass stays; 1 for a URDF import, whose heel is massless).
void note_shift_at_limit(const Model& model, const Controller& c, const SupportPolygon& target,
                         const std::array<int, 2>& side, ScenarioRun& run) {
  const VirtualDofs& v = model.virtual_dofs();
  const Vector2 com = center_of_mass_position(model, c.data()).head<2>();
  const Matrix3& R_WH = c.data().X_WB[v.heel_body].R;
  const Vector2 offset_H = R_WH.topLeftCorner<2, 2>().transpose() * (target.centroid() - com);
  const std::array<int, 2> dofs = {v.ub_x, v.ub_y};
  for (int k = 0; k < 2; ++k) {
    if (side[k] == 0) continue;
    double moved_mass = 0.0;  // the subtree of the body the dof drives
    for (int b = 0; b < model.num_bodies(); ++b)
      if (model.body(b).dof == dofs[k]) moved_mass = model.subtree_mass()[b];
    const double share = model.total_mass() > 0.0 && moved_mass > 0.0 ? moved_mass / model.total_mass() : 1.0;
    ScenarioRun::ShiftAtLimit& s = run.shift_at_limit[k];
    const double needed = c.q()[dofs[k]] + offset_H[k] / share;
    if (s.cycles == 0 || (side[k] > 0 ? needed > s.needed : needed < s.needed)) s.needed = needed;
    s.side = side[k];
    ++s.cycles;
  }
}

}  // namespace

Eigen::VectorXd ScenarioRun::actual_of(const std::string& name, int k) const {
  const int e = element(name);
  return actual[k].segment(controller->tasks().target_offset(e), controller->tasks().element(e).target_dim());
}

Eigen::VectorXd ScenarioRun::commanded_of(const std::string& name, int k) const {
  const int e = element(name);
  return commanded[k].segment(controller->tasks().target_offset(e), controller->tasks().element(e).target_dim());
}

double position_condition_number(const Model& model, const Data& data, int frame, bool joints_only) {
  Eigen::MatrixXd J(6, model.num_dofs());
  frame_jacobian(model, data, frame, J);
  Eigen::MatrixXd Jp = J.topRows<3>();
  for (int i = 0; i < model.num_dofs(); ++i) {
    const bool keep = !joints_only || model.dof(i).role == DofRole::kJoint;
    Jp.col(i) *= keep ? model.dof(i).work_range : 0.0;
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(Jp);
  const Eigen::VectorXd sv = svd.singularValues();
  // Rank below 3 within rounding (sigma_min / sigma_max at 1e-12): infinite, not the 1e16 to
  // 1e33 that rounding left of a zero singular value (a two-joint arm's position rows on a
  // small robot), which flattened every other series of the report's plot.
  return sv[2] > 1e-12 * sv[0] ? sv[0] / sv[2] : std::numeric_limits<double>::infinity();
}

std::unique_ptr<ScenarioRun> run_scenario(const Scenario& s, const RunOptions& options) {
  const int steps = scenario_cycles(s.duration, s.dt);  // parse_scenario checks files; this, Scenarios built in code
  if (steps == 0 || s.record_every < 1)
    throw ConfigError(s.source + ": duration / dt must give 1 to " + std::to_string(kMaxScenarioCycles) +
                      " cycles and record_every must be >= 1");
  auto run = std::make_unique<ScenarioRun>();
  run->scenario = s;
  run->model = std::make_unique<Model>(
      s.urdf.empty() ? make_paper_model() : bound(s, s.robot_line, "robot", [&] { return load_urdf(s.urdf, s.urdf_options); }));
  const Model& model = *run->model;
  run->controller = std::make_unique<Controller>(model, s.solver);
  Controller& c = *run->controller;
  // The task elements, and the names the model lacks in them, `initial` and `frozen`: of
  // those, the first in the file is reported (frozen on line 6 before a task on line 9),
  // whatever order they are used in.
  std::vector<std::unique_ptr<TaskElement>> elements(s.tasks.size());
  {
    std::vector<std::pair<int, std::string>> errors;
    const auto check = [&](int line, const std::string& field, const auto& lookup) {
      try {
        bound(s, line, field, lookup);
      } catch (const Error& e) {
        errors.emplace_back(line, e.what());
      }
    };
    for (size_t i = 0; i < s.tasks.size(); ++i)
      check(s.tasks[i].line, "tasks[" + std::to_string(i) + "]",
            [&] { return (elements[i] = make_element(model, s.tasks[i])).get(); });
    for (const auto& entry : s.initial)
      check(s.initial_line, "initial", [&] { return model.dof_index(entry.first); });
    for (const std::string& d : s.frozen) check(s.frozen_line, "frozen", [&] { return model.dof_index(d); });
    const auto by_line = [](const auto& a, const auto& b) { return a.first < b.first; };
    if (!errors.empty()) throw ConfigError(std::min_element(errors.begin(), errors.end(), by_line)->second);
  }
  for (size_t i = 0; i < s.tasks.size(); ++i) {
    const ScenarioTask& t = s.tasks[i];
    bound(s, t.line, "tasks[" + std::to_string(i) + "]", [&] { return c.add_task(std::move(elements[i]), t.filter); });
    run->element_types.push_back(t.type);
  }
  if (s.criterion == "squared") c.set_criterion(std::make_unique<JointCenterCriterion>(model));
  else c.set_criterion(std::make_unique<CubicJointLimitCriterion>(model, s.criterion_band));
  Eigen::VectorXd q0 = s.fixed_base ? upright_base_configuration(model, model.home()) : model.home();
  for (const auto& entry : s.initial)
    q0[bound(s, s.initial_line, "initial", [&] { return model.dof_index(entry.first); })] = entry.second;
  // A value of `initial` outside its dof's limits: reported at that line, as unknown names are.
  bound(s, s.initial_line, "initial", [&] { c.reset(q0); return 0; });
  Command cmd = c.make_command();
  cmd.external_velocity.setZero(model.num_dofs());
  TaskStack& stack = c.tasks();
  for (int i = 0; i < stack.num_elements(); ++i)
    cmd.task_active.segment(stack.row_offset(i), stack.element(i).dim()).setConstant(s.tasks[i].active);
  stack.activation() = cmd.task_active;  // the record at t = 0, before the first update, shows it
  for (const std::string& d : s.frozen)
    cmd.free_dofs[bound(s, s.frozen_line, "frozen", [&] { return model.dof_index(d); })] = false;
  if (s.fixed_base)
    for (const int i : model.virtual_dofs().all())
      if (i >= 0) cmd.free_dofs[i] = false;

  // Resolve every name of the timeline before running, so errors come before any output.
  struct Resolved {
    std::vector<std::pair<int, Eigen::VectorXd>> targets, relative;
    std::vector<int> on, off, freeze, release;
  };
  std::vector<Resolved> events;
  std::vector<std::string> target_notes;  // joint targets outside their dofs' ranges
  for (const ScenarioEvent& ev : s.events) {
    Resolved r;
    // `k`: the entry's index in its mapping (its line, where read from a file).
    auto element_of = [&](const std::string& name, const Eigen::VectorXd& v, bool relative, size_t k) {
      const std::vector<int>& lines = relative ? ev.relative_target_lines : ev.target_lines;
      const int line = k < lines.size() ? lines[k] : ev.line;
      const std::string field = (ev.field.empty() ? "" : ev.field + ".") + (relative ? "relative_targets" : "targets");
      int e = -1;
      for (int i = 0; i < stack.num_elements(); ++i)
        if (stack.element(i).name() == name) e = i;
      if (e < 0) fail(s, line, field + ": no task element named '" + name + "'" + element_hint(stack, name));
      const int dim = stack.element(e).target_dim();
      if (v.size() != dim)
        fail(s, line, field + "." + name + ": expected " + std::to_string(dim) + (dim == 1 ? " value" : " values") +
                          ", got " + std::to_string(v.size()));
      if (relative && stack.element(e).target_kind() == TargetKind::kDirection)
        fail(s, line, field + "." + name + ": axis targets must be absolute directions");
      if (!relative && stack.element(e).target_kind() == TargetKind::kDirection && v.norm() < 1e-9)
        fail(s, line, field + "." + name + ": the direction must not be zero");
      if (!relative && s.tasks[e].type == "joints")
        for (int k_dof = 0; k_dof < v.size(); ++k_dof)
          if (const Dof& dof = model.dof(model.dof_index(s.tasks[e].dofs[k_dof]));
              !dof.continuous && !(v[k_dof] >= dof.lower && v[k_dof] <= dof.upper)) {
            std::ostringstream note;  // the joint stops at its limit: the element's error stays
            note << "task '" << name << "': the target of '" << dof.name << "', " << v[k_dof] << " (" << field << ", line "
                 << line << "), lies outside its range [" << dof.lower << ", " << dof.upper
                 << "]: the joint stops at its limit, " << std::abs(v[k_dof] - std::clamp(v[k_dof], dof.lower, dof.upper))
                 << (dof.type == JointType::kPrismatic ? " m" : " rad") << " short";
            target_notes.push_back(note.str());
          }
      return e;
    };
    for (size_t k = 0; k < ev.targets.size(); ++k)
      r.targets.emplace_back(element_of(ev.targets[k].first, ev.targets[k].second, false, k), ev.targets[k].second);
    for (size_t k = 0; k < ev.relative_targets.size(); ++k)
      r.relative.emplace_back(element_of(ev.relative_targets[k].first, ev.relative_targets[k].second, true, k),
                              ev.relative_targets[k].second);
    for (const RowSelection& sel : ev.activate)
      for (int row : resolve_rows(s, c, sel)) r.on.push_back(row);
    for (const RowSelection& sel : ev.deactivate)
      for (int row : resolve_rows(s, c, sel)) r.off.push_back(row);
    for (const std::string& d : ev.freeze)
      r.freeze.push_back(bound(s, ev.line, "freeze", [&] { return model.dof_index(d); }));
    for (const std::string& d : ev.release) {
      r.release.push_back(bound(s, ev.line, "release", [&] { return model.dof_index(d); }));
      if (s.fixed_base && model.dof(r.release.back()).role != DofRole::kJoint)
        fail(s, ev.line, "release: '" + d + "' is a virtual dof, which robot.fixed_base keeps frozen");
    }
    events.push_back(r);
  }

  std::unique_ptr<BalanceModule> balance;
  bool balance_on = s.balance.enabled;
  bool balance_needed = s.balance.configured || s.balance.enabled;
  for (const ScenarioEvent& ev : s.events) balance_needed |= ev.balance == 1;
  FootGeometry feet = s.feet.geometry;
  if (!s.feet.left_frame.empty()) {
    // Spacing: lateral distance of the two foot frames in the heel frame, home pose.
    const Data& d = c.data();
    const Transform X_HW = d.X_WB[model.virtual_dofs().heel_body].inverse();
    auto foot = [&](const std::string& frame) {
      return bound(s, s.feet.line, "feet", [&] { return model.frame_index(frame); });
    };
    const double yl = (X_HW * frame_pose(model, d, foot(s.feet.left_frame)).p).y();
    const double yr = (X_HW * frame_pose(model, d, foot(s.feet.right_frame)).p).y();
    feet.spacing = std::abs(yl - yr);
  }
  run->feet = feet;
  if (balance_needed)
    balance = std::make_unique<BalanceModule>(model, std::make_unique<CenterOfMassCentering>(s.balance.gain, s.balance.margin),
                                              feet);
  std::unique_ptr<WalkingModule> walking;
  if (s.walking.enabled) {
    // Step widths, length, duration and position tolerance not given: the defaults (the
    // paper model's) scaled to this robot's feet and height, so that NAO (feet 0.10 m apart,
    // 0.34 m tall at the root) and H1 (0.41 m, 1.04 m) place their feet where they stand and
    // step as far as their legs reach.
    WalkingParameters p = s.walking.parameters;
    std::string scaled_fields;  // those not given, for an error: the user did not write them
    try {
      const WalkingParameters scaled = scaled_walking_parameters(model, feet);
      std::ostringstream text;
      for (const auto& [given, name, from, to] :
           {std::tuple{s.walking.min_width_given, "min_step_width", &scaled.min_step_width, &p.min_step_width},
            std::tuple{s.walking.max_width_given, "max_step_width", &scaled.max_step_width, &p.max_step_width},
            std::tuple{s.walking.length_given, "max_step_length", &scaled.max_step_length, &p.max_step_length},
            std::tuple{s.walking.duration_given, "step_duration", &scaled.step_duration, &p.step_duration}}) {
        if (given) continue;
        *to = *from;
        text << (text.tellp() > 0 ? ", " : "") << name << " " << *from;
      }
      scaled_fields = text.str();
      if (!s.walking.tolerance_given) p.position_tolerance = scaled.position_tolerance;  // > 0: no error to explain
      walking = std::make_unique<WalkingModule>(model, feet, p);
      walking->stand_at(c.q());  // beside the start's heel (`initial` may move it), not the home pose's
      run->walking_parameters = p;
    } catch (const Error& e) {
      // "FILE:LINE: walking: ...", and the values the file did not give.
      fail(s, s.walking.line,
           std::string(e.what()) +
               (scaled_fields.empty() ? "" : " (not given, scaled to the robot's feet and height: " + scaled_fields + ")"));
    }
  }
  auto current_support = [&]() {
    if (walking) return walking->support();
    const VirtualDofs& v = model.virtual_dofs();
    return SupportPolygon::standing(Vector2(c.q()[v.heel_x], c.q()[v.heel_y]), c.q()[v.heel_yaw], feet);
  };
  SupportPolygon support = balance || walking ? current_support() : SupportPolygon();
  cmd.compensate_external = s.balance.compensate;
  ControllerStatus last_status;
  std::uint32_t walking_flags = 0;

  {  // Elements no free dof can move (apps/task_notes.hpp): the dofs free at the start or
     // released by an event count, and those balance (the upper body's shift) and walking
     // (the heel) drive; elements active at the start or switched on by an event.
    std::vector<bool> ever_free(model.num_dofs());
    for (int i = 0; i < model.num_dofs(); ++i) ever_free[i] = cmd.free_dofs[i];
    for (const Resolved& r : events)
      for (const int d : r.release) ever_free[d] = true;
    const VirtualDofs& v = model.virtual_dofs();
    for (const int d : {v.ub_x, v.ub_y})
      if (balance && d >= 0) ever_free[d] = true;
    for (const int d : {v.heel_x, v.heel_y, v.heel_yaw})
      if (walking && d >= 0) ever_free[d] = true;
    std::vector<bool> considered(stack.num_elements());
    for (int e = 0; e < stack.num_elements(); ++e) {
      considered[e] = s.tasks[e].active;
      for (const Resolved& r : events)
        for (const int row : r.on)
          considered[e] = considered[e] || (row >= stack.row_offset(e) && row < stack.row_offset(e) + stack.element(e).dim());
    }
    run->task_notes = immovable_task_notes(model, stack, ever_free, considered, c.q());
    run->task_notes.insert(run->task_notes.end(), target_notes.begin(), target_notes.end());
    // A task on (or relative to) a frame in a locked leg: the controller moves that frame
    // with the upper body, never by the leg's joints, and the report draws the leg elsewhere.
    // (Dropped legs have no frames left to name.)
    for (const ScenarioTask& t : s.tasks)
      for (const std::string& name : {t.frame, t.reference}) {
        const int f = name.empty() ? -1 : model.find_frame(name);
        const int leg = f < 0 ? -1 : leg_of(model, f, s.urdf_options.legs);
        if (leg < 0) continue;
        run->task_notes.push_back(
            "task '" + t.name + "': its " + (name == t.frame ? "frame" : "reference") + " '" + name +
            "' is in the locked leg from '" + s.urdf_options.legs[leg] +
            "': the controller holds that leg rigid at joint value 0 (robot.legs), so the task moves it with the "
            "upper body only, and the 3D view, which draws the leg standing on its foot, draws the frame there "
            "(the task errors are the controller's)");
        break;
      }
    // Balance or walking on a URDF robot without its feet: the default ones are ASIMO-like
    // (ROBOTIS OP3's feet are 12 cm long; "11 cm inside the feet" meant nothing there).
    bool supported = s.balance.enabled || s.walking.enabled;
    for (const ScenarioEvent& ev : s.events) supported = supported || ev.balance == 1;
    if (supported && !s.urdf.empty() && s.feet.line == 0) {
      const FootGeometry d;
      std::ostringstream note;
      note << "balance and walking use the default feet (" << d.length << " m long, " << d.width << " m wide, "
           << d.spacing << " m apart: the paper's robot's), not this robot's: give them with feet: {length, width, "
              "left_frame, right_frame} (docs/scenarios.md)";
      run->task_notes.push_back(note.str());
    }
  }
  if (options.check_only) return run;
  const int n_el = stack.num_elements();
  auto record = [&](double t, std::uint32_t flags, double us) {
    run->time.push_back(t);
    run->q.push_back(c.q());
    run->qdot.push_back(c.qdot());
    run->commanded.push_back(cmd.targets);
    run->filtered.push_back(c.filtered_targets());
    run->actual.push_back(c.values());
    Eigen::VectorXd err(n_el), track(n_el), act(n_el);
    for (int i = 0; i < n_el; ++i) {
      const int t0 = stack.target_offset(i), n = stack.element(i).target_dim();
      const auto rows = stack.activation().segment(stack.row_offset(i), stack.element(i).dim());
      err[i] = distance(s.tasks[i].type, c.values().segment(t0, n), cmd.targets.segment(t0, n), rows);
      track[i] = distance(s.tasks[i].type, c.values().segment(t0, n), c.filtered_targets().segment(t0, n), rows);
      act[i] = stack.element_active(i) ? 1.0 : 0.0;
    }
    run->error.push_back(err);
    run->tracking_error.push_back(track);
    run->active.push_back(act);
    run->flags.push_back(flags);
    run->cost.push_back(c.nullspace_cost());
    run->cycle_us.push_back(us);
    run->min_singular_value.push_back(c.solver().output().min_singular_value);
    if (balance || walking) run->support.push_back(support);
    if (walking) {
      const FootPose h = walking->real_heel();
      run->walking.push_back((Eigen::VectorXd(5) << h.position.x(), h.position.y(), h.yaw, walking->walking() ? 1.0 : 0.0,
                              static_cast<double>(walking_flags)).finished());
    }
    if (balance) {
      Eigen::VectorXd b(7);
      const Vector2 com = center_of_mass_position(model, c.data()).head<2>();
      b << com.x(), com.y(), support.centroid().x(), support.centroid().y(),
          c.q()[model.virtual_dofs().ub_x], c.q()[model.virtual_dofs().ub_y], support.signed_distance(com);
      run->balance.push_back(b);
    }
  };
  record(0.0, 0, 0.0);
  const bool tty = options.progress && isatty(STDERR_FILENO);
  size_t next_event = 0;
  for (int k = 1; k <= steps; ++k) {
    const double t_start = (k - 1) * s.dt;
    while (next_event < s.events.size() && s.events[next_event].time <= t_start + 1e-12) {
      const Resolved& r = events[next_event];
      if (walking && (!r.targets.empty() || !r.relative.empty())) walking->target_changed();
      for (const auto& [e, v] : r.targets) cmd.targets.segment(stack.target_offset(e), v.size()) = v;
      for (const auto& [e, v] : r.relative)
        cmd.targets.segment(stack.target_offset(e), v.size()) = c.values().segment(stack.target_offset(e), v.size()) + v;
      for (int row : r.on) cmd.task_active[row] = true;
      for (int row : r.off) cmd.task_active[row] = false;
      for (int d : r.freeze) cmd.free_dofs[d] = false;
      for (int d : r.release) cmd.free_dofs[d] = true;
      if (s.events[next_event].balance >= 0) {
        balance_on = s.events[next_event].balance == 1;
        // Switching off a balance that was never built (no balance section, never switched
        // on) changes nothing.
        if (!balance_on && balance) balance->disable(cmd);
      }
      ++next_event;
    }
    if (walking) {
      walking_flags = walking->update(c, last_status, t_start, s.dt, cmd);
      if (walking_flags & kFootstepLanded) run->footsteps.push_back(walking->last_footstep());
      support = walking->support();
    } else if (balance) {
      support = current_support();
    }
    // During a walk the upper body is balanced over the feet as planned beside the floating
    // heel, not over the feet left behind (WalkingModule::balance_support).
    if (balance && balance_on) {
      const SupportPolygon target = walking ? walking->balance_support(c.q()) : support;
      const std::uint32_t balance_flags = balance->update(c.data(), target, s.dt, cmd);
      ++run->balanced_cycles;
      if (balance_flags & kShiftAtLimit) note_shift_at_limit(model, c, target, balance->last_shift_at_limit(), *run);
    }
    const auto t0 = std::chrono::steady_clock::now();
    const ControllerStatus st = c.update(cmd, s.dt);
    last_status = st;
    const auto t1 = std::chrono::steady_clock::now();
    record(k * s.dt, st.flags, std::chrono::duration<double, std::micro>(t1 - t0).count());
    if (tty && (k % 200 == 0 || k == steps)) progress_bar(k * s.dt, s.duration, k == steps);
  }
  run->balance_on_at_end = balance_on;
  return run;
}

double error_scale(const ScenarioTask& task) {
  if (task.type == "axis" || task.type == "attitude") return 180.0 / M_PI;
  return task.type == "joints" ? 1.0 : 1000.0;
}

double body_lead(const ScenarioRun& run, size_t k) {
  const VirtualDofs& v = run.model->virtual_dofs();
  return std::hypot(run.q[k][v.heel_x] - run.walking[k][0], run.q[k][v.heel_y] - run.walking[k][1]);
}

std::string error_unit(const ScenarioTask& task, const TaskElement& element) {
  if (task.type == "axis" || task.type == "attitude") return "deg";
  if (task.type != "joints") return "mm";
  bool angles = false, lengths = false;  // a joint element's rows: revolute and prismatic dofs
  for (int row = 0; row < element.dim(); ++row) (element.row_unit(row) == RowUnit::kAngle ? angles : lengths) = true;
  return angles && lengths ? "rad, m" : lengths ? "m" : "rad";
}

json summarize(const ScenarioRun& run) {
  const Scenario& s = run.scenario;
  const Model& model = *run.model;
  const int n = model.num_dofs();
  const int K = run.num_cycles();
  json out;
  out["scenario"] = s.name;
  out["description"] = s.description;
  out["model"] = model.name();
  out["dofs"] = n;
  out["dt"] = s.dt;
  out["duration"] = s.duration;
  out["cycles"] = K - 1;
  out["model_notes"] = model_notes(model, !s.urdf.empty(), s.urdf_options.legs);
  out["task_notes"] = run.task_notes;
  json elements = json::object();
  for (int i = 0; i < static_cast<int>(s.tasks.size()); ++i) {
    const std::string& type = run.element_types[i];
    const double scale = error_scale(s.tasks[i]);
    double max_error = 0.0, max_tracking = 0.0;
    for (int k = 0; k < K; ++k)
      if (run.active[k][i] > 0.0) {
        max_error = std::max(max_error, run.error[k][i]);
        max_tracking = std::max(max_tracking, run.tracking_error[k][i]);
      }
    elements[s.tasks[i].name] = {{"type", type},
                                 {"unit", error_unit(s.tasks[i], run.controller->tasks().element(i))},
                                 {"active_at_end", run.active[K - 1][i] > 0.0},
                                 {"final_error", run.active[K - 1][i] > 0.0 ? json(run.error[K - 1][i] * scale) : json(nullptr)},
                                 {"max_error", max_error * scale},
                                 {"max_tracking_error", max_tracking * scale}};
  }
  out["elements"] = elements;
  double max_speed_ratio = 0.0, max_speed = 0.0, max_acc = 0.0, min_limit = std::numeric_limits<double>::infinity();
  int speed_dof = 0, acc_dof = 0, limit_dof = 0;
  // The Controller's bound on the change of a rate, k v_max (k = the solver's jerk_limit).
  const double k_rate = s.solver.nullspace_rate_change_limit;
  double max_acc_ratio = 0.0;
  int acc_ratio_dof = 0;
  for (int k = 0; k < K; ++k)
    for (int i = 0; i < n; ++i) {
      const double v = std::abs(run.qdot[k][i]);
      if (v / model.dof(i).max_speed > max_speed_ratio) {
        max_speed_ratio = v / model.dof(i).max_speed;
        max_speed = v;
        speed_dof = i;
      }
      if (k >= 1) {
        const double a = std::abs(run.qdot[k][i] - run.qdot[k - 1][i]) / s.dt;
        if (a > max_acc) {
          max_acc = a;
          acc_dof = i;
        }
        if (k_rate > 0.0 && a / (k_rate * model.dof(i).max_speed) > max_acc_ratio) {
          max_acc_ratio = a / (k_rate * model.dof(i).max_speed);
          acc_ratio_dof = i;
        }
      }
      if (!model.dof(i).continuous && model.dof(i).role == DofRole::kJoint) {
        const double d = std::min(run.q[k][i] - model.dof(i).lower, model.dof(i).upper - run.q[k][i]);
        if (d < min_limit) {
          min_limit = d;
          limit_dof = i;
        }
      }
    }
  out["max_joint_speed"] = {{"value", max_speed}, {"dof", model.dof(speed_dof).name}, {"ratio_to_limit", max_speed_ratio}};
  out["max_joint_acceleration"] = {{"value", max_acc}, {"dof", model.dof(acc_dof).name}};
  if (k_rate > 0.0)
    out["max_joint_acceleration_to_bound"] = {{"ratio", max_acc_ratio}, {"dof", model.dof(acc_ratio_dof).name},
                                              {"bound", k_rate * model.dof(acc_ratio_dof).max_speed}};
  // Left out where no joint has position limits (every one continuous): a 0 there read as a
  // dof on its limit.
  if (std::isfinite(min_limit))
    out["min_distance_to_limit"] = {{"value", min_limit}, {"dof", model.dof(limit_dof).name}};
  std::vector<double> us(run.cycle_us.begin() + 1, run.cycle_us.end());
  std::sort(us.begin(), us.end());
  if (!us.empty()) {
    double mean = 0.0;
    for (double u : us) mean += u;
    out["cycle_time_us"] = {{"mean", mean / us.size()}, {"median", us[us.size() / 2]},
                            {"p99", us[std::min(us.size() - 1, us.size() * 99 / 100)]}, {"max", us.back()}};
  }
  static const std::vector<std::pair<std::uint32_t, const char*>> kFlags = {
      {kDamped, "damped"}, {kOverdetermined, "overdetermined"}, {kTaskSpeedLimited, "task_speed_limited"},
      {kNullSpaceSpeedScaled, "nullspace_speed_scaled"}, {kNullSpaceJerkLimited, "nullspace_jerk_limited"},
      {kNoActiveRows, "no_active_rows"}, {kAllDofsFrozen, "all_dofs_frozen"}, {kInvalidInput, "invalid_input"},
      {kJointLimitClamped, "joint_limit_clamped"}, {kDofAtLimitFrozen, "dof_at_limit_frozen"}, {kDofBraked, "dof_braked"},
      {kDampingRaised, "damping_raised"}, {kInvalidCommand, "invalid_command"}, {kInvalidTarget, "invalid_target"}};
  json counts = json::object();
  for (const auto& [flag, name] : kFlags) {
    int count = 0;
    for (std::uint32_t f : run.flags) count += (f & flag) ? 1 : 0;
    counts[name] = count;
  }
  out["status_cycles"] = counts;
  // Why a target may be left unmet at the end: the last cycle damped (near a singularity, a
  // target out of reach) and the joints at a position limit (within 1e-6 rad or m).
  json joints_at_limit = json::array();
  for (int i = 0; i < n; ++i) {
    const Dof& d = model.dof(i);
    if (d.continuous || d.role != DofRole::kJoint || K == 0) continue;
    const double q = run.q.back()[i];
    if (q - d.lower < 1e-6) joints_at_limit.push_back({{"dof", d.name}, {"limit", "lower"}});
    else if (d.upper - q < 1e-6) joints_at_limit.push_back({{"dof", d.name}, {"limit", "upper"}});
  }
  out["at_end"] = {{"damped", K > 0 && (run.flags.back() & kDamped) != 0}, {"dofs_at_limit", joints_at_limit}};
  if (!run.walking.empty()) {
    int walks = 0;
    for (size_t k = 1; k < run.walking.size(); ++k) walks += (run.walking[k][3] > 0.0 && run.walking[k - 1][3] == 0.0) ? 1 : 0;
    const Eigen::VectorXd& h = run.walking.back();
    out["walking"] = {{"walks", walks}, {"footsteps", run.footsteps.size()},
                      {"final_real_heel", {h[0], h[1], h[2]}},
                      {"walking_at_end", h[3] > 0.0}};
    const WalkingParameters& p = run.walking_parameters;
    out["walking"]["steps"] = {{"max_step_length", p.max_step_length}, {"min_step_width", p.min_step_width},
                               {"max_step_width", p.max_step_width}, {"step_duration", p.step_duration},
                               {"max_steps", p.max_steps}, {"max_heel_lead", p.max_heel_lead}};
    // What starts a walk, with the tolerances used (the file's, else position_tolerance scaled to
    // the robot): a user whose robot walked, or did not, sees against what.
    out["walking"]["trigger"] = {{"position_tolerance", p.position_tolerance},
                                 {"angle_tolerance", p.angle_tolerance},
                                 {"cost_threshold", p.cost_threshold},
                                 {"stall_time", p.stall_time},
                                 {"on_joint_limit", p.trigger_on_joint_limit}};
    // Walks that max_steps ended, and how far the feet then stand from the body's heel (the
    // heel dofs): a walk that ends so freezes the heel where the body went, and the feet
    // stay behind it.
    int at_step_limit = 0;
    for (const Eigen::VectorXd& w : run.walking) at_step_limit += (static_cast<std::uint32_t>(w[4]) & kStepLimitReached) != 0;
    const VirtualDofs& v = model.virtual_dofs();
    const Eigen::VectorXd& q = run.q.back();
    out["walking"]["walks_at_step_limit"] = at_step_limit;
    out["walking"]["feet_from_body"] = std::hypot(h[0] - q[v.heel_x], h[1] - q[v.heel_y]);
    // How far the body ran ahead of the feet during the walks [m]: the legs must bridge it.
    double lead = 0.0;
    for (size_t k = 0; k < run.walking.size(); ++k)
      if (run.walking[k][3] > 0.0) lead = std::max(lead, body_lead(run, k));
    out["walking"]["max_body_lead"] = lead;
  }
  if (!run.balance.empty()) {
    double min_margin = 1e300;
    for (const Eigen::VectorXd& b : run.balance) min_margin = std::min(min_margin, b[6]);
    out["balance"] = {{"min_com_margin", min_margin}, {"final_com_margin", run.balance.back()[6]},
                      {"on_at_end", run.balance_on_at_end}, {"balanced_cycles", run.balanced_cycles}};
    json at_limit = json::array();
    for (int k = 0; k < 2; ++k) {
      const ScenarioRun::ShiftAtLimit& a = run.shift_at_limit[k];
      if (a.cycles > 0) {
        const std::string dof = k == 0 ? "upper_body_x" : "upper_body_y";
        // A range that reaches the needed shift with a centimetre to spare, on whole centimetres.
        const Dof& d = run.model->dof(run.model->dof_index(dof));
        const bool upper = a.side > 0;
        const double reach = upper ? std::ceil((a.needed + 0.01) * 100.0) / 100.0 : std::floor((a.needed - 0.01) * 100.0) / 100.0;
        std::ostringstream range;
        range << "[" << (upper ? d.lower : reach) << ", " << (upper ? reach : d.upper) << "]";
        std::string remedy = run.scenario.urdf.empty()
                                 ? "the built-in paper model's range is fixed"
                                 : "widen robot." + dof + "_range for these feet, e.g. to " + range.str();
        // Feet left behind by a walk that max_steps ended: no range makes up for that.
        if (out.contains("walking") && out["walking"]["walks_at_step_limit"].get<int>() > 0 &&
            !out["walking"]["walking_at_end"].get<bool>() &&
            out["walking"]["feet_from_body"].get<double>() > run.walking_parameters.feet_tolerance)
          remedy = "a walk ended at max_steps and left the feet behind the body (see walking): raise walking.max_steps";
        at_limit.push_back({{"dof", dof}, {"cycles", a.cycles}, {"limit", upper ? d.upper : d.lower}, {"needed", a.needed},
                            {"remedy", remedy}});
      }
    }
    out["balance"]["shift_at_limit"] = at_limit;
  }
  out["nullspace_cost"] = {{"initial", run.cost.front()}, {"final", run.cost.back()},
                           {"max", *std::max_element(run.cost.begin(), run.cost.end())}};
  return out;
}

std::string describe_shift_at_limit(const json& entry, int balanced_cycles) {
  const int cycles = entry["cycles"].get<int>();
  std::ostringstream line;
  line << std::fixed << std::setprecision(1) << entry["dof"].get<std::string>() << " held at its limit "
       << entry["limit"].get<double>() * 100.0 << " cm in " << cycles << " of " << balanced_cycles
       << " balanced cycles (" << 100.0 * cycles / std::max(balanced_cycles, 1)
       << " %); the centre of mass would have needed " << entry["needed"].get<double>() * 100.0
       << " cm: " << entry["remedy"].get<std::string>();
  return line.str();
}

std::vector<std::string> describe_walking(const json& w) {
  const int walks = w["walks"].get<int>();
  const json& steps = w["steps"];  // the step limits used: the file's, else scaled to the robot
  std::ostringstream line;
  line << std::fixed << std::setprecision(3) << w["footsteps"].get<int>() << " footsteps in " << walks
       << (walks == 1 ? " walk" : " walks") << (w["walking_at_end"].get<bool>() ? ", still walking at the end" : "")
       << " (steps up to " << steps["max_step_length"].get<double>() << " m ahead, "
       << steps["min_step_width"].get<double>() << "-" << steps["max_step_width"].get<double>() << " m wide, every "
       << steps["step_duration"].get<double>() << " s)";
  std::vector<std::string> lines = {line.str()};
  if (walks > 0) {
    const double bound = steps["max_heel_lead"].get<double>();
    std::ostringstream lead;
    lead << std::fixed << std::setprecision(3) << "the body up to " << w["max_body_lead"].get<double>()
         << " m ahead of the feet (the floating heel from the real heel between them; ";
    if (bound > 0.0) lead << std::setprecision(2) << "held beyond " << bound << " steps)";
    else lead << "walking.max_heel_lead can bound it)";
    lines.push_back(lead.str());
  }
  if (const int at_limit = w["walks_at_step_limit"].get<int>(); at_limit > 0) {
    std::ostringstream limit;
    limit << std::fixed << std::setprecision(3) << at_limit << (at_limit == 1 ? " walk" : " walks")
          << " ended at max_steps (" << steps["max_steps"].get<int>() << " footsteps); the feet stand "
          << w["feet_from_body"].get<double>()
          << " m from the body's heel at the end: raise walking.max_steps for walks this long";
    lines.push_back(limit.str());
  }
  return lines;
}

std::string describe_last_cycle(const json& at_end) {
  std::string why = at_end["damped"].get<bool>() ? "damped (near a singularity, or a target out of reach)" : "";
  std::string dofs;
  for (const json& d : at_end["dofs_at_limit"])
    dofs += (dofs.empty() ? "" : ", ") + d["dof"].get<std::string>() + " (" + d["limit"].get<std::string>() + ")";
  if (!dofs.empty()) why += (why.empty() ? "" : "; ") + std::string("at a position limit: ") + dofs;
  return why;
}

namespace {

/// A CSV header field: quoted (RFC 4180, quotes doubled) when the name holds a comma or a
/// quote, as URDF joint names and element names may.
std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

}  // namespace

void write_outputs(const ScenarioRun& run, const std::string& directory, bool report) {
  namespace fs = std::filesystem;
  std::error_code error;
  fs::create_directories(directory, error);
  if (error) throw ConfigError(directory + ": cannot create the output directory (" + error.message() + ")");
  const Scenario& s = run.scenario;
  const Model& model = *run.model;
  const TaskStack& stack = run.controller->tasks();
  std::map<std::string, std::string> files;

  std::ostringstream csv;
  csv << std::setprecision(10) << "time,status";
  for (const Dof& d : model.dofs()) csv << "," << csv_field("q." + d.name);
  for (int i = 0; i < stack.num_elements(); ++i) {
    const std::string& name = stack.element(i).name();
    for (const char* kind : {"target", "filtered", "actual"})
      for (int j = 0; j < stack.element(i).target_dim(); ++j)
        csv << "," << csv_field(name + "." + kind + "." + std::to_string(j));
    csv << "," << csv_field(name + ".active") << "," << csv_field(name + ".error");
  }
  csv << ",nullspace_cost,cycle_us\n";
  for (int k = 0; k < run.num_cycles(); k += s.record_every) {
    csv << run.time[k] << "," << run.flags[k];
    for (int i = 0; i < model.num_dofs(); ++i) csv << "," << run.q[k][i];
    for (int i = 0; i < stack.num_elements(); ++i) {
      const int t0 = stack.target_offset(i), n = stack.element(i).target_dim();
      for (const auto* v : {&run.commanded[k], &run.filtered[k], &run.actual[k]})
        for (int j = 0; j < n; ++j) csv << "," << (*v)[t0 + j];
      csv << "," << run.active[k][i] << "," << run.error[k][i];
    }
    csv << "," << run.cost[k] << "," << run.cycle_us[k] << "\n";
  }
  files["trajectory.csv"] = csv.str();
  files["summary.json"] = summarize(run).dump(2) + "\n";
  if (s.walking.enabled) {
    std::ostringstream steps;
    steps << std::setprecision(10) << "time,foot,x,y,yaw\n";
    for (const Footstep& f : run.footsteps)
      steps << f.time << "," << (f.left ? "L" : "R") << "," << f.pose.position.x() << "," << f.pose.position.y() << ","
            << f.pose.yaw << "\n";
    files["footsteps.csv"] = steps.str();
  }
  if (report) files["report.html"] = render_report(run);
  // Write everything to temporaries first, then rename: a failure leaves no partial output.
  for (const auto& [name, text] : files) {
    std::ofstream out(directory + "/" + name + ".tmp", std::ios::binary);
    out << text;
    if (!out) throw ConfigError(directory + "/" + name + ": cannot write the file");
  }
  for (const auto& [name, text] : files) fs::rename(directory + "/" + name + ".tmp", directory + "/" + name);
}

}  // namespace wbm
