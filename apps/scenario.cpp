#include "scenario.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "wbm/errors.hpp"

namespace wbm {
namespace {

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& field, const std::string& message) const {
    const int line = node.Mark().line >= 0 ? node.Mark().line + 1 : 0;
    throw ConfigError(source_ + ":" + std::to_string(line) + ": " + field + ": " + message);
  }
  int line(const YAML::Node& node) const { return node.Mark().line + 1; }

  double number(const YAML::Node& node, const std::string& field) const {
    if (!node.IsScalar()) fail(node, field, "expected a number");
    try {
      const double v = node.as<double>();
      if (!std::isfinite(v)) fail(node, field, "expected a finite number, got '" + node.Scalar() + "'");
      return v;
    } catch (const YAML::Exception&) {
      fail(node, field, "expected a number, got '" + node.Scalar() + "'");
    }
  }
  double positive(const YAML::Node& node, const std::string& field) const {
    const double v = number(node, field);
    if (v <= 0.0) fail(node, field, "expected a number > 0");
    return v;
  }
  double non_negative(const YAML::Node& node, const std::string& field) const {
    const double v = number(node, field);
    if (v < 0.0) fail(node, field, "expected a number >= 0");
    return v;
  }
  std::string text(const YAML::Node& node, const std::string& field) const {
    if (!node.IsScalar()) fail(node, field, "expected a string");
    return node.Scalar();
  }
  /// A name that appears in messages, CSV headers and (for the scenario) a directory: not
  /// empty, no control characters; `as_directory` also rules out '/', '\', "." and "..".
  std::string name(const YAML::Node& node, const std::string& field, bool as_directory) const {
    const std::string value = text(node, field);
    const bool control = std::any_of(value.begin(), value.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20; });
    if (value.empty() || control) fail(node, field, "expected a non-empty name without control characters");
    if (as_directory && (value == "." || value == ".." || value.find_first_of("/\\") != std::string::npos))
      fail(node, field, "'" + value + "' cannot name the output directory (expected no '/' or '\\', not '.' or '..')");
    if (as_directory && value.size() > kMaxFileNameBytes)
      fail(node, field, "a name of " + std::to_string(value.size()) + " bytes cannot name the output directory (at most " +
                            std::to_string(kMaxFileNameBytes) + ")");
    return value;
  }
  bool boolean(const YAML::Node& node, const std::string& field) const {
    try {
      return node.as<bool>();
    } catch (const YAML::Exception&) {
      fail(node, field, "expected true or false");
    }
  }
  std::vector<std::string> strings(const YAML::Node& node, const std::string& field) const {
    std::vector<std::string> out;
    if (node.IsScalar()) return {node.Scalar()};
    if (!node.IsSequence()) fail(node, field, "expected a list of names");
    for (size_t i = 0; i < node.size(); ++i) out.push_back(text(node[i], field + "[" + std::to_string(i) + "]"));
    return out;
  }
  Eigen::VectorXd vector(const YAML::Node& node, const std::string& field) const {
    if (node.IsScalar()) return Eigen::VectorXd::Constant(1, number(node, field));
    if (!node.IsSequence() || node.size() == 0) fail(node, field, "expected a list of numbers");
    Eigen::VectorXd v(node.size());
    for (size_t i = 0; i < node.size(); ++i) v[i] = number(node[i], field + "[" + std::to_string(i) + "]");
    return v;
  }
  void only(const YAML::Node& map, const std::string& field, const std::set<std::string>& keys) const {
    if (!map.IsMap()) fail(map, field, "expected a mapping");
    for (const auto& kv : map) {
      const std::string key = kv.first.Scalar();
      if (!keys.count(key)) {
        std::string list;
        for (const std::string& k : keys) list += (list.empty() ? "" : ", ") + k;
        fail(kv.first, field.empty() ? key : field + "." + key, "unknown field (expected one of: " + list + ")");
      }
    }
  }

 private:
  std::string source_;
};

FilterParameters read_filter(const Reader& r, const YAML::Node& node, const std::string& field, FilterParameters f) {
  r.only(node, field, {"bandwidth", "max_speed", "order"});
  if (node["bandwidth"]) {
    f.bandwidth = r.number(node["bandwidth"], field + ".bandwidth");
    if (f.bandwidth < TrajectoryFilter::kMinBandwidth)
      r.fail(node["bandwidth"], field + ".bandwidth",
             "expected a number >= 0.001 [1/s] (a time constant of at most 1000 s)");
  }
  if (node["max_speed"]) f.max_speed = r.positive(node["max_speed"], field + ".max_speed");
  if (node["order"]) {
    const double order = r.number(node["order"], field + ".order");
    if (order != std::floor(order) || order < 2 || order > 6) r.fail(node["order"], field + ".order", "expected an integer in [2, 6]");
    f.order = static_cast<int>(order);
  }
  return f;
}

