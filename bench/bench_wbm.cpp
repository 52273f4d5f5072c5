// bench_wbm: wbm against Orocos KDL on the same trees, and the real-time budget.
//
// Fixtures (see bench/README.md): the built-in paper model with 3, 6 and 12 rows, the
// Unitree G1 with 20 rows, Romeo with 12 rows, optionally any URDF (--wbm_urdf=...).
// Per fixture:
//   <id>/wbm/kinematics      forward kinematics + the active rows' Jacobians (TaskStack::assemble)
//   <id>/kdl/kinematics      TreeFkSolverPos_recursive + TreeJntToJacSolver for the endpoints
//   <id>/wbm/cycle           one Controller::update(): filters, FK, Jacobians, solve, limits
//   <id>/wbm/cycle_cold      the same with cold caches (2 MiB of other data and 64 KiB of other
//                            code between two cycles, untimed: L1 and L2 evicted)
//   <id>/wbm/cycle_out_of_reach  the same with the hand targets out of reach: the damped path
//                            and dofs frozen at their limits (the slow paths)
//   <id>/wbm/part/<stage>    each stage of the cycle alone (filters, fk, ..., solve, integrate)
//   <id>/wbm/solve_after_other_code  the solve stage with 64 KiB of other code run between
//                            two calls, untimed: its code decoded again, as inside the cycle
//   <id>/kdl_wdls/cycle      endpoint FK, twists, TreeIkSolverVel_wdls (6 rows per endpoint), integration,
//                            on wbm's whole tree (the same dofs, virtual ones included)
//   <id>/kdl_wdls_urdf/cycle the same on the URDF's own tree (no virtual dofs, legs included)
//   <id>/kdl_arm/cycle       the same with ChainIkSolverVel_pinv_nso on the right arm chain only
//                            (ChainIkSolverVel_pinv for arms with < 6 joints: the paper model)
// plus scaling/dofs/<n> and scaling/rows_n<n>/<m> on generated trees (the cycle, and its
// assemble and solve stages alone: .../assemble, .../solve), and filter/direction/fixed_dt
// and .../varying_dt (one axis filter update; dt changing on every call).
//
// Every iteration is one call timed on its own (steady_clock, manual time), so the table at
// the end gives the median and the 99th percentile of single calls. Nothing asserts on
// timing; the process fails (exit 1) only if a fixture's sanity check fails.
//
// Own flags (before Google Benchmark's): --wbm_urdf=FILE --wbm_root=LINK --wbm_legs=A,B
// --wbm_hands=LEFT,RIGHT [--wbm_head=FRAME] [--wbm_com] [--wbm_posture=DOF,DOF,...] [--wbm_start=DOF=VALUE,...]
// [--wbm_default_limits] [--wbm_ignore_xacro_elements] [--wbm_drop_legs] [--wbm_root_height=H] [--wbm_upper_body_pivot=H] [--wbm_root_rpy=R,P,Y] [--wbm_fixed_base]
// [--wbm_upper_body_x_range=LO,HI] [--wbm_upper_body_y_range=LO,HI] [--wbm_add_frame=NAME:PARENT:X,Y,Z[:R,P,Y] ...]
// [--wbm_id=NAME] register a fixture "<NAME>" (default "custom") on that model;
// --wbm_loop=SECONDS [--wbm_rate=HZ] [--wbm_priority=P] [--wbm_spin] run the periodic
// real-time loop (periodic_loop.hpp) on that fixture, or on paper_r12, g1_r20 and romeo_r12,
// instead of the benchmarks. scripts/bench.sh wraps this.
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <benchmark/benchmark.h>

#include "bench_common.hpp"
#include "fixtures.hpp"
#include "periodic_loop.hpp"
#include "scaling.hpp"
#include "walking_loop.hpp"
#include "wbm/controller.hpp"
#include "wbm/errors.hpp"
#include "wbm/trajectory_filter.hpp"

namespace {

using wbm_bench::FixtureSpec;

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, sep))
    if (!item.empty()) out.push_back(item);
  return out;
}

/// "; the ends of FILE's tree (links [frames welded to them]): a b [c, d and 3 more] e" (the
/// bodies without children that three or more of the robot's own joints move: the ends of the
/// arms, and of the legs unless locked), or why the URDF does not load; for the error of a
/// missing --hands. Each end is named once, as its body, with the frames welded to it in
/// brackets (the first two and how many more: Romeo's head carries eleven sensor frames). A hand's fingers are shown as the
/// body they branch from (a palm): the first body above an end with two or more children, if
/// it is moved by three or more joints and no end below it lies more than four joints deeper
/// (Valkyrie's fingers made about 50 ends; the torso, where the arms branch, has the arms'
/// ends seven joints below it).
std::string arm_ends(const std::string& urdf, const wbm::UrdfImportOptions& options) {
  constexpr int kMinArmJoints = 3, kMaxFingerJoints = 4;
  constexpr std::size_t kWeldedNamesShown = 2;
  try {
    const wbm::Model model = wbm::load_urdf(urdf, options);
    std::vector<int> children(model.num_bodies(), 0);
    for (int b = 0; b < model.num_bodies(); ++b)
      if (model.body(b).parent >= 0) ++children[model.body(b).parent];
    const auto moves = [&](int b) {  // one of the robot's own joints moves body b
      return model.body(b).dof >= 0 && model.dof(model.body(b).dof).role == wbm::DofRole::kJoint;
    };
    std::vector<int> depth(model.num_bodies(), 0);  // joints from the body down to its deepest end
    for (int b = model.num_bodies() - 1; b >= 0; --b)  // children come after their parents
      if (model.body(b).parent >= 0)
        depth[model.body(b).parent] = std::max(depth[model.body(b).parent], depth[b] + moves(b));
    const auto joints_above = [&](int body) {
      int joints = 0;
      for (const int b : model.moving_bodies(body)) joints += moves(b);
      return joints;
    };
    std::vector<int> end_bodies;  // in the order of their first frame
    for (const wbm::Frame& f : model.frames()) {
      if (children[f.body] > 0 || joints_above(f.body) < kMinArmJoints) continue;
      int branch = model.body(f.body).parent;
      while (branch >= 0 && children[branch] < 2) branch = model.body(branch).parent;
      const bool palm = branch >= 0 && depth[branch] <= kMaxFingerJoints && joints_above(branch) >= kMinArmJoints;
      const int end = palm ? branch : f.body;
      if (std::find(end_bodies.begin(), end_bodies.end(), end) == end_bodies.end()) end_bodies.push_back(end);
    }
    std::string list;
    for (const int end : end_bodies) {
      const std::string& body_name = model.body(end).name;
      std::vector<std::string> welded;
      for (const wbm::Frame& f : model.frames())
        if (f.body == end && f.name != body_name) welded.push_back(f.name);
      list += " " + body_name;
      if (welded.empty()) continue;
      list += " [";
      for (std::size_t k = 0; k < std::min(welded.size(), kWeldedNamesShown); ++k)
        list += (k == 0 ? "" : (k + 1 == welded.size() ? " and " : ", ")) + welded[k];
      if (welded.size() > kWeldedNamesShown) list += " and " + std::to_string(welded.size() - kWeldedNamesShown) + " more";
      list += "]";
    }
    return end_bodies.empty() ? "" : "; the ends of " + urdf + "'s tree (links [frames welded to them]):" + list;
  } catch (const std::exception& e) {
    return "; and the URDF does not load: " + std::string(e.what());
  }
}

