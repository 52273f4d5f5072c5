#include "report_writer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <set>

#include <nlohmann/json.hpp>

#include "leg_poser.hpp"
#include "runner.hpp"
#include "wbm/balance.hpp"
#include "wbm/errors.hpp"

namespace wbm {
namespace {

using nlohmann::json;

constexpr int kMaxSamples = 1500;  // 3D animation and plot samples in the page

json xyz(const Vector3& v) { return json::array({v.x(), v.y(), v.z()}); }

json value_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

/// A link's position coordinate [m] rounded to a micrometre: the 3D view needs no more, and
/// the positions of every link at every sample are most of a report (G1's 48 links: 2.8 of
/// 3.8 MB written with 17 digits, 1.2 MB rounded).
double micrometres(double x) { return std::round(x * 1e6) / 1e6; }  // "/": the double nearest to n um

/// One foot on the ground for the 3D view: its outline from `time` [s] on.
json footprint(double time, bool left, const FootPose& pose, const FootGeometry& feet) {
  const SupportPolygon outline = SupportPolygon::from_feet(std::span(&pose, 1), feet);
  json polygon = json::array();
  for (const Vector2& p : outline.vertices()) polygon.push_back(json::array({p.x(), p.y()}));
  return {{"t", time}, {"side", left ? "L" : "R"}, {"polygon", polygon}};
}

}  // namespace

std::string render_report(const ScenarioRun& run) {
  const Scenario& s = run.scenario;
  const Model& model = *run.model;
  const TaskStack& stack = run.controller->tasks();
  const int K = run.num_cycles();
  const int stride = std::max(1, (K + kMaxSamples - 1) / kMaxSamples);
  std::vector<int> samples;
  for (int k = 0; k < K; k += stride) samples.push_back(k);
  if (samples.back() != K - 1) samples.push_back(K - 1);

  json data;
  data["title"] = "wbm: " + s.name;
  data["subtitle"] = s.description + " (model " + model.name() + ", " + std::to_string(model.num_dofs()) + " dofs)";
  json time = json::array();
  for (int k : samples) time.push_back(run.time[k]);
  data["time"] = time;

  // Robot: the links drawn are the bodies and the welded frames (URDF links folded into a
  // body: locked legs, heads, sensors, hand points), each from the frame it hangs from
  // (Frame::parent) or its body's origin. Node b is body b; the welded frames follow. Also
  // the frames the tasks use and, on small models, every non-body frame, with their axes.
  // Of the virtual chain only the heel (a point on the floor) and the upper body are drawn:
  // its inner bodies lie on the floor and in the air between them, and were drawn as a rod
  // along x on the floor and a pole up to the pelvis. The upper body hangs from the heel by
  // one link where that link stands for the legs (the built-in model; legs dropped), not
  // where the legs are drawn (locked legs, or free leg joints).
  const int nb = model.num_bodies();
  const VirtualDofs& chain = model.virtual_dofs();
  std::vector<bool> hidden(nb, false);
  for (int b = 0; b < nb; ++b) {
    const int dof = model.body(b).dof;
    const DofRole role = dof >= 0 ? model.dof(dof).role : DofRole::kJoint;
    hidden[b] = role != DofRole::kJoint && role != DofRole::kHeelYaw && b != chain.upper_body;
  }
  const bool legs_as_one_link = s.urdf.empty() || s.urdf_options.leg_mode == LegMode::kDrop;
  std::vector<int> node_of_frame(model.num_frames()), welded;
  for (int f = 0; f < model.num_frames(); ++f) {
    const bool own = model.is_body_frame(f);
    node_of_frame[f] = own ? model.frame(f).body : nb + static_cast<int>(welded.size());
    if (!own) welded.push_back(f);
  }
  json bodies = json::array();
  for (int b = 0; b < nb; ++b) {
    const int parent_frame = model.frame(model.frame_index(model.body(b).name)).parent;
    int parent = parent_frame >= 0 ? node_of_frame[parent_frame] : model.body(b).parent;
    if (hidden[b] || (parent >= 0 && parent < nb && hidden[parent])) parent = -1;
    if (b == chain.upper_body && chain.heel_body >= 0) parent = legs_as_one_link ? chain.heel_body : -1;
    bodies.push_back({{"name", model.body(b).name}, {"parent", parent}});
  }
  for (int f : welded) {
    const Frame& frame = model.frame(f);
    bodies.push_back({{"name", frame.name}, {"parent", frame.parent >= 0 ? node_of_frame[frame.parent] : frame.body}});
  }
  std::vector<int> frames;
  std::set<int> used;
  for (const ScenarioTask& t : s.tasks)
    if (!t.frame.empty()) used.insert(model.frame_index(t.frame));
  // On small models every non-body frame but those of locked legs (a 0.26 m robot's ten leg
  // links each had an arrow and a legend entry, no task using them).
  auto in_a_leg = [&](int f) { return leg_of(model, f, s.urdf_options.legs) >= 0; };
  for (int f = 0; f < model.num_frames(); ++f)
    if (used.count(f) || (!model.is_body_frame(f) && model.num_frames() < 40 && !in_a_leg(f)))
      frames.push_back(f);
  // The arrow drawn at each frame: the axis of the first axis task on it, else its z-axis.
  std::vector<Vector3> drawn_axis(frames.size(), Vector3::UnitZ());
  for (auto t = s.tasks.rbegin(); t != s.tasks.rend(); ++t)
    if (t->type == "axis")  // its frame is one of `frames` (the tasks' frames are)
      drawn_axis[std::find(frames.begin(), frames.end(), model.frame_index(t->frame)) - frames.begin()] =
          t->axis.normalized();
  json frame_list = json::array();
  for (int f : frames) frame_list.push_back({{"name", model.frame(f).name}});
  data["robot"] = {{"bodies", bodies}, {"frames", frame_list}};

  // A URDF robot's locked legs are drawn standing on the feet (LegPoser), not rigid under
  // the leaning, shifting, walking upper body as the controller treats them.
  LegPoser legs_poser(s, model, run.feet.spacing);
  std::array<double, 2> leg_miss = {0.0, 0.0};  // the farthest a foot was missed [m], [rad]
  Data d(model);
  json body_pos = json::array(), frame_pos = json::array(), frame_z = json::array(), heel_path = json::array();
  std::vector<json> target_values(stack.num_elements(), json::array());
  for (int k : samples) {
    forward_kinematics(model, d, run.q[k]);
    if (legs_poser.usable()) {
      legs_poser.pose(d, drawn_feet(run, run.time[k]));
      leg_miss = {std::max(leg_miss[0], legs_poser.position_miss()), std::max(leg_miss[1], legs_poser.angle_miss())};
    }
    json bp = json::array(), fp = json::array(), fz = json::array();
    for (int b = 0; b < nb; ++b)
      for (int i = 0; i < 3; ++i) bp.push_back(hidden[b] ? json(nullptr) : json(micrometres(d.X_WB[b].p[i])));
    for (int f : welded) {
      const Vector3 p = legs_poser.leg_frame_position(f).value_or(frame_position(model, d, f));
      for (int i = 0; i < 3; ++i) bp.push_back(micrometres(p[i]));
    }
    for (size_t j = 0; j < frames.size(); ++j) {
      // A task's frame in a locked leg: where the drawn leg puts it (its task error, in
      // the plots, is the controller's, on the locked leg; a task note says so).
      const Transform X = legs_poser.leg_frame_pose(frames[j]).value_or(frame_pose(model, d, frames[j]));
      const Vector3 axis = X.R * drawn_axis[j];
      for (int i = 0; i < 3; ++i) {
        fp.push_back(X.p[i]);
        fz.push_back(axis[i]);
      }
    }
    body_pos.push_back(bp);
    frame_pos.push_back(fp);
    frame_z.push_back(fz);
    if (model.virtual_dofs().heel_body >= 0) heel_path.push_back(xyz(d.X_WB[model.virtual_dofs().heel_body].p));
    for (int e = 0; e < stack.num_elements(); ++e) {
      const ScenarioTask& t = s.tasks[e];
      if (run.active[k][e] == 0.0 || (t.type != "position" && t.type != "axis")) {
        target_values[e].push_back(nullptr);
        continue;
      }
      const Vector3 v = run.commanded[k].segment<3>(stack.target_offset(e));
      Transform X_WR;
      if (!t.reference.empty() && t.reference != "world") X_WR = frame_pose(model, d, model.frame_index(t.reference));
      target_values[e].push_back(xyz(t.type == "position" ? Vector3(X_WR * v) : Vector3(X_WR.R * v.normalized())));
    }
  }
  data["body_pos"] = body_pos;
  data["frame_pos"] = frame_pos;
  data["frame_z"] = frame_z;
  json targets = json::array();
  for (int e = 0; e < stack.num_elements(); ++e) {
    const ScenarioTask& t = s.tasks[e];
    if (t.type != "position" && t.type != "axis") continue;
    const int f = model.frame_index(t.frame);
    const int index = static_cast<int>(std::find(frames.begin(), frames.end(), f) - frames.begin());
    targets.push_back({{"name", t.name + " (" + t.type + ")"}, {"kind", t.type}, {"frame", index}, {"values", target_values[e]}});
  }
  data["targets"] = targets;
  json paths = json::array();
  if (model.virtual_dofs().heel_body >= 0) paths.push_back({{"name", run.walking.empty() ? "heel" : "floating heel"}, {"points", heel_path}});
  if (!run.walking.empty()) {
    json real = json::array();
    for (int k : samples) real.push_back(json::array({run.walking[k][0], run.walking[k][1], 0.0}));
    paths.push_back({{"name", "real heel (between the feet)"}, {"points", real}});
    // The feet standing at the start (beside the real heel of the first cycle), then each
    // footstep as it lands: without the first two, no feet were drawn until the first step.
    json prints = json::array();
    const DrawnFeet start = drawn_feet(run, run.time.front());
    for (const int side : {0, 1}) prints.push_back(footprint(run.time.front(), side == 0, start.pose[side], run.feet));
    for (const Footstep& f : run.footsteps) prints.push_back(footprint(f.time, f.left, f.pose, run.feet));
    data["footprints"] = prints;
  }
  if (!run.balance.empty()) {
    // Balance: the centre of mass on the ground, and (standing) the feet it is kept over.
    json com = json::array();
    for (int k : samples) com.push_back(json::array({run.balance[k][0], run.balance[k][1], 0.0}));
    paths.push_back({{"name", "centre of mass (on the ground)"}, {"points", com}});
    if (run.walking.empty()) {
      const DrawnFeet start = drawn_feet(run, run.time.front());
      json prints = json::array();
      for (const int side : {0, 1}) prints.push_back(footprint(run.time.front(), side == 0, start.pose[side], run.feet));
      data["footprints"] = prints;
    }
  }
  data["paths"] = paths;

  auto series = [&](const std::string& label, auto&& value) {
    json values = json::array();
    for (int k : samples) values.push_back(value_or_null(value(k)));
    return json{{"label", label}, {"values", values}};
  };
  json plots = json::array();
  json joints = json::array(), virtual_dofs = json::array();
  bool prismatic_joints = false;  // e.g. a torso lift: "Joint positions", rad and m
  for (int i = 0; i < model.num_dofs(); ++i) {
    json sr = series(model.dof(i).name, [&](int k) { return run.q[k][i]; });
    const bool joint = model.dof(i).role == DofRole::kJoint;
    prismatic_joints = prismatic_joints || (joint && model.dof(i).type == JointType::kPrismatic);
    (joint ? joints : virtual_dofs).push_back(sr);
  }
  plots.push_back({{"title", prismatic_joints ? "Joint positions" : "Joint angles"},
                   {"unit", prismatic_joints ? "rad, m" : "rad"},
                   {"series", joints}});
  if (!virtual_dofs.empty()) plots.push_back({{"title", "Heel and upper-body dofs"}, {"unit", "m, rad"}, {"series", virtual_dofs}});
  // Task errors, one plot per unit in the order the units first appear: on one axis, a grasp
  // axis's 19 degrees were invisible beside a hand's 1,034 mm.
  std::vector<std::pair<std::string, json>> errors;  // unit, series
  bool any_active = false;  // a scenario that never switches an element on has no errors to plot
  for (int k : samples)
    for (int e = 0; e < stack.num_elements(); ++e) any_active = any_active || run.active[k][e] > 0.0;
  for (int e = 0; e < stack.num_elements() && any_active; ++e) {
    const double scale = error_scale(s.tasks[e]);
    const std::string unit = error_unit(s.tasks[e], stack.element(e));
    auto group = std::find_if(errors.begin(), errors.end(), [&](const auto& g) { return g.first == unit; });
    if (group == errors.end()) group = errors.insert(errors.end(), {unit, json::array()});
    group->second.push_back(series(s.tasks[e].name + " [" + unit + "]", [&](int k) {
      return run.active[k][e] > 0.0 ? scale * run.error[k][e] : std::nan("");
    }));
  }
  for (const auto& [unit, group] : errors)
    plots.push_back({{"title", "Task errors to the commanded targets" +
                                   (errors.size() > 1 ? " [" + unit + "]" : std::string()) + " (inactive: gap)"},
                     {"unit", unit},
                     {"series", group}});
  plots.push_back({{"title", "Null-space cost H(q)"},
                   {"unit", ""},
                   {"series", json::array({series("H", [&](int k) { return run.cost[k]; })})}});
  json cond = json::array();
  for (int e = 0; e < stack.num_elements(); ++e) {
    if (s.tasks[e].type != "position") continue;
    const int f = model.frame_index(s.tasks[e].frame);
    json whole = json::array(), limb = json::array();
    for (int k : samples) {
      forward_kinematics(model, d, run.q[k]);
      whole.push_back(value_or_null(position_condition_number(model, d, f, false)));
      limb.push_back(value_or_null(position_condition_number(model, d, f, true)));
    }
    cond.push_back({{"label", s.tasks[e].name + " whole body"}, {"values", whole}});
    cond.push_back({{"label", s.tasks[e].name + " joints only"}, {"values", limb}});
  }
  if (!cond.empty())
    plots.push_back({{"title", "Condition number of the weighted position Jacobian (rank below 3: gap)"},
                     {"unit", ""},
                     {"series", cond}});
  if (!run.walking.empty()) {
    plots.push_back({{"title", "Walking: floating heel (solver) and real heel (feet)"},
                     {"unit", "m, rad"},
                     {"series", json::array({series("floating heel x", [&](int k) { return run.q[k][model.virtual_dofs().heel_x]; }),
                                             series("floating heel y", [&](int k) { return run.q[k][model.virtual_dofs().heel_y]; }),
                                             series("floating heel yaw", [&](int k) { return run.q[k][model.virtual_dofs().heel_yaw]; }),
                                             series("real heel x", [&](int k) { return run.walking[k][0]; }),
                                             series("real heel y", [&](int k) { return run.walking[k][1]; }),
                                             series("real heel yaw", [&](int k) { return run.walking[k][2]; }),
                                             series("walking", [&](int k) { return run.walking[k][3]; }),
                                             // How far the body is ahead of the feet, and
                                             // when the walk held it (max_heel_lead).
                                             series("body ahead of the feet", [&](int k) {
                                               return body_lead(run, static_cast<size_t>(k));
                                             }),
                                             series("heel held", [&](int k) {
                                               return (static_cast<std::uint32_t>(run.walking[k][4]) & kHeelHeld) != 0 ? 1.0 : 0.0;
                                             })})}});
  }
  if (!run.balance.empty()) {
    plots.push_back({{"title", "Balance: centre of mass and support centre (world x, y)"},
                     {"unit", "m"},
                     {"series", json::array({series("com x", [&](int k) { return run.balance[k][0]; }),
                                             series("com y", [&](int k) { return run.balance[k][1]; }),
                                             series("support centre x", [&](int k) { return run.balance[k][2]; }),
                                             series("support centre y", [&](int k) { return run.balance[k][3]; }),
                                             series("com margin", [&](int k) { return run.balance[k][6]; })})}});
  }
  data["plots"] = plots;

  const json summary = summarize(run);
  json table = json::array();
  for (const auto& [name, e] : summary["elements"].items()) {
    char text[160];
    const std::string unit = e["unit"].get<std::string>();
    if (e["final_error"].is_null())
      std::snprintf(text, sizeof text, "inactive at the end; max tracking %.3g %s", e["max_tracking_error"].get<double>(), unit.c_str());
    else
      std::snprintf(text, sizeof text, "final %.3g %s, max tracking %.3g %s", e["final_error"].get<double>(), unit.c_str(),
                    e["max_tracking_error"].get<double>(), unit.c_str());
    table.push_back({name, text});
  }
  auto number = [](double value, const char* unit = "") {  // three digits, not to_string's six decimals
    char text[64];
    std::snprintf(text, sizeof text, std::abs(value) >= 100.0 ? "%.0f%s" : "%.3g%s", value, unit);
    return std::string(text);
  };
  table.push_back({"max joint speed / limit", number(summary["max_joint_speed"]["ratio_to_limit"].get<double>()) + " (" +
                                                  summary["max_joint_speed"]["dof"].get<std::string>() + ")"});
  if (summary.contains("max_joint_acceleration_to_bound"))
    table.push_back({"max joint acceleration / bound k v_max",
                     number(summary["max_joint_acceleration_to_bound"]["ratio"].get<double>()) + " (" +
                         summary["max_joint_acceleration_to_bound"]["dof"].get<std::string>() + ")"});
  if (summary.contains("min_distance_to_limit")) {
    const std::string dof = summary["min_distance_to_limit"]["dof"];
    const bool prismatic = model.dof(model.dof_index(dof)).type == JointType::kPrismatic;
    table.push_back({"min distance to a joint limit",
                     number(summary["min_distance_to_limit"]["value"].get<double>(), prismatic ? " m" : " rad") + " (" +
                         dof + ")"});
  } else {
    table.push_back({"min distance to a joint limit", "none: no joint has position limits"});
  }
  if (const std::string held = describe_last_cycle(summary["at_end"]); !held.empty())
    table.push_back({"last cycle", held});
  if (summary.contains("balance")) {
    const json& b = summary["balance"];
    char text[160];
    std::snprintf(text, sizeof text, "%.1f / %.1f cm (negative: outside)%s", b["min_com_margin"].get<double>() * 100.0,
                  b["final_com_margin"].get<double>() * 100.0, b["on_at_end"].get<bool>() ? "" : "; balance off at the end");
    table.push_back({"centre of mass inside the feet, least / at the end", text});
    for (const json& a : b["shift_at_limit"])
      table.push_back({"balance: upper-body shift at its limit", describe_shift_at_limit(a, b["balanced_cycles"].get<int>())});
  }
  if (summary.contains("walking"))
    for (const std::string& line : describe_walking(summary["walking"])) table.push_back({"walking", line});
  if (legs_poser.usable()) {
    // Below a micrometre and 0.01 deg: on the feet (the solve stops at 0.1 um).
    const bool on_feet = leg_miss[0] < 1e-6 && leg_miss[1] < 1e-4;
    table.push_back({"legs (3D view only)",
                     "drawn standing on the feet by inverse kinematics; the controller keeps them locked; " +
                         (on_feet ? std::string("every foot reached")
                                  : "farthest from a foot " + number(leg_miss[0] * 1000.0, " mm") + ", turned from it " +
                                        number(leg_miss[1] * 180.0 / std::numbers::pi, " deg") +
                                        " (out of the legs' reach: beyond their length or joint limits, or a turn "
                                        "coupled hip joints cannot take; drawn as near as they get)")});
  }
  for (const json& note : summary["model_notes"]) table.push_back({"note on the model", note});
  for (const json& note : summary["task_notes"]) table.push_back({"note on a task", note});
  if (summary.contains("cycle_time_us"))
    table.push_back({"cycle time median / p99 [us]", number(summary["cycle_time_us"]["median"].get<double>()) + " / " +
                                                         number(summary["cycle_time_us"]["p99"].get<double>())});
  data["summary"] = table;

  std::string text = data.dump();
  std::string escaped;
  escaped.reserve(text.size());
  for (char ch : text) {
    if (ch == '<') escaped += "\\u003c";
    else escaped += ch;
  }
  std::string page = report_template();
  const std::string placeholder = "__WBM_REPORT_DATA__";
  const size_t at = page.find(placeholder);
  if (at == std::string::npos) throw ConfigError("report template has no data placeholder");
  page.replace(at, placeholder.size(), escaped);
  return page;
}

}  // namespace wbm