std::vector<std::pair<std::string, Eigen::VectorXd>> read_targets(const Reader& r, const YAML::Node& node,
                                                                   const std::string& field, std::vector<int>& lines) {
  if (!node.IsMap()) r.fail(node, field, "expected a mapping element: [values]");
  std::vector<std::pair<std::string, Eigen::VectorXd>> out;
  for (const auto& kv : node) {
    out.emplace_back(kv.first.Scalar(), r.vector(kv.second, field + "." + kv.first.Scalar()));
    lines.push_back(r.line(kv.first));
  }
  return out;
}

std::vector<RowSelection> read_rows(const Reader& r, const YAML::Node& node, const std::string& field) {
  std::vector<RowSelection> out;
  const std::vector<std::string> names = r.strings(node, field);
  for (const std::string& n : names) out.push_back({n, r.line(node), field});
  return out;
}

}  // namespace

int scenario_cycles(double duration, double dt) {
  const double cycles = dt > 0.0 ? std::round(duration / dt) : 0.0;
  return cycles >= 1.0 && cycles <= kMaxScenarioCycles ? static_cast<int>(cycles) : 0;
}

Scenario load_scenario(const std::string& path) {
  std::error_code error;  // an ifstream opens a directory, which then reads as an empty document
  if (std::filesystem::is_directory(path, error)) throw ConfigError(path + ": is a directory, not a scenario file");
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the scenario file");
  std::stringstream text;
  text << in.rdbuf();
  const size_t slash = path.find_last_of('/');
  return parse_scenario(text.str(), path, slash == std::string::npos ? "." : path.substr(0, slash));
}