/// A number from a flag's text, or an error naming the flag and what was expected.
bool parse_number(const std::string& flag, const std::string& text, const char* expected, double& value,
                  std::string& error) {
  char* end = nullptr;
  value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(value)) {
    error = flag + " '" + text + "': " + expected + " expected";
    return false;
  }
  return true;
}

/// --wbm_loop=SECONDS [--wbm_rate=HZ] [--wbm_priority=P] [--wbm_spin] [--wbm_loop_csv=FILE]:
/// the periodic loop instead of the benchmarks.
struct LoopRequest {
  bool requested = false;
  wbm_bench::PeriodicLoopOptions options;
  std::string csv;  ///< --wbm_loop_csv=FILE: every period's wake-up latency and cycle time
};

bool parse_loop_flags(std::map<std::string, std::string>& flags, LoopRequest& loop, std::string& error) {
  const bool any = flags.count("loop") || flags.count("rate") || flags.count("priority") || flags.count("spin") ||
                   flags.count("loop_csv");
  if (!any) return true;
  if (!flags.count("loop")) {
    error = "--rate/--priority/--spin/--plot (--wbm_rate, --wbm_priority, --wbm_spin, --wbm_loop_csv) need --loop "
            "SECONDS (--wbm_loop)";
    return false;
  }
  loop.csv = flags["loop_csv"];
  loop.options.spin = flags.count("spin") > 0;
  if (loop.options.spin) loop.options.fifo_priority = 0;
  loop.requested = true;
  double priority = loop.options.fifo_priority;
  if (!parse_number("--loop (--wbm_loop)", flags["loop"], "a positive number of seconds", loop.options.seconds, error) ||
      (flags.count("rate") &&
       !parse_number("--rate (--wbm_rate)", flags["rate"], "a positive number of Hz", loop.options.rate_hz, error)) ||
      (flags.count("priority") &&
       !parse_number("--priority (--wbm_priority)", flags["priority"], "a SCHED_FIFO priority 1-99, or 0 for none",
                     priority, error)))
    return false;
  if (!(loop.options.seconds > 0.0) || loop.options.seconds * std::max(loop.options.rate_hz, 1.0) > 1e8) {
    error = "--loop (--wbm_loop) '" + flags["loop"] + "': a positive number of seconds expected (at most 1e8 periods)";
    return false;
  }
  if (!(loop.options.rate_hz > 0.0 && loop.options.rate_hz <= 1e6)) {
    error = "--rate (--wbm_rate) '" + flags["rate"] + "': a rate in Hz expected, > 0 and <= 1e6";
    return false;
  }
  if (!(priority >= 0.0 && priority <= 99.0 && priority == std::floor(priority))) {
    error = "--priority (--wbm_priority) '" + flags["priority"] + "': a SCHED_FIFO priority 1-99, or 0 for none expected";
    return false;
  }
  loop.options.fifo_priority = static_cast<int>(priority);
  if (loop.options.spin && loop.options.fifo_priority > 0) {
    error = "--spin with --priority " + flags["priority"] + ": a busy-waiting SCHED_FIFO thread is throttled by the "
            "kernel (50 ms of every second); busy-waiting runs without SCHED_FIFO";
    return false;
  }
  for (const char* k : {"loop", "rate", "priority", "spin", "loop_csv"}) flags.erase(k);
  return true;
}

/// Removes the --wbm_* flags from argv; returns a custom fixture if --wbm_urdf was given,
/// and the periodic loop if asked for.
bool parse_own_flags(int& argc, char** argv, FixtureSpec& custom, LoopRequest& loop, std::string& error) {
  std::map<std::string, std::string> flags;
  int out = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--wbm_", 0) == 0) {
      const std::size_t eq = a.find('=');
      const std::string key = a.substr(6, eq == std::string::npos ? std::string::npos : eq - 6);
      const std::string value = eq == std::string::npos ? "1" : a.substr(eq + 1);
      if (key == "add_frame" && flags.count(key))  // repeatable: the frames joined by ';'
        flags[key] += ";" + value;
      else
        flags[key] = value;
    } else {
      argv[out++] = argv[i];
    }
  }
  argc = out;
  argv[argc] = nullptr;
  if (!parse_loop_flags(flags, loop, error)) return false;
  if (flags.empty()) return false;
  static const char* known[] = {"urdf",      "root",        "legs",        "hands", "head", "com", "posture",
                                "default_limits", "ignore_xacro_elements", "drop_legs", "root_height", "upper_body_pivot", "root_rpy",
                                "upper_body_x_range", "upper_body_y_range", "fixed_base", "start", "add_frame", "id"};
  for (const auto& flag : flags)
    if (std::none_of(std::begin(known), std::end(known), [&](const char* k) { return flag.first == k; })) {
      error = "unknown flag --wbm_" + flag.first;
      return false;
    }
  if (!flags.count("urdf")) {
    error = "--wbm_urdf=FILE is required with the other --wbm_ flags";
    return false;
  }
  wbm::UrdfImportOptions options;
  options.root = flags["root"];
  options.legs = split(flags["legs"], ',');
  options.default_limits = flags.count("default_limits") > 0;
  options.ignore_xacro_elements = flags.count("ignore_xacro_elements") > 0;
  if (flags.count("drop_legs")) options.leg_mode = wbm::LegMode::kDrop;
  for (const std::string& frame : split(flags["add_frame"], ';')) {
    try {
      options.added_frames.push_back(wbm::parse_added_frame(frame));
    } catch (const wbm::ConfigError& e) {
      error = e.what();
      return false;
    }
  }
  if (flags.count("root_height") && !parse_number("--root-height (--wbm_root_height)", flags["root_height"],
                                                   "a number of metres", options.root_height, error))
    return false;
  if (flags.count("upper_body_pivot") &&
      !parse_number("--upper-body-pivot (--wbm_upper_body_pivot)", flags["upper_body_pivot"], "a number of metres",
                    options.upper_body_pivot, error))
    return false;
  if (flags.count("root_rpy")) {
    const std::vector<std::string> angles = split(flags["root_rpy"], ',');
    if (angles.size() != 3) {
      error = "--root-rpy (--wbm_root_rpy) '" + flags["root_rpy"] + "': ROLL,PITCH,YAW in radians expected";
      return false;
    }
    for (int k = 0; k < 3; ++k)
      if (!parse_number("--root-rpy (--wbm_root_rpy)", angles[k], "an angle in radians", options.root_rpy[k], error))
        return false;
  }
  for (auto [key, range] : {std::pair{std::string("upper_body_x_range"), &options.upper_body_x_range},
                            std::pair{std::string("upper_body_y_range"), &options.upper_body_y_range}}) {
    if (!flags.count(key)) continue;
    std::string flag = key;
    std::replace(flag.begin(), flag.end(), '_', '-');
    const std::string what = "--" + flag + " (--wbm_" + key + ")";
    const std::vector<std::string> bounds = split(flags[key], ',');
    if (bounds.size() != 2) {
      error = what + " '" + flags[key] + "': LOWER,UPPER in metres expected";
      return false;
    }
    for (int k = 0; k < 2; ++k)
      if (!parse_number(what, bounds[k], "a number of metres", (*range)[k], error)) return false;
  }
  const std::vector<std::string> hands = split(flags["hands"], ',');
  if (hands.size() != 2) {
    error = "--hands LEFT,RIGHT (--wbm_hands) is required: the two frames whose position and grasp axis are "
            "commanded, one per arm" +
            (flags["hands"].empty() ? std::string()
                                    : " (got " + std::to_string(hands.size()) + ": '" + flags["hands"] + "')") +
            arm_ends(flags["urdf"], options);
    return false;
  }
  if (hands[0] == hands[1]) {
    error = "--hands " + flags["hands"] + " (--wbm_hands): two different frames expected (left and right hand)";
    return false;
  }
  if (flags["head"] == hands[0] || flags["head"] == hands[1]) {
    error = "--head " + flags["head"] + ": a frame other than the hands expected (the view axis on a hand frame "
            "repeats the rows of its grasp axis)";
    return false;
  }
  const std::string id = flags.count("id") ? flags["id"] : "custom";
  custom = wbm_bench::custom_fixture(id, flags["urdf"], options, hands[0], hands[1], flags["head"]);
  custom.com = flags.count("com") > 0;
  custom.joint_task = split(flags["posture"], ',');
  custom.fixed_base = flags.count("fixed_base") > 0;
  for (const std::string& item : split(flags["start"], ',')) {
    const std::size_t eq = item.find('=');
    double value = 0.0;
    if (eq == std::string::npos || eq == 0) {
      error = "--start (--wbm_start) '" + item + "': DOF=VALUE expected (a dof's name, a value in rad or m)";
      return false;
    }
    if (!parse_number("--start " + item.substr(0, eq) + " (--wbm_start)", item.substr(eq + 1),
                      "a value in rad (m for a prismatic dof)", value, error))
      return false;
    custom.start_values.emplace_back(item.substr(0, eq), value);
  }
  custom.user_robot = true;
  if (custom.com || !custom.joint_task.empty() || !custom.start_values.empty())
    custom.description = flags["urdf"] + ": hands position + grasp axis" + (flags["head"].empty() ? "" : ", head view axis") +
                         (custom.com ? ", centre of mass (heel)" : "") +
                         (custom.joint_task.empty() ? "" : ", posture of " + flags["posture"]) + " (" +
                         std::to_string(custom.rows()) + " rows)" +
                         (custom.start_values.empty() ? "" : ", from the home pose with " + flags["start"]);
  return true;
}

/// One direction (axis) filter update, with the cycle time fixed or changing on every call
/// (a measured dt): the filter recomputes its step coefficients whenever dt changes.
void bm_direction_filter(benchmark::State& state, bool varying_dt) {
  wbm::TrajectoryFilter filter(wbm::TargetKind::kDirection, 3, wbm::FilterParameters{});
  filter.reset(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero());
  const double w = 2.0 * M_PI * 0.25;  // the target moves on a cone, as in the fixtures
  double t = 0.0;
  long k = 0;
  Eigen::Vector3d target = Eigen::Vector3d::UnitZ();
  double dt = 1e-3;
  wbm_bench::timed_loop(
      state,
      [&] {
        dt = varying_dt ? 1e-3 * (1.0 + 1e-4 * static_cast<double>(++k % 7)) : 1e-3;
        t += dt;
        target = Eigen::Vector3d(0.15 * std::cos(w * t), 0.15 * std::sin(w * t), 1.0).normalized();
      },
      [&] { filter.update(target, dt); });
  if (!filter.value().allFinite()) state.SkipWithError("direction filter produced NaN");
}