Scenario parse_scenario(const std::string& yaml, const std::string& source, const std::string& base_dir) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(source + ":" + std::to_string(e.mark.line + 1) + ": malformed YAML: " + e.msg);
  }
  const Reader r(source);
  Scenario s;
  s.source = source;
  if (!root.IsMap()) throw ConfigError(source + ":1: expected a mapping with name, robot, tasks, timeline, ...");
  r.only(root, "", {"name", "description", "robot", "dt", "duration", "record_every", "solver", "criterion", "initial",
                    "frozen", "tasks", "timeline", "balance", "walking", "feet"});
  if (!root["name"]) throw ConfigError(source + ":1: name: missing (expected a scenario name)");
  s.name = r.name(root["name"], "name", true);
  s.name_line = r.line(root["name"]);
  if (root["description"]) s.description = r.text(root["description"], "description");
  if (const YAML::Node robot = root["robot"]) {
    r.only(robot, "robot", {"builtin", "urdf", "root", "legs", "drop_legs", "root_height", "root_rpy", "default_limits",
                            "upper_body_x_range", "upper_body_y_range", "upper_body_pivot", "ignore_xacro_elements",
                            "fixed_base", "add_frames"});
    s.robot_line = r.line(robot);
    if (robot["builtin"] && r.text(robot["builtin"], "robot.builtin") != "paper")
      r.fail(robot["builtin"], "robot.builtin", "expected 'paper' (the only built-in model)");
    if (robot["urdf"]) {
      if (robot["builtin"]) r.fail(robot["builtin"], "robot.builtin", "robot.urdf names the robot; give one of the two");
      s.urdf = r.text(robot["urdf"], "robot.urdf");
      if (!s.urdf.empty() && s.urdf[0] != '/') s.urdf = base_dir + "/" + s.urdf;
    } else {  // the import options would be ignored without a word
      for (const char* option : {"root", "legs", "drop_legs", "root_height", "root_rpy", "default_limits",
                                 "upper_body_x_range", "upper_body_y_range", "upper_body_pivot", "ignore_xacro_elements",
                                 "add_frames"})
        if (robot[option])
          r.fail(robot[option], std::string("robot.") + option,
                 "an option of the URDF import; the built-in paper model takes none (add robot.urdf)");
    }
    if (robot["root"]) s.urdf_options.root = r.text(robot["root"], "robot.root");
    if (robot["legs"]) s.urdf_options.legs = r.strings(robot["legs"], "robot.legs");
    if (robot["drop_legs"] && r.boolean(robot["drop_legs"], "robot.drop_legs")) s.urdf_options.leg_mode = LegMode::kDrop;
    // >= 0 here (0: a robot without legs on the ground); the import refuses 0 with legs.
    if (robot["root_height"]) s.urdf_options.root_height = r.non_negative(robot["root_height"], "robot.root_height");
    if (robot["upper_body_pivot"])
      s.urdf_options.upper_body_pivot = r.non_negative(robot["upper_body_pivot"], "robot.upper_body_pivot");
    if (robot["root_rpy"]) {
      // The shape and range here, at the option's line (load_urdf checks the range too).
      const Eigen::VectorXd rpy = r.vector(robot["root_rpy"], "robot.root_rpy");
      if (rpy.size() != 3) r.fail(robot["root_rpy"], "robot.root_rpy", "expected [roll, pitch, yaw] in rad");
      if (!(rpy.array().abs() <= 2.0 * M_PI).all()) {
        std::ostringstream msg;
        msg << "expected [roll, pitch, yaw] in rad, each within [-2 pi, 2 pi] (degrees?), got " << rpy[0] << ", "
            << rpy[1] << ", " << rpy[2];
        r.fail(robot["root_rpy"], "robot.root_rpy", msg.str());
      }
      s.urdf_options.root_rpy = rpy;
    }
    auto range = [&](const char* option, std::array<double, 2>& out) {
      const YAML::Node node = robot[option];
      if (!node) return;
      const std::string field = std::string("robot.") + option;
      const Eigen::VectorXd v = r.vector(node, field);
      if (v.size() != 2 || !(v.array().abs() <= kMaxLength).all() || !(v[0] < v[1]))
        r.fail(node, field, "expected [lower, upper] in m, finite, lower < upper");
      out = {v[0], v[1]};
    };
    range("upper_body_x_range", s.urdf_options.upper_body_x_range);
    range("upper_body_y_range", s.urdf_options.upper_body_y_range);
    if (robot["default_limits"]) s.urdf_options.default_limits = r.boolean(robot["default_limits"], "robot.default_limits");
    if (robot["ignore_xacro_elements"])
      s.urdf_options.ignore_xacro_elements = r.boolean(robot["ignore_xacro_elements"], "robot.ignore_xacro_elements");
    if (robot["fixed_base"]) s.fixed_base = r.boolean(robot["fixed_base"], "robot.fixed_base");
    if (const YAML::Node frames = robot["add_frames"]) {  // AddedFrame: hand points where the URDF has no link
      if (!frames.IsSequence()) r.fail(frames, "robot.add_frames", "expected a list of {name, parent, xyz, rpy}");
      for (size_t i = 0; i < frames.size(); ++i) {
        const YAML::Node f = frames[i];
        const std::string field = "robot.add_frames[" + std::to_string(i) + "]";
        r.only(f, field, {"name", "parent", "xyz", "rpy"});
        AddedFrame added;
        if (!f["name"] || !f["parent"]) r.fail(f, field, "expected name and parent (a frame of the robot)");
        added.name = r.text(f["name"], field + ".name");
        added.parent = r.text(f["parent"], field + ".parent");
        for (const auto& [key, out] : {std::pair{"xyz", &added.xyz}, std::pair{"rpy", &added.rpy}}) {
          if (!f[key]) continue;
          const Eigen::VectorXd v = r.vector(f[key], field + "." + key);
          if (v.size() != 3 || !(v.array().abs() <= kMaxLength).all())
            r.fail(f[key], field + "." + key,
                   std::string(key) == "xyz" ? "expected [x, y, z] in m, finite" : "expected [roll, pitch, yaw] in rad, finite");
          *out = v;
        }
        s.urdf_options.added_frames.push_back(added);
      }
    }
  }
  // A fixed base keeps the nine virtual dofs frozen; balance shifts the upper body and
  // walking moves the heel, both through those dofs.
  auto no_fixed_base = [&](const YAML::Node& node, const std::string& field, const char* what) {
    if (s.fixed_base)
      r.fail(node, field, std::string(what) + " moves the virtual dofs, which robot.fixed_base keeps frozen");
  };
  if (root["dt"]) s.dt = r.positive(root["dt"], "dt");
  if (root["duration"]) s.duration = r.positive(root["duration"], "duration");
  // The run keeps every cycle in memory (about 1 KB each on the paper model).
  const int cycles = scenario_cycles(s.duration, s.dt);
  if (cycles == 0) {
    std::ostringstream msg;
    msg << "duration / dt = " << s.duration << " s / " << s.dt << " s = " << s.duration / s.dt
        << " cycles; a scenario runs 1 to " << kMaxScenarioCycles << " cycles";
    r.fail(root["duration"] ? root["duration"] : root["dt"] ? root["dt"] : root, "duration", msg.str());
  }
  s.record_every = std::max(1, static_cast<int>(std::lround(0.01 / s.dt)));
  if (root["record_every"]) {
    const double every = r.number(root["record_every"], "record_every");
    if (!(every >= 1 && every <= kMaxScenarioCycles && every == std::floor(every)))
      r.fail(root["record_every"], "record_every", "expected a whole number of cycles >= 1");
    s.record_every = static_cast<int>(every);
  }
  if (const YAML::Node solver = root["solver"]) {
    r.only(solver, "solver", {"nullspace_gain", "singular_threshold", "max_damping", "jerk_limit", "limit_speeds"});
    if (solver["nullspace_gain"]) s.solver.nullspace_gain = r.number(solver["nullspace_gain"], "solver.nullspace_gain");
    if (solver["singular_threshold"]) s.solver.singular_threshold = r.positive(solver["singular_threshold"], "solver.singular_threshold");
    if (solver["max_damping"]) s.solver.max_damping = r.positive(solver["max_damping"], "solver.max_damping");
    if (solver["jerk_limit"]) s.solver.nullspace_rate_change_limit = r.number(solver["jerk_limit"], "solver.jerk_limit");
    if (solver["limit_speeds"]) s.solver.limit_speeds = r.boolean(solver["limit_speeds"], "solver.limit_speeds");
    if (s.solver.nullspace_gain < 0.0) r.fail(solver["nullspace_gain"], "solver.nullspace_gain", "expected a number >= 0");
    if (s.solver.nullspace_rate_change_limit < 0.0) r.fail(solver["jerk_limit"], "solver.jerk_limit", "expected a number >= 0 (0 = off)");
  }
  if (const YAML::Node criterion = root["criterion"]) {
    r.only(criterion, "criterion", {"type", "band"});
    if (criterion["type"]) s.criterion = r.text(criterion["type"], "criterion.type");
    if (s.criterion != "cubic" && s.criterion != "squared")
      r.fail(criterion["type"], "criterion.type", "expected 'cubic' or 'squared'");
    if (criterion["band"]) s.criterion_band = r.number(criterion["band"], "criterion.band");
    if (!(s.criterion_band >= 0.0 && s.criterion_band < 1.0)) r.fail(criterion["band"], "criterion.band", "expected a number in [0, 1)");
  }
  if (const YAML::Node initial = root["initial"]) {
    if (!initial.IsMap()) r.fail(initial, "initial", "expected a mapping dof: value");
    for (const auto& kv : initial) s.initial.emplace_back(kv.first.Scalar(), r.number(kv.second, "initial." + kv.first.Scalar()));
    s.initial_line = r.line(initial);
  }
  if (root["frozen"]) {
    s.frozen = r.strings(root["frozen"], "frozen");
    s.frozen_line = r.line(root["frozen"]);
  }
  if (const YAML::Node balance = root["balance"]) {
    r.only(balance, "balance", {"enabled", "compensate", "gain", "margin"});
    s.balance.configured = true;
    if (balance["enabled"]) s.balance.enabled = r.boolean(balance["enabled"], "balance.enabled");
    if (s.balance.enabled) no_fixed_base(balance["enabled"], "balance.enabled", "balance");
    if (balance["compensate"]) s.balance.compensate = r.boolean(balance["compensate"], "balance.compensate");
    if (balance["gain"]) s.balance.gain = r.positive(balance["gain"], "balance.gain");
    if (balance["margin"]) s.balance.margin = r.number(balance["margin"], "balance.margin");
  }
  if (const YAML::Node feet = root["feet"]) {
    r.only(feet, "feet", {"length", "width", "spacing", "left_frame", "right_frame"});
    FootGeometry& g = s.feet.geometry;
    s.feet.line = r.line(feet);
    if (feet["length"]) g.length = r.positive(feet["length"], "feet.length");
    if (feet["width"]) g.width = r.positive(feet["width"], "feet.width");
    if (feet["spacing"]) g.spacing = r.positive(feet["spacing"], "feet.spacing");
    if (feet["left_frame"]) s.feet.left_frame = r.text(feet["left_frame"], "feet.left_frame");
    if (feet["right_frame"]) s.feet.right_frame = r.text(feet["right_frame"], "feet.right_frame");
    if (s.feet.left_frame.empty() != s.feet.right_frame.empty())
      r.fail(feet, "feet", "give both left_frame and right_frame, or neither");
    if (feet["spacing"] && !s.feet.left_frame.empty())
      r.fail(feet, "feet", "give the spacing or the foot frames to measure it from, not both");
  }
  if (const YAML::Node walking = root["walking"]) {
    WalkingParameters& w = s.walking.parameters;
    s.walking.line = r.line(walking);
    if (walking["error_tolerance"])  // one number for metres and radians before 2026-12-03
      r.fail(walking["error_tolerance"], "walking.error_tolerance",
             "replaced by position_tolerance [m] (scaled to the robot's height unless given) and angle_tolerance [rad]");
    r.only(walking, "walking", {"enabled", "trigger_on_joint_limit", "cost_threshold", "stall_time", "position_tolerance",
                                "angle_tolerance", "trigger_time",
                                "max_step_length", "max_step_width", "min_step_width", "max_step_turn", "step_duration",
                                "converged_speed", "converge_time", "feet_tolerance", "max_steps", "max_walks",
                                "heel_stop_time", "max_heel_lead"});
    if (walking["enabled"]) s.walking.enabled = r.boolean(walking["enabled"], "walking.enabled");
    if (s.walking.enabled) no_fixed_base(walking["enabled"], "walking.enabled", "walking");
    if (walking["trigger_on_joint_limit"]) w.trigger_on_joint_limit = r.boolean(walking["trigger_on_joint_limit"], "walking.trigger_on_joint_limit");
    const std::vector<std::pair<const char*, double*>> numbers = {
        {"cost_threshold", &w.cost_threshold}, {"stall_time", &w.stall_time}, {"trigger_time", &w.trigger_time},
        {"max_step_length", &w.max_step_length}, {"max_step_width", &w.max_step_width},
        {"min_step_width", &w.min_step_width}, {"max_step_turn", &w.max_step_turn}, {"step_duration", &w.step_duration},
        {"converged_speed", &w.converged_speed}, {"converge_time", &w.converge_time}, {"feet_tolerance", &w.feet_tolerance},
        {"heel_stop_time", &w.heel_stop_time}, {"max_heel_lead", &w.max_heel_lead}};
    for (const auto& [key, slot] : numbers)
      if (walking[key]) *slot = r.number(walking[key], std::string("walking.") + key);
    if (walking["position_tolerance"])
      w.position_tolerance = r.positive(walking["position_tolerance"], "walking.position_tolerance");
    if (walking["angle_tolerance"]) w.angle_tolerance = r.positive(walking["angle_tolerance"], "walking.angle_tolerance");
    s.walking.tolerance_given = static_cast<bool>(walking["position_tolerance"]);
    s.walking.min_width_given = static_cast<bool>(walking["min_step_width"]);
    s.walking.max_width_given = static_cast<bool>(walking["max_step_width"]);
    s.walking.length_given = static_cast<bool>(walking["max_step_length"]);
    s.walking.duration_given = static_cast<bool>(walking["step_duration"]);
    if (walking["max_steps"]) w.max_steps = static_cast<int>(r.positive(walking["max_steps"], "walking.max_steps"));
    if (walking["max_walks"]) w.max_walks = static_cast<int>(r.positive(walking["max_walks"], "walking.max_walks"));
  }
  const YAML::Node tasks = root["tasks"];
  if (!tasks || !tasks.IsSequence() || tasks.size() == 0)
    r.fail(tasks ? tasks : root, "tasks", "expected a non-empty list of task elements");
  std::set<std::string> names;
  for (size_t i = 0; i < tasks.size(); ++i) {
    const YAML::Node t = tasks[i];
    const std::string field = "tasks[" + std::to_string(i) + "]";
    r.only(t, field, {"name", "type", "frame", "reference", "axis", "dofs", "gain", "filter", "active"});
    ScenarioTask task;
    task.line = r.line(t);
    if (!t["name"]) r.fail(t, field + ".name", "missing");
    if (!t["type"]) r.fail(t, field + ".type", "missing (expected position, axis, attitude, com or joints)");
    task.name = r.name(t["name"], field + ".name", false);
    if (!names.insert(task.name).second) r.fail(t["name"], field + ".name", "duplicate element name '" + task.name + "'");
    task.type = r.text(t["type"], field + ".type");
    static const std::set<std::string> kTypes = {"position", "axis", "attitude", "com", "joints"};
    if (!kTypes.count(task.type))
      r.fail(t["type"], field + ".type", "unknown type '" + task.type + "' (expected position, axis, attitude, com or joints)");
    const bool needs_frame = task.type == "position" || task.type == "axis" || task.type == "attitude";
    if (needs_frame && !t["frame"]) r.fail(t, field + ".frame", "missing (the frame this " + task.type + " task moves)");
    if (t["frame"]) task.frame = r.text(t["frame"], field + ".frame");
    if (t["reference"]) task.reference = r.text(t["reference"], field + ".reference");
    if (t["axis"]) {
      if (task.type != "axis") r.fail(t["axis"], field + ".axis", "only for axis tasks (the axis in their frame)");
      // The shape here; a zero axis is AxisTask's error (named with this task's line).
      const Eigen::VectorXd axis = r.vector(t["axis"], field + ".axis");
      if (axis.size() != 3) r.fail(t["axis"], field + ".axis", "expected a direction [x, y, z] in the frame");
      task.axis = axis;
    }
    if (task.type == "joints") {
      if (!t["dofs"]) r.fail(t, field + ".dofs", "missing (the dofs of this joints task)");
      task.dofs = r.strings(t["dofs"], field + ".dofs");
    }
    if (t["gain"]) {
      task.gain = r.number(t["gain"], field + ".gain");
      if (task.gain < 0.0) r.fail(t["gain"], field + ".gain", "expected a number >= 0 [1/s]");
    }
    FilterParameters defaults;
    if (task.type == "axis" || task.type == "attitude") defaults.max_speed = 1.0;
    task.filter = t["filter"] ? read_filter(r, t["filter"], field + ".filter", defaults) : defaults;
    if (t["active"]) task.active = r.boolean(t["active"], field + ".active");
    s.tasks.push_back(task);
  }
  if (const YAML::Node timeline = root["timeline"]) {
    if (!timeline.IsSequence()) r.fail(timeline, "timeline", "expected a list of events");
    for (size_t i = 0; i < timeline.size(); ++i) {
      const YAML::Node e = timeline[i];
      const std::string field = "timeline[" + std::to_string(i) + "]";
      r.only(e, field, {"t", "targets", "relative_targets", "activate", "deactivate", "freeze", "release", "balance"});
      ScenarioEvent ev;
      ev.line = r.line(e);
      if (!e["t"]) r.fail(e, field + ".t", "missing (the event time in seconds)");
      ev.time = r.number(e["t"], field + ".t");
      if (ev.time < 0.0) r.fail(e["t"], field + ".t", "expected a time >= 0 s");
      const double last_start = (cycles - 1) * s.dt;  // events apply at the start of a cycle
      if (ev.time > last_start + 1e-12) {
        std::ostringstream msg;
        msg << ev.time << " s is after the start of the scenario's last cycle (" << last_start
            << " s; duration " << s.duration << " s): the event would never happen";
        r.fail(e["t"], field + ".t", msg.str());
      }
      if (!s.events.empty() && ev.time < s.events.back().time) {  // a typo more often than a wish
        std::ostringstream msg;
        msg << ev.time << " s is before the previous event's " << s.events.back().time << " s ("
            << s.events.back().field << ", line " << s.events.back().line
            << "): list the events in the order of their times (events at the same time apply in the file's order)";
        r.fail(e["t"], field + ".t", msg.str());
      }
      ev.field = field;
      if (e["targets"]) ev.targets = read_targets(r, e["targets"], field + ".targets", ev.target_lines);
      if (e["relative_targets"])
        ev.relative_targets = read_targets(r, e["relative_targets"], field + ".relative_targets", ev.relative_target_lines);
      if (e["activate"]) ev.activate = read_rows(r, e["activate"], field + ".activate");
      if (e["deactivate"]) ev.deactivate = read_rows(r, e["deactivate"], field + ".deactivate");
      if (e["freeze"]) ev.freeze = r.strings(e["freeze"], field + ".freeze");
      if (e["release"]) ev.release = r.strings(e["release"], field + ".release");
      if (e["balance"]) ev.balance = r.boolean(e["balance"], field + ".balance") ? 1 : 0;
      if (ev.balance == 1) no_fixed_base(e["balance"], field + ".balance", "balance");
      s.events.push_back(ev);
    }
  }
  return s;
}

}  // namespace wbm