struct Result {
  double p50_us = 0.0, p99_us = 0.0, mean_us = 0.0;
  double damped_pct = 0.0, refrozen_pct = 0.0;  // wbm cycles only
  double peer_p50_us = 0.0;                     // the paired run: KDL's median
  double peer_ratio() const { return peer_p50_us / p50_us; }  // the paired run: KDL / wbm
};

/// Console output as usual, and the results kept for the tables at the end.
class TableReporter : public benchmark::ConsoleReporter {
 public:
  TableReporter() : ConsoleReporter(isatty(fileno(stdout)) ? OO_ColorTabular : OO_Tabular) {}

  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& run : runs) {
      if (run.run_type != Run::RT_Iteration || run.error_occurred || run.iterations == 0) continue;
      Result r;
      const auto p50 = run.counters.find("p50_us"), p99 = run.counters.find("p99_us");
      if (p50 == run.counters.end() || p99 == run.counters.end()) continue;
      r.p50_us = p50->second.value;
      r.p99_us = p99->second.value;
      const auto damped = run.counters.find("damped_pct"), refrozen = run.counters.find("refrozen_pct");
      if (damped != run.counters.end()) r.damped_pct = damped->second.value;
      if (refrozen != run.counters.end()) r.refrozen_pct = refrozen->second.value;
      const auto peer = run.counters.find("kdl_p50_us");
      if (peer != run.counters.end()) r.peer_p50_us = peer->second.value;
      r.mean_us = run.real_accumulated_time / static_cast<double>(run.iterations) * 1e6;
      std::string name = run.benchmark_name();
      const std::string suffix = "/manual_time";
      if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
        name.resize(name.size() - suffix.size());
      const std::size_t min_time = name.find("/min_time:");  // the cold-cache cycles' own minimum time
      if (min_time != std::string::npos) name.resize(min_time);
      results_[name].push_back(r);
    }
  }

  /// Median over repetitions of each statistic.
  /// The paired run of a fixture (both cycles interleaved), if it ran and timed anything.
  bool get_paired(const std::string& id, Result& out) const {
    return get(id + "/paired/wbm_vs_kdl_wdls", out) && out.p50_us > 0.0;
  }

  bool get(const std::string& name, Result& out) const {
    const auto it = results_.find(name);
    if (it == results_.end() || it->second.empty()) return false;
    auto median = [&](double Result::*field) {
      std::vector<double> v;
      for (const Result& r : it->second) v.push_back(r.*field);
      std::sort(v.begin(), v.end());
      return v[v.size() / 2];
    };
    out.p50_us = median(&Result::p50_us);
    out.p99_us = median(&Result::p99_us);
    out.mean_us = median(&Result::mean_us);
    out.damped_pct = median(&Result::damped_pct);
    out.refrozen_pct = median(&Result::refrozen_pct);
    out.peer_p50_us = median(&Result::peer_p50_us);
    return true;
  }

 private:
  std::map<std::string, std::vector<Result>> results_;
};

std::string fmt_us(double us) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2f", us);
  return buffer;
}

std::string fmt_pct(double fraction) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.0f %%", 100.0 * fraction);
  return buffer;
}

std::string cell(const TableReporter& rep, const std::string& name) {
  Result r;
  if (!rep.get(name, r)) return "-";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.2f / %.2f", r.p50_us, r.p99_us);
  return buffer;
}

std::string ratio(const TableReporter& rep, const std::string& slow, const std::string& fast) {
  Result a, b;
  if (!rep.get(slow, a) || !rep.get(fast, b) || b.p50_us <= 0.0) return "-";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.1fx", a.p50_us / b.p50_us);
  return buffer;
}

void print_tables(const TableReporter& rep, const std::vector<FixtureSpec>& fixtures) {
  std::printf("\nTimes of single calls: median / p99 [us] (timer overhead %.1f ns subtracted). "
              "Ratio = KDL median / wbm median.\n",
              wbm_bench::timer_overhead_ns());
  std::printf("KDL's TreeIkSolverVel_wdls solves 6 rows (position + orientation) per endpoint, on wbm's whole tree "
              "(the same dofs: wbm::export_urdf with the virtual dofs) and on the URDF's own tree (no virtual dofs); "
              "ChainIkSolverVel_pinv_nso (pinv on arms with < 6 joints) solves 6 rows on the right arm chain only.\n\n");
  std::printf("| fixture | rows | wbm FK+Jacobians | KDL FK+Jacobians | ratio |\n|---|---|---|---|---|\n");
  for (const FixtureSpec& f : fixtures) {
    const std::string w = f.id + "/wbm/kinematics", k = f.id + "/kdl/kinematics";
    Result r;
    if (!rep.get(w, r) && !rep.get(k, r)) continue;
    std::printf("| %s | %d | %s | %s | %s |\n", f.id.c_str(), f.rows(), cell(rep, w).c_str(), cell(rep, k).c_str(),
                ratio(rep, k, w).c_str());
  }
  std::printf("\n| fixture | rows | wbm cycle | KDL wdls, same tree | ratio | KDL wdls, URDF tree | ratio "
              "| KDL arm chain | ratio |\n|---|---|---|---|---|---|---|---|---|\n");
  for (const FixtureSpec& f : fixtures) {
    const std::string w = f.id + "/wbm/cycle", k = f.id + "/kdl_wdls/cycle", u = f.id + "/kdl_wdls_urdf/cycle",
                      n = f.id + "/kdl_arm/cycle";
    Result r;
    if (!rep.get(w, r) && !rep.get(k, r) && !rep.get(u, r) && !rep.get(n, r)) continue;
    std::printf("| %s | %d | %s | %s | %s | %s | %s | %s | %s |\n", f.id.c_str(), f.rows(), cell(rep, w).c_str(),
                cell(rep, k).c_str(), ratio(rep, k, w).c_str(), cell(rep, u).c_str(), ratio(rep, u, w).c_str(),
                cell(rep, n).c_str(), ratio(rep, n, w).c_str());
  }
  // The same two cycles interleaved (a slow spell of the machine mostly hits both alike).
  bool paired_header = false;
  for (const FixtureSpec& f : fixtures) {
    Result p;
    if (!rep.get_paired(f.id, p)) continue;
    if (!paired_header) {
      std::printf("\nPaired: the wbm cycle and KDL's wdls cycle (same tree) interleaved, 24 and 2 cycles at a time, "
                  "each timed alone (medians).\n\n| fixture | rows | wbm cycle | KDL wdls, same tree | ratio |\n"
                  "|---|---|---|---|---|\n");
      paired_header = true;
    }
    std::printf("| %s | %d | %.2f | %.2f | %.1fx |\n", f.id.c_str(), f.rows(), p.p50_us, p.peer_p50_us,
                p.peer_ratio());
  }
  // The slow paths: the same cycle with the hands reaching for targets out of reach.
  bool reach_header = false;
  for (const FixtureSpec& f : fixtures) {
    const std::string w = f.id + "/wbm/cycle", o = f.id + "/wbm/cycle_out_of_reach";
    Result reach;
    if (!rep.get(o, reach)) continue;
    if (!reach_header) {
      std::printf("\nOut of reach: the hand targets 1 m beyond the hands, timed after 3 s of reaching (arms "
                  "stretched: the damped path; dofs at their limits: frozen and re-solved). Cycles that took "
                  "these paths, in %% of the timed ones.\n\n"
                  "| fixture | rows | wbm cycle | out of reach | out of reach / cycle | damped | refrozen |\n"
                  "|---|---|---|---|---|---|---|\n");
      reach_header = true;
    }
    std::printf("| %s | %d | %s | %s | %s | %.0f %% | %.0f %% |\n", f.id.c_str(), f.rows(), cell(rep, w).c_str(),
                cell(rep, o).c_str(), ratio(rep, o, w).c_str(), reach.damped_pct,
                reach.refrozen_pct);
  }
  // Cold caches: what a 1 kHz loop with other work between the cycles sees.
  bool cold_header = false;
  for (const FixtureSpec& f : fixtures) {
    const std::string w = f.id + "/wbm/cycle", c = f.id + "/wbm/cycle_cold", k = f.id + "/kdl_wdls/cycle_cold";
    Result cold;
    if (!rep.get(c, cold)) continue;
    if (!cold_header) {
      std::printf("\nCold caches: before each timed cycle (untimed) 2 MiB of other data read and written and 64 KiB "
                  "of other code run, as a robot's other work between two control cycles would (L1 and L2 "
                  "evicted, the shared L3 not).\n\n"
                  "| fixture | rows | wbm cycle | wbm cold | cold / cycle | KDL wdls cold, same tree | ratio |\n"
                  "|---|---|---|---|---|---|---|\n");
      cold_header = true;
    }
    std::printf("| %s | %d | %s | %s | %s | %s | %s |\n", f.id.c_str(), f.rows(), cell(rep, w).c_str(),
                cell(rep, c).c_str(), ratio(rep, c, w).c_str(), cell(rep, k).c_str(),
                ratio(rep, k, c).c_str());
  }
  // Stages of the cycle, each timed alone (medians).
  bool parts_header = false, negative_rest = false;
  for (const FixtureSpec& f : fixtures) {
    Result cycle;
    if (!rep.get(f.id + "/wbm/cycle", cycle)) continue;
    std::string row = "| " + f.id + " | " + fmt_us(cycle.p50_us);
    double sum = 0.0;
    bool any = false;
    for (wbm_bench::Part part : wbm_bench::all_parts()) {
      Result r;
      if (rep.get(f.id + "/wbm/part/" + wbm_bench::part_name(part), r)) {
        row += " | " + fmt_us(r.p50_us) + " (" + fmt_pct(r.p50_us / cycle.p50_us) + ")";
        sum += r.p50_us;
        any = true;
      } else {
        row += " | -";
      }
    }
    if (!any) continue;
    if (!parts_header) {
      std::printf("\nStages of the wbm cycle, each timed alone: median [us] (share of the cycle median).\n\n"
                  "| fixture | cycle");
      for (wbm_bench::Part part : wbm_bench::all_parts()) std::printf(" | %s", wbm_bench::part_name(part));
      std::printf(" | rest |\n|---|---");
      for (std::size_t i = 0; i <= wbm_bench::all_parts().size(); ++i) std::printf("|---");
      std::printf("|\n");
      parts_header = true;
    }
    row += " | " + fmt_us(cycle.p50_us - sum) + " (" + fmt_pct((cycle.p50_us - sum) / cycle.p50_us) + ") |";
    std::printf("%s\n", row.c_str());
    negative_rest |= cycle.p50_us < sum;
  }
  if (negative_rest)
    std::printf("A negative rest: the stages alone took longer than the whole cycle, so the run was disturbed "
                "(other load on the core, an unpinned thread, a busy VM host); run again pinned (taskset -c 1) "
                "or with -- --benchmark_repetitions=5 (medians over the repetitions).\n");

  // The solve stage with its code evicted from the op cache and the L1 instruction cache.
  bool evicted_header = false;
  for (const FixtureSpec& f : fixtures) {
    const std::string alone = f.id + "/wbm/part/solve", evicted = f.id + "/wbm/solve_after_other_code";
    Result r;
    if (!rep.get(alone, r) || !rep.get(evicted, r)) continue;
    if (!evicted_header) {
      std::printf("\nThe solve stage with 64 KiB of other code run before each call (untimed): its code decoded "
                  "again, as inside the cycle, where the other stages' code evicts it; its data still cached.\n\n"
                  "| fixture | solve alone | solve after other code | ratio |\n|---|---|---|---|\n");
      evicted_header = true;
    }
    std::printf("| %s | %s | %s | %s |\n", f.id.c_str(), cell(rep, alone).c_str(), cell(rep, evicted).c_str(),
                ratio(rep, evicted, alone).c_str());
  }

  // A walking robot's loop (walking_loop.hpp): what the walking and balance modules add.
  const std::string walk = "paper_walk/wbm/cycle_with_balance", modules = "paper_walk/wbm/walking_and_balance";
  if (Result r; rep.get(walk, r) || rep.get(modules, r))
    std::printf("\nWalking with balance (the paper model's walk of section VI, restarted when it has ended): the loop "
                "(walking, support polygon, balance, controller) %s us; the walking and balance modules with the "
                "support polygon alone %s us.\n",
                cell(rep, walk).c_str(), cell(rep, modules).c_str());

  // Goals (informational; nothing fails on timing).
  struct Goal {
    const char* id;
    double budget_us;
  };
  bool header = false;
  for (const Goal& g : {Goal{"paper_r12", 2.0}, Goal{"g1_r20", 5.0}}) {
    Result r;
    if (!rep.get(std::string(g.id) + "/wbm/cycle", r)) continue;
    if (!header) std::printf("\nGoals:\n");
    header = true;
    std::printf("  %-10s full cycle median %.2f us <= %.1f us: %s\n", g.id, r.p50_us, g.budget_us,
                r.p50_us <= g.budget_us ? "met" : "MISSED");
  }
  // The ratio from the separate benchmarks, and from the paired one where it ran (both
  // solvers interleaved, so a slow spell of the machine mostly hits both alike); the goal is
  // judged on the paired ratio when there is one.
  for (const char* id : {"paper_r12", "g1_r20"}) {
    const std::string f = id;
    Result a, b, paired;
    const bool separate = rep.get(f + "/kdl_wdls/cycle", a) && rep.get(f + "/wbm/cycle", b) && b.p50_us > 0.0;
    const bool interleaved = rep.get_paired(f, paired);
    if (!separate && !interleaved) continue;
    if (!header) std::printf("\nGoals:\n");
    header = true;
    const double judged = interleaved ? paired.peer_ratio() : a.p50_us / b.p50_us;
    std::printf("  %-10s KDL wdls (same tree) / wbm = ", id);
    // Two decimals: at one, 19.96x printed as "20.0x ... MISSED".
    if (separate) std::printf("%.2fx (separate runs)%s", a.p50_us / b.p50_us, interleaved ? ", " : "");
    if (interleaved)
      std::printf("%.2fx (paired: %.2f / %.2f us)", paired.peer_ratio(), paired.peer_p50_us,
                  paired.p50_us);
    std::printf(" >= 20x: %s\n", judged >= 20.0 ? "met" : "MISSED");
  }
}

/// The last lines for the user's robot: what its cycle costs in a real-time loop.
void print_budget(const TableReporter& rep, const FixtureSpec& f) {
  Result cycle, cold, reach, kdl;
  if (!rep.get(f.id + "/wbm/cycle", cycle)) return;
  const bool has_cold = rep.get(f.id + "/wbm/cycle_cold", cold);
  const bool has_reach = rep.get(f.id + "/wbm/cycle_out_of_reach", reach);
  const double worst_p99 =
      std::max({cycle.p99_us, has_cold ? cold.p99_us : 0.0, has_reach ? reach.p99_us : 0.0});
  std::printf("\nYour robot (%s, %d rows): the wbm cycle takes %.2f us (median), %.2f us (p99)", f.urdf.c_str(),
              f.rows(), cycle.p50_us, cycle.p99_us);
  if (has_cold) std::printf("; with cold caches (other work between the cycles) %.2f / %.2f us", cold.p50_us, cold.p99_us);
  if (has_reach) std::printf("; out of reach (damped, dofs frozen at limits) %.2f / %.2f us", reach.p50_us, reach.p99_us);
  std::printf(".\n  At 1 kHz the largest p99 (%.2f us) is %.2f %% of the 1 ms period", worst_p99, worst_p99 / 10.0);
  // The ratio from the interleaved runs where they ran (a slow spell of the machine mostly
  // hits both alike).
  Result paired;
  const bool interleaved = rep.get_paired(f.id, paired);
  // Each ratio with the two medians it divides: the interleaved run's wbm median is not the
  // separate one above (on a busy machine 2.70 against 3.50 us, once).
  const bool separate = rep.get(f.id + "/kdl_wdls/cycle", kdl);
  if (interleaved)
    std::printf("; KDL's wdls on the same tree, the two interleaved: %.2f us against wbm's %.2f us (%.1fx)",
                paired.peer_p50_us, paired.p50_us, paired.peer_ratio());
  if (separate)
    std::printf("%s %.2f us (%.1fx the wbm median above)",
                interleaved ? "; in separate runs KDL's wdls" : "; KDL's wdls on the same tree takes", kdl.p50_us,
                kdl.p50_us / cycle.p50_us);
  std::printf(".\n  On a shared or unpinned machine the p99 values move by tens of percent; pin the run "
              "(taskset -c 1) and see bench/README.md. In a real-time loop each cycle starts cold and the "
              "machine adds its wake-up latency: scripts/bench.sh --loop 10 with the same flags measures both.\n"
              "  Whether wbm computes your robot right (Jacobians against finite differences and KDL, the "
              "solver's identities, limits): scripts/check_model.sh with the same URDF and --hands/--head/"
              "--legs/--root flags.\n");
}

/// The periodic loop on each fixture in turn, wbm's cycle and then KDL's wdls cycle on the
/// same tree; progress on stderr, a table at the end. Exit 1 if a fixture fails its checks
/// or a cycle reports invalid input; timing never fails.
int run_loops(const std::vector<FixtureSpec>& fixtures, const LoopRequest& request) {
  const wbm_bench::PeriodicLoopOptions& options = request.options;
  struct Row {
    std::string id, solver;
    int rows = 0;
    wbm_bench::PeriodicLoopResult r;
  };
  // The samples go to FILE.tmp, renamed to FILE at the end: a failed or interrupted run
  // leaves no half-written FILE (an old one stays as it was). Opened first, so that a path
  // that cannot be written fails before the run, not after it.
  const std::string csv_tmp = request.csv + ".tmp";
  std::FILE* csv = nullptr;
  if (!request.csv.empty() && (csv = std::fopen(csv_tmp.c_str(), "w")) == nullptr) {
    std::fprintf(stderr, "bench_wbm: --plot/--wbm_loop_csv: cannot write %s: %s\n", csv_tmp.c_str(),
                 std::strerror(errno));
    return 1;
  }
  std::vector<Row> done;
  std::string scheduling;
  for (const FixtureSpec& f : fixtures) {
    if (!wbm_bench::prepare_fixture(f).empty()) {
      if (csv != nullptr) {
        std::fclose(csv);
        std::remove(csv_tmp.c_str());
      }
      return 1;
    }
    for (const wbm_bench::LoopSolver solver : {wbm_bench::LoopSolver::kWbm, wbm_bench::LoopSolver::kKdlWdls}) {
      const char* name = solver == wbm_bench::LoopSolver::kWbm ? "wbm" : "kdl_wdls";
      const wbm_bench::ControlCycle c = wbm_bench::control_cycle(f, solver);
      std::fprintf(stderr, "%s/%s: %d rows, %d dofs, %.0f Hz for %g s ...\n", f.id.c_str(), name, c.rows, c.dofs,
                   options.rate_hz, options.seconds);
      auto progress = [&](double seconds, const wbm_bench::PeriodicLoopResult& so_far) {
        std::fprintf(stderr, "  %s/%s: %3.0f / %g s, %ld periods, cycle max %.1f us, wake-up max %.1f us, "
                     "overruns %ld\n", f.id.c_str(), name, seconds, options.seconds, so_far.periods,
                     so_far.cycle_max, so_far.wake_max, so_far.overruns);
      };
      done.push_back({f.id, name, c.rows, wbm_bench::run_periodic_loop(options, c.next_targets, c.update, progress)});
      scheduling = done.back().r.scheduling;
    }
  }
  if (!wbm_bench::notes().empty()) {
    std::printf("\nSanity checks and sizes:\n");
    for (const std::string& line : wbm_bench::notes()) std::printf("  %s\n", line.c_str());
  }
  const double period_us = 1e6 / options.rate_hz;
  std::printf("\nPeriodic loop: %.0f Hz (period %.1f us) for %g s per solver after %g s of warm-up; %s.\n"
              "Wake-up: from a period's start (clock_nanosleep, absolute, CLOCK_MONOTONIC) to the thread running. "
              "Cycle: one control cycle alone (wbm: Controller::update; kdl_wdls: endpoint FK, twists, "
              "TreeIkSolverVel_wdls, integration, on the same tree). Busy: wake-up + cycle, the part of a period "
              "used. Overrun: a cycle that ended after the next period's start. Ratio: KDL's cycle median / wbm's.\n\n"
              "| fixture | solver | rows | periods | cycle median / p99 / p99.9 / max [us] | wake-up median / p99 / max "
              "[us] | busy max | overruns | skipped | ratio |\n|---|---|---|---|---|---|---|---|---|---|\n",
              options.rate_hz, period_us, options.seconds, options.warmup_seconds, scheduling.c_str());
  bool failed = false;
  for (std::size_t i = 0; i < done.size(); ++i) {
    const Row& d = done[i];
    const wbm_bench::PeriodicLoopResult& r = d.r;
    std::string ratio = "";
    if (d.solver != "wbm" && i > 0 && done[i - 1].id == d.id && done[i - 1].r.cycle_p50 > 0.0) {
      char buffer[32];
      std::snprintf(buffer, sizeof buffer, "%.1fx", r.cycle_p50 / done[i - 1].r.cycle_p50);
      ratio = buffer;
    }
    std::printf("| %s | %s | %d | %ld | %.2f / %.2f / %.2f / %.2f | %.1f / %.1f / %.1f | %.1f %% | %ld | %ld | %s |\n",
                d.id.c_str(), d.solver.c_str(), d.rows, r.periods, r.cycle_p50, r.cycle_p99, r.cycle_p999,
                r.cycle_max, r.wake_p50, r.wake_p99, r.wake_max, 100.0 * r.busy_max / period_us, r.overruns,
                r.skipped, ratio.c_str());
    if ((r.flags & (static_cast<std::uint32_t>(wbm::kInvalidCommand) | wbm::kInvalidInput)) != 0) {
      std::fprintf(stderr, "bench_wbm: FAILED: %s/%s: a cycle reported invalid input or NaN (status 0x%x)\n",
                   d.id.c_str(), d.solver.c_str(), r.flags);
      failed = true;
    }
  }
  if (csv != nullptr) {
    std::fprintf(csv, "fixture,solver,period,period_us,wake_us,cycle_us\n");
    for (const Row& d : done)
      for (std::size_t k = 0; k < d.r.cycle_us.size(); ++k)
        std::fprintf(csv, "%s,%s,%zu,%.3f,%.3f,%.3f\n", d.id.c_str(), d.solver.c_str(), k, d.r.period_us,
                     d.r.wake_us[k], d.r.cycle_us[k]);
    const bool written = std::fclose(csv) == 0;
    if (!written || std::rename(csv_tmp.c_str(), request.csv.c_str()) != 0) {
      std::fprintf(stderr, "bench_wbm: --plot/--wbm_loop_csv: cannot write %s: %s\n", request.csv.c_str(),
                   std::strerror(errno));
      std::remove(csv_tmp.c_str());
      failed = true;
    }
  }
  std::printf("\n%s The largest wake-up latencies and cycle maxima on a shared VM come from the host and the "
              "kernel, not from the controller. For a robot: a PREEMPT_RT kernel, an isolated core (isolcpus, "
              "taskset) and SCHED_FIFO (root or CAP_SYS_NICE).\n",
              options.spin ? "The core busy-waits between two periods: caches and branch predictors keep more of "
                             "the cycle's state than when it sleeps."
                           : "Between two periods the core sleeps: each cycle starts with cold caches and branch "
                             "predictors (in a VM also after the host has run other work), so its median here lies "
                             "above the benchmarks' back-to-back one.");
  return failed ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  FixtureSpec custom;
  LoopRequest loop;
  std::string error;
  const bool has_custom = parse_own_flags(argc, argv, custom, loop, error);
  if (!error.empty()) {
    std::fprintf(stderr, "bench_wbm: %s\n", error.c_str());
    return 2;
  }
  // The cold-cache cycles spend about 70 us per iteration untimed (evicting the caches):
  // their minimum timed time is at most 0.1 s, else the full run would take minutes longer.
  double min_time = 0.5;  // Google Benchmark's default [s]
  for (int i = 1; i < argc; ++i)  // before Initialize(), which removes its flags
    if (std::strncmp(argv[i], "--benchmark_min_time=", 21) == 0) min_time = std::atof(argv[i] + 21);
  const double cold_min_time = std::clamp(min_time, 1e-3, 0.1);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 2;
  wbm_bench::calibrate_timer();

  static std::vector<FixtureSpec> fixtures = wbm_bench::standard_fixtures();
  if (loop.requested) {
    std::vector<FixtureSpec> looped;
    if (has_custom) looped.push_back(custom);
    for (const FixtureSpec& f : fixtures)
      if (!has_custom && (f.id == "paper_r12" || f.id == "g1_r20" || f.id == "romeo_r12")) looped.push_back(f);
    return run_loops(looped, loop);
  }
  if (has_custom) {
    // The user's robot is built and checked before anything runs: a bad name or a failed
    // check is one error (bench_wbm: FAILED: ...), exit 1, no benchmark output.
    // Under the failure, the checks' findings before it (convergence, tracking, how often
    // damped or at a limit): what a user needs to see why.
    if (!wbm_bench::prepare_fixture(custom).empty()) {
      std::fprintf(stderr, "bench_wbm: the checks before the failure:\n");
      for (const std::string& line : wbm_bench::notes())
        if (line.rfind("FAILED: ", 0) != 0) std::fprintf(stderr, "  %s\n", line.c_str());
      return 1;
    }
    fixtures.push_back(custom);
  }
  for (const FixtureSpec& f : fixtures) {
    const FixtureSpec* p = &f;
    auto reg = [&](const std::string& what, void (*fn)(benchmark::State&, const FixtureSpec*)) {
      benchmark::RegisterBenchmark((f.id + "/" + what).c_str(), fn, p)->UseManualTime()->Unit(benchmark::kMicrosecond);
    };
    reg("wbm/kinematics", wbm_bench::bm_wbm_kinematics);
    reg("kdl/kinematics", wbm_bench::bm_kdl_kinematics);
    reg("wbm/cycle", wbm_bench::bm_wbm_cycle);
    for (auto [what, fn] : {std::pair{"wbm/cycle_cold", &wbm_bench::bm_wbm_cycle_cold},
                            std::pair{"kdl_wdls/cycle_cold", &wbm_bench::bm_kdl_wdls_cycle_cold}})
      benchmark::RegisterBenchmark((f.id + "/" + what).c_str(), fn, p)
          ->UseManualTime()
          ->MinTime(cold_min_time)
          ->Unit(benchmark::kMicrosecond);
    reg("wbm/cycle_out_of_reach", wbm_bench::bm_wbm_cycle_out_of_reach);
    reg("wbm/solve_after_other_code", wbm_bench::bm_wbm_solve_after_other_code);
    reg("kdl_wdls/cycle", wbm_bench::bm_kdl_wdls_cycle);
    reg("paired/wbm_vs_kdl_wdls", wbm_bench::bm_wbm_vs_kdl_wdls_paired);
    reg("kdl_wdls_urdf/cycle", wbm_bench::bm_kdl_wdls_urdf_cycle);
    reg("kdl_arm/cycle", wbm_bench::bm_kdl_arm_cycle);
    for (wbm_bench::Part part : wbm_bench::all_parts()) {
      if (part == wbm_bench::Part::kCenterOfMass && !f.com) continue;
      benchmark::RegisterBenchmark((f.id + "/wbm/part/" + wbm_bench::part_name(part)).c_str(), wbm_bench::bm_wbm_part, p,
                                   part)
          ->UseManualTime()
          ->Unit(benchmark::kMicrosecond);
    }
  }
  for (auto [name, part] : {std::pair{"paper_walk/wbm/cycle_with_balance", wbm_bench::WalkPart::kCycle},
                            std::pair{"paper_walk/wbm/walking_and_balance", wbm_bench::WalkPart::kModules}})
    benchmark::RegisterBenchmark(name, wbm_bench::bm_walk, part)->UseManualTime()->Unit(benchmark::kMicrosecond);
  for (bool varying : {false, true})
    benchmark::RegisterBenchmark(varying ? "filter/direction/varying_dt" : "filter/direction/fixed_dt",
                                 bm_direction_filter, varying)
        ->UseManualTime()
        ->Unit(benchmark::kNanosecond);
  static std::vector<wbm_bench::ScalingCase> scaling = wbm_bench::scaling_cases();
  for (const wbm_bench::ScalingCase& c : scaling)
    for (wbm_bench::ScalingStage stage :
         {wbm_bench::ScalingStage::kCycle, wbm_bench::ScalingStage::kAssemble, wbm_bench::ScalingStage::kSolve}) {
      const std::string suffix = wbm_bench::stage_name(stage);
      benchmark::RegisterBenchmark((c.name + (suffix.empty() ? "" : "/" + suffix)).c_str(), wbm_bench::bm_scaling, &c, stage)
          ->UseManualTime()
          ->Unit(benchmark::kMicrosecond);
    }

  TableReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  std::fflush(stdout);
  if (!wbm_bench::notes().empty()) {
    std::printf("\nSanity checks and sizes:\n");
    for (const std::string& line : wbm_bench::notes()) std::printf("  %s\n", line.c_str());
  }
  print_tables(reporter, fixtures);
  if (has_custom) print_budget(reporter, custom);
  benchmark::Shutdown();
  return wbm_bench::any_failure() ? 1 : 0;
}
