// The paper's experiments (Figs. 4 and 7), balance (section V) and walking (section VI),
// run as the shipped scenarios, each checked against what the paper shows.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <iomanip>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <nlohmann/json.hpp>

#include "leg_poser.hpp"
#include "report_writer.hpp"
#include "runner.hpp"
#include "scenario.hpp"
#include "shipped_models.hpp"
#include "test_util.hpp"
#include "wbm/balance.hpp"
#include "wbm/errors.hpp"
#include "wbm/kinematics.hpp"
#include "wbm/paper_model.hpp"
#include "wbm/tasks/attitude_task.hpp"
#include "wbm/tasks/axis_task.hpp"
#include "wbm/tasks/com_task.hpp"
#include "wbm/tasks/joint_task.hpp"
#include "wbm/tasks/position_task.hpp"

namespace {

using namespace wbm;
using Eigen::VectorXd;

Scenario shipped(const std::string& name) { return load_scenario(wbm_test::source_path("scenarios/" + name + ".yaml")); }

/// The report's data (the JSON written into the page's template).
nlohmann::json report_data(const ScenarioRun& run) {
  const std::string page = render_report(run);
  const std::string tmpl = report_template();
  const size_t hole = tmpl.find("__WBM_REPORT_DATA__");
  const std::string after = tmpl.substr(hole + 19, 40);
  const size_t begin = page.find(tmpl.substr(hole - 40, 40)) + 40;
  return nlohmann::json::parse(page.substr(begin, page.find(after, begin) - begin));
}

double deg(double rad) { return rad * 180.0 / M_PI; }

/// Largest |q_ddot| over the run (from the recorded velocities; the robot starts at rest).
double max_acceleration(const ScenarioRun& run) {
  double a = 0.0;
  for (int k = 1; k < run.num_cycles(); ++k) a = std::max(a, (run.qdot[k] - run.qdot[k - 1]).cwiseAbs().maxCoeff());
  return a / run.scenario.dt;
}

TEST(PaperFig7, TopRightHandTargetWithHeadAndLeftArmAtTheirCentres) {
  const auto run = run_scenario(shipped("fig7_top_right_hand"));
  const Model& m = *run->model;
  for (const char* d : {"head_pan", "head_tilt", "l_shoulder_pitch", "l_shoulder_roll", "l_shoulder_yaw", "l_elbow", "l_hand_rot"}) {
    const int i = m.dof_index(d);
    for (int k = 0; k < run->num_cycles(); ++k)
      ASSERT_LT(deg(std::abs(run->q[k][i] - m.dof(i).center())), 1.0) << d << " at t = " << run->time[k];
  }
  const int last = run->num_cycles() - 1;
  EXPECT_LT(run->error[last][run->element("r_hand")], 1e-4);  // 0.1 mm
  // The right arm, the upper-body height (by 1 mm or more; its 12 cm range gives it a small
  // weight in W) and its attitude contribute.
  auto moved = [&](const char* d) { return std::abs(run->q[last][m.dof_index(d)] - run->q[0][m.dof_index(d)]); };
  for (const char* d : {"r_shoulder_pitch", "r_elbow"}) EXPECT_GT(moved(d), 0.05) << d;
  EXPECT_GT(moved("upper_body_z"), 0.001);
  EXPECT_GT(moved("upper_body_pitch") + moved("upper_body_yaw") + moved("upper_body_roll"), 0.02);
}

TEST(PaperFig7, MiddleGazeSweepWithBothHandsHeld) {
  const auto run = run_scenario(shipped("fig7_middle_gaze_sweep"));
  const Model& m = *run->model;
  EXPECT_EQ(run->controller->tasks().num_rows(), 12);
  double yaw_min = 0, yaw_max = 0;
  for (int k = 0; k < run->num_cycles(); ++k) {
    ASSERT_EQ(run->active[k].sum(), 5.0);  // all 5 elements, 12 rows
    for (const char* hand : {"l_hand", "r_hand"}) ASSERT_LT(run->error[k][run->element(hand)], 1e-3) << hand;
    for (const char* axis : {"l_grasp", "r_grasp"}) ASSERT_LT(deg(run->error[k][run->element(axis)]), 1.0) << axis;
    ASSERT_EQ(run->flags[k] & (kDamped | kTaskSpeedLimited | kInvalidInput), 0u) << "t = " << run->time[k];
    const double yaw = run->q[k][m.dof_index("upper_body_yaw")];
    yaw_min = std::min(yaw_min, yaw);
    yaw_max = std::max(yaw_max, yaw);
  }
  // The upper body turns about the vertical axis, to both sides.
  EXPECT_GT(yaw_max, 0.05);
  EXPECT_LT(yaw_min, -0.05);
  EXPECT_LT(deg(run->error.back()[run->element("view")]), 1.0);
}

TEST(PaperFig7, BottomLeftHandHighTarget) {
  const auto run = run_scenario(shipped("fig7_bottom_left_hand_high"));
  const Model& m = *run->model;
  const int last = run->num_cycles() - 1;
  EXPECT_LT(run->error[last][run->element("l_hand")], 1e-3);
  // x and y are free (null space): they move by themselves.
  const VectorXd start = run->actual_of("l_hand", 0), end = run->actual_of("l_hand", last);
  EXPECT_GT((end - start).head<2>().norm(), 0.02);
  // The upper body rotates as the arm nears a straight configuration.
  const VectorXd& q = run->q[last];
  const double rotation = std::abs(q[m.dof_index("upper_body_roll")]) + std::abs(q[m.dof_index("upper_body_pitch")]) +
                          std::abs(q[m.dof_index("upper_body_yaw")]);
  EXPECT_GT(rotation, 0.05);
  // Whole-body Jacobian far better conditioned than the arm's alone.
  Data d(m);
  forward_kinematics(m, d, q);
  const int f = m.frame_index("l_hand_ref");
  const double whole = position_condition_number(m, d, f, false), arm = position_condition_number(m, d, f, true);
  std::cout << "condition numbers at the end: whole body " << whole << ", joints only " << arm << "\n";
  EXPECT_LT(whole, arm);
  // Two joints move the camera: its position rows have rank 2, an infinite condition number
  // (a gap in the report), not the rounding's 1e16 or more.
  for (const VectorXd& qk : {q, m.home(), run->q[last / 2]}) {
    forward_kinematics(m, d, qk);
    EXPECT_TRUE(std::isinf(position_condition_number(m, d, m.frame_index("head_camera"), true)));
  }
}

TEST(PaperFig4, SwitchingKeepsJointAccelerationsBoundedWithTheJerkLimit) {
  // The bound, dt = 1 ms: |q_ddot| <= 100 rad/s^2 for every dof over the whole run
  // (start from rest included). Without the jerk limit the null-space motion starts with
  // a velocity jump of up to the speed limit in one cycle.
  constexpr double kBound = 100.0;
  for (const char* name : {"fig4a_switch_on_hand_z", "fig4b_switch_to_full_hand"}) {
    Scenario s = shipped(name);
    const auto with = run_scenario(s);
    s.solver.nullspace_rate_change_limit = 0.0;
    const auto without = run_scenario(s);
    const double a_with = max_acceleration(*with), a_without = max_acceleration(*without);
    std::cout << name << ": max |q_ddot| " << a_with << " rad/s^2 with the jerk limit, " << a_without << " without\n";
    EXPECT_LE(a_with, kBound) << name;
    EXPECT_GT(a_without, kBound) << name;
    // The switched tasks are reached either way.
    for (int e = 0; e < with->controller->tasks().num_elements(); ++e)
      if (with->active.back()[e] > 0) {
        EXPECT_LT(with->error.back()[e], 2e-3) << name;
      }
  }
}

TEST(Balance, CompensationKeepsTrackingAsAccurateAsWithoutBalance) {
  Scenario s = shipped("balance_hands_forward");
  const auto with = run_scenario(s);
  s.balance.compensate = false;
  const auto uncompensated = run_scenario(s);
  s.balance.enabled = false;
  const auto without = run_scenario(s);
  auto worst = [](const ScenarioRun& r) {  // largest tracking error of an active element
    double e = 0;
    for (int k = 0; k < r.num_cycles(); ++k) e = std::max(e, r.tracking_error[k].cwiseProduct(r.active[k]).maxCoeff());
    return e;
  };
  auto min_margin = [](const ScenarioRun& r) {
    double mm = 1e9;
    for (const VectorXd& b : r.balance) mm = std::min(mm, b[6]);
    return mm;
  };
  std::cout << "max tracking error: balance + x_bal " << worst(*with) * 1e3 << " mm, balance without x_bal "
            << worst(*uncompensated) * 1e3 << " mm, no balance " << worst(*without) * 1e3 << " mm\n"
            << "min com margin: balance " << min_margin(*with) << " m, no balance " << min_margin(*without) << " m\n";
  EXPECT_GT(min_margin(*with), 0.05);                        // com well inside the feet
  EXPECT_GT(min_margin(*with), min_margin(*without) + 0.02);  // balance moved it back
  EXPECT_LT(std::abs(worst(*with) - worst(*without)), 1e-3);  // within 1 mm of no balance
  EXPECT_GT(worst(*uncompensated), worst(*with) + 2e-3);      // measurably worse without x_bal
  const int ub_x = with->model->virtual_dofs().ub_x;
  EXPECT_GT(std::abs(with->q.back()[ub_x] - with->q.front()[ub_x]), 0.01);  // the upper body did shift
  // It shifts back to its lower limit (-2 cm) for about a third of the run and would have
  // needed a few millimetres more (docs/scenarios.md): reported, with the built-in model's
  // range named as fixed.
  const nlohmann::json held = summarize(*with)["balance"]["shift_at_limit"];
  ASSERT_EQ(held.size(), 1u) << held.dump();
  EXPECT_EQ(held[0]["dof"], "upper_body_x");
  EXPECT_EQ(held[0]["limit"].get<double>(), -0.02);
  EXPECT_LT(held[0]["needed"].get<double>(), -0.021);
  EXPECT_GT(held[0]["needed"].get<double>(), -0.025);
  const double share = held[0]["cycles"].get<double>() / summarize(*with)["balance"]["balanced_cycles"].get<double>();
  EXPECT_GT(share, 0.25);
  EXPECT_LT(share, 0.45);
  EXPECT_EQ(held[0]["remedy"], "the built-in paper model's range is fixed");
  // The needed shift replayed from the record: over the cycles with the shift at its limit, the
  // limit plus the centre of mass's offset from the centroid divided by the share of the mass
  // the shift moves, measured here by moving it (the heel body's 10 kg stay behind).
  const Model& m = *with->model;
  Data d(m);
  VectorXd q = with->q.back();
  forward_kinematics(m, d, q);
  const double com_x = center_of_mass_position(m, d).x();
  q[ub_x] += 1e-3;
  forward_kinematics(m, d, q);
  const double mass_share = (center_of_mass_position(m, d).x() - com_x) / 1e-3;
  EXPECT_GT(mass_share, 0.5);
  EXPECT_LT(mass_share, 0.95);
  double needed = 0.0;
  for (size_t k = 0; k < with->balance.size(); ++k)
    if (std::abs(with->q[k][ub_x] + 0.02) < 1e-9)
      needed = std::min(needed, with->q[k][ub_x] + (with->balance[k][2] - with->balance[k][0]) / mass_share);
  std::cout << "needed shift: reported " << held[0]["needed"].get<double>() << " m, replayed " << needed
            << " m (mass share " << mass_share << ")\n";
  EXPECT_NEAR(held[0]["needed"].get<double>(), needed, 2e-5);
}

// A timeline that switches balance off in a scenario without a balance section (the
// module was never built) crashed the runner; it changes nothing now.
TEST(Balance, SwitchingOffABalanceThatWasNeverOnChangesNothing) {
  const std::string head =
      "name: b\nrobot: {builtin: paper}\nduration: 1\nfrozen: [heel_x, heel_y, heel_yaw]\n"
      "tasks: [{name: l, type: position, frame: l_hand_ref}]\n"
      "timeline:\n  - {t: 0.1, activate: [l], relative_targets: {l: [0.1, 0, 0.1]}}\n";
  const auto plain = run_scenario(parse_scenario(head, "b.yaml", "."));
  const auto switched = run_scenario(parse_scenario(head + "  - {t: 0.5, balance: false}\n", "b.yaml", "."));
  ASSERT_EQ(plain->num_cycles(), switched->num_cycles());
  EXPECT_TRUE(switched->balance.empty());
  for (int k = 0; k < plain->num_cycles(); ++k) ASSERT_EQ(plain->q[k], switched->q[k]) << "cycle " << k;
}

TEST(Balance, UrdfModelWithFeetMeasuredFromItsAnkles) {
  const auto run = run_scenario(shipped("g1_reach_with_balance"));
  // G1's ankle roll links are about 0.24 m apart: the support polygon uses that spacing.
  EXPECT_NEAR(run->feet.spacing, 0.24, 0.03);
  for (const VectorXd& b : run->balance) ASSERT_GT(b[6], 0.03);  // com inside with 3 cm to spare
  for (const char* hand : {"l_hand", "r_hand"}) EXPECT_LT(run->error.back()[run->element(hand)], 1e-3) << hand;
}

// An upper-body shift dof at its position limit that the law drives further out is flagged
// (kShiftAtLimit), not one the law drives back in or one inside its range.
TEST(Balance, AShiftDrivenAgainstItsLimitIsFlagged) {
  const Model model = make_paper_model();
  const int ub_x = model.virtual_dofs().ub_x, ub_y = model.virtual_dofs().ub_y;
  Controller c(model);
  c.add_task(std::make_unique<PositionTask>(model, "l_hand", "l_hand_ref"));
  BalanceModule balance(model, std::make_unique<CenterOfMassCentering>(4.0, 0.0));
  auto flags_at = [&](double x, double y, const Vector2& heel) {
    VectorXd q = model.home();
    q[ub_x] = x;
    q[ub_y] = y;
    c.reset(q);
    Command cmd = c.make_command();
    cmd.external_velocity = VectorXd::Zero(model.num_dofs());
    return balance.update(c.data(), SupportPolygon::standing(heel, 0.0, FootGeometry{}), 0.001, cmd);
  };
  const Dof &dx = model.dof(ub_x), &dy = model.dof(ub_y);
  const Vector2 ahead(1.0, 0.0), behind(-1.0, 0.0), left(0.0, 1.0);
  using Sides = std::array<int, 2>;  // which limit each dof (x, y) is driven against
  EXPECT_TRUE(flags_at(dx.upper, 0.0, ahead) & kShiftAtLimit);
  EXPECT_EQ(balance.last_shift_at_limit(), (Sides{1, 0}));
  EXPECT_FALSE(flags_at(dx.upper, 0.0, behind) & kShiftAtLimit);
  EXPECT_EQ(balance.last_shift_at_limit(), (Sides{0, 0}));
  EXPECT_TRUE(flags_at(dx.lower, 0.0, behind) & kShiftAtLimit);
  EXPECT_EQ(balance.last_shift_at_limit(), (Sides{-1, 0}));
  EXPECT_FALSE(flags_at(dx.center(), 0.0, ahead) & kShiftAtLimit);
  EXPECT_TRUE(flags_at(dx.center(), dy.upper, left) & kShiftAtLimit);
  EXPECT_EQ(balance.last_shift_at_limit(), (Sides{0, 1}));
  EXPECT_FALSE(flags_at(dx.center(), dy.lower, left) & kShiftAtLimit);
}

// What the run's "needed" shift assumes: shifting the upper body by d moves the centre of mass
// by d times the share of the mass that the shift dof carries (the paper model's heel body,
// 10 kg of lumped shanks and feet, stays; a URDF import's heel is massless: share 1).
TEST(Balance, TheCentreOfMassFollowsTheShiftByTheShareOfTheMassItMoves) {
  for (const bool urdf : {false, true}) {
    const Model model = urdf ? wbm_test::shipped_model("g1_29dof").load() : make_paper_model();
    const VirtualDofs& v = model.virtual_dofs();
    Data data(model);
    for (const int dof : {v.ub_x, v.ub_y}) {
      int body = -1;
      for (int b = 0; b < model.num_bodies(); ++b)
        if (model.body(b).dof == dof) body = b;
      ASSERT_GE(body, 0);
      const double share = model.subtree_mass()[body] / model.total_mass();
      if (urdf) EXPECT_NEAR(share, 1.0, 1e-14);
      else EXPECT_NEAR(share, 1.0 - 10.0 / model.total_mass(), 1e-12);
      VectorXd q = model.home();
      forward_kinematics(model, data, q);
      const Vector3 before = center_of_mass_position(model, data);
      q[dof] += 0.01;
      forward_kinematics(model, data, q);
      const Vector3 moved = center_of_mass_position(model, data) - before;
      const Matrix3& R_WH = data.X_WB[v.heel_body].R;  // the shift's axes are the heel frame's
      EXPECT_NEAR((R_WH.transpose() * moved)[dof == v.ub_x ? 0 : 1], 0.01 * share, 1e-12) << model.name();
    }
  }
}

// Feet longer than the default upper-body range allows for (TOCABI's, 0.30 m, needed 0.21 m
// where the range ends at 0.14 m): the run reports the shift held at its limit and the shift
// the centre of mass needed; with the range widened to that, the centre of mass is centred.
TEST(Balance, ARangeTooSmallForTheFeetIsReportedAndWideningItCentresTheCom) {
  Scenario s = shipped("g1_reach_with_balance");
  s.feet.geometry.length = 0.5;
  const auto short_range = run_scenario(s);
  const nlohmann::json held = summarize(*short_range)["balance"]["shift_at_limit"];
  ASSERT_EQ(held.size(), 1u) << held.dump();
  EXPECT_EQ(held[0]["dof"], "upper_body_x");
  EXPECT_EQ(held[0]["limit"].get<double>(), 0.14);
  const double needed = held[0]["needed"].get<double>();
  EXPECT_GT(needed, 0.2);
  EXPECT_GT(held[0]["cycles"].get<int>(), short_range->num_cycles() / 2);
  // The remedy suggests a range that reaches the needed shift with a centimetre to spare; it works.
  EXPECT_EQ(held[0]["remedy"], "widen robot.upper_body_x_range for these feet, e.g. to [-0.02, 0.25]");
  EXPECT_GT(0.25, needed + 0.01);
  s.urdf_options.upper_body_x_range = {-0.02, 0.25};
  const auto wide_range = run_scenario(s);
  EXPECT_TRUE(summarize(*wide_range)["balance"]["shift_at_limit"].empty());
  const VectorXd& end = wide_range->balance.back();  // com x, y, centroid x, y, ...
  std::cout << "feet 0.5 m long: com " << (short_range->balance.back().head<2>() - short_range->balance.back().segment<2>(2)).norm()
            << " m from the centroid with the default range, needed " << needed << " m of shift; "
            << (end.head<2>() - end.segment<2>(2)).norm() << " m with the range widened\n";
  EXPECT_LT((end.head<2>() - end.segment<2>(2)).norm(), 0.01);
  EXPECT_GT((short_range->balance.back().head<2>() - short_range->balance.back().segment<2>(2)).norm(), 0.05);
  // The report's summary table says it too, beside the centre of mass's margins.
  auto rows_named = [](const ScenarioRun& run, const std::string& key) {
    std::vector<std::string> texts;
    const nlohmann::json report = report_data(run);
    for (const auto& row : report["summary"])
      if (row[0] == key) texts.push_back(row[1].get<std::string>());
    return texts;
  };
  const std::vector<std::string> said = rows_named(*short_range, "balance: upper-body shift at its limit");
  ASSERT_EQ(said.size(), 1u);
  EXPECT_EQ(said[0].rfind("upper_body_x held at its limit 14.0 cm in ", 0), 0u) << said[0];
  EXPECT_NE(said[0].find("e.g. to [-0.02, 0.25]"), std::string::npos) << said[0];
  EXPECT_TRUE(rows_named(*wide_range, "balance: upper-body shift at its limit").empty());
  EXPECT_EQ(rows_named(*wide_range, "centre of mass inside the feet, least / at the end").size(), 1u);
  // The shipped scenario's own feet fit the default range.
  EXPECT_TRUE(summarize(*run_scenario(shipped("g1_reach_with_balance")))["balance"]["shift_at_limit"].empty());
}

TEST(Balance, ZeroAreaSupportAndABadLawHaveDefinedResults) {
  const Model model = make_paper_model();
  Controller c(model);
  c.add_task(std::make_unique<PositionTask>(model, "l_hand", "l_hand_ref"));
  c.reset(model.home());
  Command cmd = c.make_command();
  cmd.external_velocity = VectorXd::Zero(model.num_dofs());
  BalanceModule balance(model, std::make_unique<CenterOfMassCentering>(4.0, 0.0));
  const std::uint32_t none = balance.update(c.data(), SupportPolygon(), 0.001, cmd);
  EXPECT_TRUE(none & kNoSupport);
  EXPECT_EQ(cmd.external_velocity.norm(), 0.0);
  EXPECT_FALSE(cmd.free_dofs[model.virtual_dofs().ub_x]);
  struct NanLaw : BalanceLaw {
    Vector2 shift_velocity(const Vector2&, const SupportPolygon&, double) override { return Vector2::Constant(std::nan("")); }
  };
  BalanceModule bad(model, std::make_unique<NanLaw>());
  const SupportPolygon feet = SupportPolygon::standing(Vector2::Zero(), 0.0, FootGeometry{});
  EXPECT_NEAR(feet.area(), 0.22 * (0.18 + 0.12), 1e-12);
  EXPECT_TRUE(bad.update(c.data(), feet, 0.001, cmd) & kInvalidLawOutput);
  EXPECT_EQ(cmd.external_velocity.norm(), 0.0);
  EXPECT_TRUE(c.update(cmd, 0.001).ok());
  EXPECT_TRUE(c.q().allFinite());
  EXPECT_THROW(CenterOfMassCentering(0.0, 0.0), ConfigError);
  // Signed distance: positive inside, negative outside.
  EXPECT_NEAR(feet.signed_distance(feet.centroid()), 0.11, 1e-12);
  EXPECT_LT(feet.signed_distance(Vector2(1.0, 0.0)), 0.0);
}

// The shipped law's dead zone: with a margin, no shift while the centre of mass is at
// least that far inside the support polygon, gain * (centroid - com) once it is closer to
// the boundary or outside; without one, always the pull towards the centroid.
TEST(Balance, TheMarginIsADeadZoneInsideTheSupportPolygon) {
  const SupportPolygon feet = SupportPolygon::standing(Vector2::Zero(), 0.0, FootGeometry{});
  const double margin = 0.03, gain = 4.0;
  CenterOfMassCentering with_margin(gain, margin), without(gain, 0.0);
  // Points along x through the centroid: 0.11 m from the heel and toe edges at the centroid.
  for (const double x : {0.11, 0.05, -0.05, -0.075, -0.085, -0.09, -0.2, 0.2, 0.3}) {
    const Vector2 com = feet.centroid() + Vector2(x, 0.0);
    const double inside = feet.signed_distance(com);
    const Vector2 pull = gain * (feet.centroid() - com);
    const Vector2 v = with_margin.shift_velocity(com, feet, 0.001);
    if (inside >= margin)
      EXPECT_EQ(v.norm(), 0.0) << "x " << x << ", " << inside << " m inside";
    else
      EXPECT_LT((v - pull).norm(), 1e-15) << "x " << x << ", " << inside << " m inside";
    EXPECT_LT((without.shift_velocity(com, feet, 0.001) - pull).norm(), 1e-15) << "x " << x;
  }
  EXPECT_THROW(CenterOfMassCentering(gain, -0.01), ConfigError);
}

// The support polygon holds its vertices in the object (no allocation in the cycle): on
// random feet (1 to kMaxFeet, seeded) it is the convex hull of the corners: counter-clockwise
// and convex, its vertices corners, every corner inside or on it, its area the shoelace
// formula's; more feet than it has room for are a ConfigError.
TEST(Balance, SupportPolygonIsTheHullOfTheFeetCorners) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> position(-0.5, 0.5), angle(-M_PI, M_PI), size(0.01, 0.3);
  for (int trial = 0; trial < 20000; ++trial) {
    FootGeometry g;
    g.length = size(rng);
    g.width = size(rng);
    std::vector<FootPose> feet(1 + trial % SupportPolygon::kMaxFeet);
    for (FootPose& f : feet) f = {Vector2(position(rng), position(rng)), angle(rng)};
    if (trial % 7 == 0) feet.back() = feet.front();  // coincident feet: repeated corners
    const SupportPolygon poly = SupportPolygon::from_feet(feet, g);
    std::vector<Vector2> corners;
    for (const FootPose& f : feet)
      for (const Vector2& c : {Vector2(0.0, -0.5 * g.width), Vector2(g.length, -0.5 * g.width),
                               Vector2(g.length, 0.5 * g.width), Vector2(0.0, 0.5 * g.width)})
        corners.push_back(f.position + Eigen::Rotation2Dd(f.yaw) * c);
    const auto v = poly.vertices();
    ASSERT_GE(v.size(), 4u) << "trial " << trial;
    ASSERT_LE(v.size(), corners.size()) << "trial " << trial;
    double area = 0.0;
    for (size_t i = 0; i < v.size(); ++i) {
      const Vector2 &a = v[i], &b = v[(i + 1) % v.size()], &c = v[(i + 2) % v.size()];
      area += 0.5 * (a.x() * b.y() - b.x() * a.y());
      EXPECT_GT((b - a).x() * (c - b).y() - (b - a).y() * (c - b).x(), 0.0) << "trial " << trial << ": not convex at " << i;
      EXPECT_TRUE(std::any_of(corners.begin(), corners.end(), [&](const Vector2& k) { return (k - a).norm() == 0.0; }))
          << "trial " << trial << ": vertex " << i << " is not a corner";
    }
    EXPECT_NEAR(poly.area(), area, 1e-12) << "trial " << trial;
    for (const Vector2& k : corners) EXPECT_GE(poly.signed_distance(k), -1e-12) << "trial " << trial;
    if (HasFailure()) break;
  }
  const std::vector<FootPose> too_many(SupportPolygon::kMaxFeet + 1);
  try {
    SupportPolygon::from_feet(too_many, FootGeometry{});
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("support polygon: 5 feet, at most 4"), std::string::npos) << e.what();
  }
}

// The signed distance on random support polygons (seeded) against a plain computation: the
// distance to the nearest point of the boundary's segments, positive where the point lies on
// the inner side of every edge. Points near an edge (a millimetre either side) and beyond a
// corner (where the nearest point is the corner, not the edge's line) are drawn too.
TEST(Balance, SignedDistanceIsTheDistanceToTheBoundary) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> position(-0.4, 0.4), angle(-M_PI, M_PI), size(0.05, 0.3), unit(0.0, 1.0);
  for (int trial = 0; trial < 5000; ++trial) {
    FootGeometry g;
    g.length = size(rng);
    g.width = size(rng);
    std::vector<FootPose> feet(1 + trial % SupportPolygon::kMaxFeet);
    for (FootPose& f : feet) f = {Vector2(position(rng), position(rng)), angle(rng)};
    const SupportPolygon poly = SupportPolygon::from_feet(feet, g);
    const auto v = poly.vertices();
    const size_t nv = v.size();
    auto plain = [&](const Vector2& p) {
      double nearest = std::numeric_limits<double>::infinity();
      bool inside = true;
      for (size_t i = 0; i < nv; ++i) {
        const Vector2 a = v[i], e = v[(i + 1) % nv] - a;
        inside = inside && e.x() * (p.y() - a.y()) - e.y() * (p.x() - a.x()) >= 0.0;
        const double t = std::clamp((p - a).dot(e) / e.squaredNorm(), 0.0, 1.0);
        nearest = std::min(nearest, (a + t * e - p).norm());
      }
      return inside ? nearest : -nearest;
    };
    std::vector<Vector2> points;
    for (int k = 0; k < 4; ++k) points.push_back(Vector2(position(rng), position(rng)));
    const size_t i = trial % nv;
    const Vector2 a = v[i], e = v[(i + 1) % nv] - a;
    const Vector2 inward = Vector2(-e.y(), e.x()).normalized();
    for (const double d : {1e-3, -1e-3}) points.push_back(a + unit(rng) * e + d * inward);
    // Beyond the corner a, outside both edges that meet there.
    const Vector2 previous = a - v[(i + nv - 1) % nv];
    const Vector2 out = -(inward + Vector2(-previous.y(), previous.x()).normalized()).normalized();
    points.push_back(a + 0.05 * out);
    for (const Vector2& p : points)
      ASSERT_NEAR(poly.signed_distance(p), plain(p), 1e-12)
          << "trial " << trial << ", point " << p.transpose() << ", " << nv << " vertices";
    ASSERT_LT(poly.signed_distance(a + 0.05 * out), -0.049) << "trial " << trial << ": the corner's distance";
  }
}

TEST(Balance, ParametersOutsideTheirRangesThrow) {
  const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
  for (const double margin : {-0.01, nan, inf}) EXPECT_THROW(CenterOfMassCentering(4.0, margin), ConfigError) << margin;
  for (const double gain : {0.0, -1.0, nan, inf}) EXPECT_THROW(CenterOfMassCentering(gain, 0.0), ConfigError) << gain;
  EXPECT_NO_THROW(CenterOfMassCentering(4.0, 0.0));
  const Model model = make_paper_model();
  auto law = [] { return std::make_unique<CenterOfMassCentering>(4.0, 0.0); };
  for (const auto& [field, value] : std::vector<std::pair<std::string, double>>{
           {"length", 0.0}, {"length", nan}, {"width", -0.1}, {"width", nan}, {"spacing", -1e-3}, {"spacing", nan}}) {
    FootGeometry feet;
    (field == "length" ? feet.length : field == "width" ? feet.width : feet.spacing) = value;
    EXPECT_THROW(BalanceModule(model, law(), feet), ConfigError) << field << " " << value;
  }
  FootGeometry together;
  together.spacing = 0.0;  // feet side by side without a gap
  EXPECT_NO_THROW(BalanceModule(model, law(), together));
  EXPECT_THROW(BalanceModule(model, nullptr), ConfigError);
  // A model needs the heel and both upper-body shift dofs.
  for (int missing = 0; missing < 3; ++missing) {
    VirtualDofs v;
    v.heel_body = missing == 0 ? -1 : 0;
    v.ub_x = missing == 1 ? -1 : 1;
    v.ub_y = missing == 2 ? -1 : 2;
    const Model partial = wbm_test::chain_model("partial", {"a", "b", "c"}, v);
    EXPECT_TRUE(wbm_test::throws_with<ConfigError>([&] { BalanceModule(partial, law()); },
                                                   "has no virtual heel and upper-body x/y dofs"))
        << "without " << (missing == 0 ? "heel" : missing == 1 ? "ub_x" : "ub_y");
  }
}

// What the module writes and flags: the centre of mass outside the feet is flagged, a law
// faster than the shift dofs is scaled to their speed limit (direction kept) and flagged,
// and disable() hands the dofs back with no external velocity left on them.
TEST(Balance, TheFlagsAndTheCommandSayWhatTheShiftDid) {
  const Model model = make_paper_model();
  const int ub_x = model.virtual_dofs().ub_x, ub_y = model.virtual_dofs().ub_y;
  Controller c(model);
  c.add_task(std::make_unique<PositionTask>(model, "l_hand", "l_hand_ref"));
  c.reset(model.home());
  Command cmd = c.make_command();
  cmd.external_velocity = VectorXd::Zero(model.num_dofs());
  const Vector2 com = center_of_mass_position(model, c.data()).head<2>();
  const FootGeometry feet;
  // The feet under the centre of mass (its heel edge 5 cm behind it): inside, a slow pull.
  BalanceModule slow(model, std::make_unique<CenterOfMassCentering>(0.5, 0.0));
  std::uint32_t flags = slow.update(c.data(), SupportPolygon::standing(com - Vector2(0.05, 0.0), 0.0, feet), 0.001, cmd);
  EXPECT_EQ(flags, kBalanceOk);
  EXPECT_GT(slow.last_margin(), 0.0);
  EXPECT_GT(cmd.external_velocity[ub_x], 0.0);
  EXPECT_LT(cmd.external_velocity[ub_x], model.dof(ub_x).max_speed);
  // The feet 30 cm ahead and 10 cm to the left: outside, and a fast law saturates.
  BalanceModule fast(model, std::make_unique<CenterOfMassCentering>(50.0, 0.0));
  const SupportPolygon ahead = SupportPolygon::standing(com + Vector2(0.3, 0.1), 0.0, feet);
  flags = fast.update(c.data(), ahead, 0.001, cmd);
  EXPECT_TRUE(flags & kComOutside);
  EXPECT_TRUE(flags & kShiftSaturated);
  EXPECT_LT(fast.last_margin(), -0.2);
  const Vector2 shift(cmd.external_velocity[ub_x], cmd.external_velocity[ub_y]);
  const Vector2 pull = ahead.centroid() - com;
  EXPECT_NEAR(std::max(std::abs(shift.x()) / model.dof(ub_x).max_speed, std::abs(shift.y()) / model.dof(ub_y).max_speed),
              1.0, 1e-12);
  EXPECT_NEAR(shift.normalized().dot(pull.normalized()), 1.0, 1e-12);
  EXPECT_FALSE(cmd.free_dofs[ub_x] || cmd.free_dofs[ub_y]);
  fast.disable(cmd);
  EXPECT_TRUE(cmd.free_dofs[ub_x] && cmd.free_dofs[ub_y]);
  EXPECT_EQ(cmd.external_velocity[ub_x], 0.0);
  EXPECT_EQ(cmd.external_velocity[ub_y], 0.0);
}

const Eigen::VectorXd& final_walking(const ScenarioRun& r) { return r.walking.back(); }
int walks(const ScenarioRun& r) {
  int n = 0;
  for (size_t k = 1; k < r.walking.size(); ++k) n += (r.walking[k][3] > 0 && r.walking[k - 1][3] == 0) ? 1 : 0;
  return n;
}

/// Largest joint acceleration [rad/s^2, m/s^2] over the cycles from time t0 on (second
/// differences of the recorded configurations), and its dof.
std::pair<double, std::string> largest_acceleration_after(const ScenarioRun& run, double t0) {
  std::pair<double, std::string> worst{0.0, ""};
  for (size_t k = 1; k + 1 < run.q.size(); ++k) {
    if (run.time[k] < t0) continue;
    const double dt = run.time[k + 1] - run.time[k];
    const VectorXd a = (run.q[k + 1] - 2.0 * run.q[k] + run.q[k - 1]) / (dt * dt);
    Eigen::Index i = 0;
    if (a.cwiseAbs().maxCoeff(&i) > worst.first) worst = {std::abs(a[i]), run.model->dof(static_cast<int>(i)).name};
  }
  return worst;
}

TEST(Walking, ObjectAheadWalksStopsAndGrasps) {
  const auto run = run_scenario(shipped("walk_object_ahead"));
  EXPECT_GE(walks(*run), 1);
  EXPECT_GE(run->footsteps.size(), 4u);
  EXPECT_EQ(final_walking(*run)[3], 0.0);  // stopped, heel frozen again
  EXPECT_LT(run->error.back()[run->element("l_hand")], 0.01);
  EXPECT_LT(deg(run->error.back()[run->element("l_grasp")]), 5.0);
  // The real heel (between the feet) came along with the floating heel.
  const Model& m = *run->model;
  const Vector2 floating(run->q.back()[m.virtual_dofs().heel_x], run->q.back()[m.virtual_dofs().heel_y]);
  EXPECT_LT((floating - final_walking(*run).head<2>()).norm(), 0.03);
  EXPECT_GT(floating.norm(), 0.5);
  // The walk ended after the heel dofs had been slower than converged_speed for converge_time
  // (their rates from the recorded configurations; the cycle the walk ended in excluded).
  const WalkingParameters& wp = run->walking_parameters;
  const double dt = run->time[1] - run->time[0];
  for (int k = 1; k < run->num_cycles(); ++k) {
    if (!(run->walking[k - 1][3] > 0 && run->walking[k][3] == 0)) continue;
    for (int j = k - 1 - static_cast<int>(wp.converge_time / dt) + 1; j < k; ++j)
      for (const int d : {m.virtual_dofs().heel_x, m.virtual_dofs().heel_y, m.virtual_dofs().heel_yaw})
        ASSERT_LT(std::abs(run->q[j][d] - run->q[j - 1][d]) / dt, wp.converged_speed + 1e-9)
            << "walk ending at t = " << run->time[k] << ": heel dof " << d << " at t = " << run->time[j];
  }
  // The walk ended with each foot at its place beside the floating heel, within feet_tolerance.
  for (const bool left : {true, false}) {
    FootPose last = standing_foot(left, Vector2::Zero(), 0.0, run->feet.spacing);
    for (const Footstep& step : run->footsteps)
      if (step.left == left) last = step.pose;
    const FootPose place = standing_foot(left, floating, run->q.back()[m.virtual_dofs().heel_yaw], run->feet.spacing);
    EXPECT_LT((last.position - place.position).norm(), run->walking_parameters.feet_tolerance) << left;
  }
  // Where the heel dofs are released and frozen again (b_C), q_dot changes by at most
  // k vmax dt per cycle (80 rad/s^2 here; 754 before that limit covered such switches).
  const auto [acceleration, dof] = largest_acceleration_after(*run, 0.0);
  EXPECT_LT(acceleration, 100.0) << dof;
  // The report draws the feet standing at the start, then every footstep as it lands (no
  // feet were drawn until the first step).
  const nlohmann::json prints = report_data(*run)["footprints"];
  ASSERT_EQ(prints.size(), run->footsteps.size() + 2);
  const FootGeometry& feet = run->feet;
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(prints[i]["t"].get<double>(), run->time.front());
    const double y0 = prints[i]["polygon"][0][1].get<double>(), y2 = prints[i]["polygon"][2][1].get<double>();
    EXPECT_NEAR(0.5 * (y0 + y2), (i == 0 ? 0.5 : -0.5) * feet.spacing, 1e-12);  // beside the heel at the origin
  }
  EXPECT_EQ(prints[2]["t"].get<double>(), run->footsteps.front().time);
  // The hand's error in mm and the grasp axis's in degrees are plotted apart (on one axis the
  // degrees were invisible beside the millimetres).
  std::vector<std::string> error_units;
  const nlohmann::json report = report_data(*run);
  for (const auto& plot : report["plots"])
    if (plot["title"].get<std::string>().rfind("Task errors", 0) == 0) error_units.push_back(plot["unit"]);
  EXPECT_EQ(error_units, (std::vector<std::string>{"mm", "deg"}));
}

TEST(Walking, ObjectBehindTurnsAndWalks) {
  const auto run = run_scenario(shipped("walk_object_behind"));
  const auto [acceleration, dof] = largest_acceleration_after(*run, 0.0);
  EXPECT_LT(acceleration, 100.0) << dof;  // 635 rad/s^2 before, see above
  EXPECT_GE(walks(*run), 1);
  EXPECT_GT(std::abs(final_walking(*run)[2]), M_PI / 2);  // real heel turned more than 90 deg
  EXPECT_EQ(final_walking(*run)[3], 0.0);
  EXPECT_LT(run->error.back()[run->element("l_hand")], 0.01);
  // The walk ended with both feet turned as far as the heel (within twice feet_tolerance in
  // rad; Walking.AWalkThatOnlyTurnsTurnsTheFeet checks a turn too small to move the feet).
  const double heel_yaw = run->q.back()[run->model->virtual_dofs().heel_yaw];
  const double tolerance = 2.0 * run->walking_parameters.feet_tolerance;
  ASSERT_GE(run->footsteps.size(), 2u);
  for (size_t k = run->footsteps.size() - 2; k < run->footsteps.size(); ++k)
    EXPECT_LT(std::abs(std::remainder(run->footsteps[k].pose.yaw - heel_yaw, 2 * M_PI)), tolerance)
        << (run->footsteps[k].left ? "left" : "right") << " foot at yaw " << run->footsteps[k].pose.yaw
        << ", heel " << heel_yaw;
  EXPECT_LT(std::abs(std::remainder(final_walking(*run)[2] - heel_yaw, 2 * M_PI)), tolerance);
}

TEST(Walking, ObjectWithinReachDoesNotWalk) {
  const auto run = run_scenario(shipped("walk_object_within_reach"));
  EXPECT_EQ(walks(*run), 0);
  EXPECT_TRUE(run->footsteps.empty());
  EXPECT_LT(run->error.back()[run->element("l_hand")], 1e-3);
}

// A robot that starts elsewhere (`initial` moves the heel) stands there: the walking module
// placed its feet beside the home pose's heel (0, 0, facing x), so the feet, the real heel and
// the support balance kept the centre of mass over were 0.36 m away and turned the other way.
TEST(Walking, TheFeetStandBesideTheStartsHeel) {
  Scenario s = shipped("walk_object_within_reach");
  s.initial = {{"heel_x", 0.3}, {"heel_y", -0.2}, {"heel_yaw", 2.5}};
  s.balance.enabled = s.balance.configured = true;
  s.duration = 0.1;  // before the (now distant) object makes it walk
  const auto run = run_scenario(s);
  ASSERT_TRUE(run->footsteps.empty());
  for (int k : {0, run->num_cycles() - 1}) {
    EXPECT_NEAR(run->walking[k][0], 0.3, 1e-12);
    EXPECT_NEAR(run->walking[k][1], -0.2, 1e-12);
    EXPECT_NEAR(run->walking[k][2], 2.5, 1e-12);
    // The support's centroid: the real heel moved half a foot forward along its yaw.
    EXPECT_LT((run->support[k].centroid() - Vector2(0.3, -0.2)).norm(), run->feet.length) << k;
  }
  WalkingModule walking(*run->model, run->feet, run->walking_parameters);
  EXPECT_THROW(walking.stand_at(Eigen::VectorXd::Zero(3)), ConfigError);
}

TEST(Walking, UnreachableTargetDoesNotStepForever) {
  Scenario s = shipped("walk_object_ahead");
  s.duration = 20.0;
  s.events[0].targets[0].second = Eigen::Vector3d(0.5, 0.3, 20.0);  // 20 m up
  const auto run = run_scenario(s);
  EXPECT_LE(walks(*run), s.walking.parameters.max_walks);
  EXPECT_EQ(final_walking(*run)[3], 0.0);
  for (const VectorXd& q : run->q) ASSERT_TRUE(q.allFinite());
  // Stepping stopped well before the end, after few steps.
  EXPECT_LT(run->footsteps.size(), 20u);
  if (!run->footsteps.empty()) {
    EXPECT_LT(run->footsteps.back().time, s.duration - 5.0);
  }
}

// A walk that ends while the heel still moves: a target 300 m ahead, which the heel at its
// speed limit (0.5 m/s) approaches by less than 1 % per stall_time, so the walk stalls at
// full speed. The heel then brakes to rest at v_max / heel_stop_time; with heel_stop_time
// 0 it stops within a cycle (found by random scenarios: 0.5 m/s to 0 in 2 ms).
TEST(Walking, AWalkEndingWhileTheHeelMovesBrakesTheHeel) {
  Scenario s = shipped("walk_object_ahead");
  s.duration = 12.0;
  s.events[0].targets[0].second = Eigen::Vector3d(300.0, 0.0, 1.0);
  for (const double stop_time : {0.25, 0.0}) {
    s.walking.parameters.heel_stop_time = stop_time;
    const auto run = run_scenario(s);
    const int heel_x = run->model->virtual_dofs().heel_x;
    const double v_max = run->model->max_speeds()[heel_x];
    std::vector<double> v;
    for (int k = 1; k < run->num_cycles(); ++k) v.push_back((run->q[k][heel_x] - run->q[k - 1][heel_x]) / s.dt);
    double fastest = 0.0, largest_fall = 0.0;
    for (size_t k = 1; k < v.size(); ++k) {
      fastest = std::max(fastest, v[k]);
      largest_fall = std::max(largest_fall, v[k - 1] - v[k]);
    }
    EXPECT_GT(fastest, 0.99 * v_max) << "the heel walked at its speed limit";
    EXPECT_EQ(v.back(), 0.0) << "the heel at rest at the end";
    std::cout << "heel_stop_time " << stop_time << " s: " << walks(*run) << " walks, fastest " << fastest
              << " m/s, largest fall " << largest_fall << " m/s in a cycle\n";
    if (stop_time > 0.0) {
      EXPECT_LE(largest_fall, v_max / stop_time * s.dt * (1.0 + 1e-9)) << "braked at v_max / heel_stop_time";
    } else {
      EXPECT_GT(largest_fall, 0.9 * v_max) << "stops within a cycle";
    }
  }
}

// The floating heel's lead over the real heel between the feet (summary.json's
// walking.max_body_lead): without a bound the paper model's body ran 0.81 m ahead of its
// feet walking 4 m behind it (the heel's 0.5 m/s per axis against the feet's half-length
// steps backward while they turn). max_heel_lead (2 steps by default, 1.5 here) holds the
// heel that far ahead, plus its braking distance (v_max^2 / (2 v_max / heel_stop_time)),
// and the walk still ends with the hand at its target.
TEST(Walking, AHeelLeadBoundKeepsTheBodyNearTheFeet) {
  Scenario s = shipped("walk_object_ahead");
  s.duration = 24.0;
  s.events[0].targets[0].second = Eigen::Vector3d(-4.0, 0.5, 0.75);
  auto lead_of = [](const ScenarioRun& run) { return summarize(run)["walking"]["max_body_lead"].get<double>(); };
  auto held_cycles = [](const ScenarioRun& run) {
    int held = 0;
    for (const Eigen::VectorXd& w : run.walking) held += (static_cast<std::uint32_t>(w[4]) & kHeelHeld) != 0;
    return held;
  };
  const double default_lead = s.walking.parameters.max_heel_lead;
  EXPECT_EQ(default_lead, 2.0);
  s.walking.parameters.max_heel_lead = 0.0;
  const auto free_run = run_scenario(s);
  EXPECT_EQ(held_cycles(*free_run), 0);
  const double length = free_run->walking_parameters.max_step_length;
  const double v_max = free_run->model->max_speeds()[free_run->model->virtual_dofs().heel_x];
  // Held when above the bound in one cycle (v_max dt later at most), braked to rest from there.
  auto bound = [&](double steps) {
    return steps * length + v_max * s.dt + 0.5 * v_max * s.walking.parameters.heel_stop_time;
  };
  EXPECT_GT(lead_of(*free_run), bound(2.0) + 0.1) << "unbounded, the body runs ahead";
  const Scenario from_file = parse_scenario(
      "name: w\nrobot: {builtin: paper}\nwalking: {enabled: true, max_heel_lead: 1.5}\n"
      "tasks: [{name: h, type: position, frame: l_hand_ref}]\n", "w.yaml", ".");
  EXPECT_EQ(from_file.walking.parameters.max_heel_lead, 1.5) << "walking.max_heel_lead read";
  const auto said = [](const ScenarioRun& r) {
    const std::vector<std::string> lines = describe_walking(summarize(r)["walking"]);
    return lines.size() > 1 ? lines[1] : std::string();
  };
  EXPECT_NE(said(*free_run).find("walking.max_heel_lead can bound it"), std::string::npos) << said(*free_run);
  for (const double steps : {default_lead, from_file.walking.parameters.max_heel_lead}) {
    s.walking.parameters.max_heel_lead = steps;
    const auto run = run_scenario(s);
    std::cout << "max body lead " << lead_of(*free_run) << " m free, " << lead_of(*run) << " m held beyond " << steps
              << " steps (bound " << bound(steps) << " m, " << held_cycles(*run) << " cycles held); footsteps "
              << free_run->footsteps.size() << " and " << run->footsteps.size() << "\n";
    EXPECT_GT(held_cycles(*run), 0) << steps;
    EXPECT_LE(lead_of(*run), bound(steps)) << steps;
    EXPECT_EQ(walks(*run), 1) << steps;
    EXPECT_EQ(final_walking(*run)[3], 0.0) << steps << ": still walking after " << run->footsteps.size() << " steps";
    EXPECT_LT(run->error.back()[run->element("l_hand")], 1e-3) << steps;
    std::ostringstream text;
    text << std::fixed << std::setprecision(2) << "(the floating heel from the real heel between them; held beyond "
         << steps << " steps)";
    EXPECT_NE(said(*run).find(text.str()), std::string::npos) << said(*run);
    // The report's walking plot shows the lead and when the heel was held.
    double plotted_lead = 0.0, plotted_held = 0.0;
    const nlohmann::json report = report_data(*run);  // kept: a range-for over a temporary's member dangles
    for (const auto& plot : report["plots"])
      if (plot["title"].get<std::string>().rfind("Walking", 0) == 0)
        for (const auto& series : plot["series"])
          for (const auto& v : series["values"]) {
            if (series["label"] == "body ahead of the feet") plotted_lead = std::max(plotted_lead, v.get<double>());
            if (series["label"] == "heel held") plotted_held = std::max(plotted_held, v.get<double>());
          }
    EXPECT_GT(plotted_lead, 0.8 * lead_of(*run)) << steps;  // the plot's samples, not every cycle
    EXPECT_LE(plotted_lead, lead_of(*run)) << steps;
    EXPECT_EQ(plotted_held, 1.0) << steps;
  }
}

// max_heel_lead below one step would release the heel only with the feet nearer than half
// a step, which a held heel beside the feet never lets happen: refused, as a NaN is.
TEST(Walking, AHeelLeadBoundBelowOneStepIsRefused) {
  const Model model = make_paper_model();
  for (const double lead : {0.5, std::nan("")}) {
    WalkingParameters p;
    p.max_heel_lead = lead;
    try {
      WalkingModule w(model, FootGeometry{}, p);
      ADD_FAILURE() << "no error for max_heel_lead " << lead;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("max_heel_lead must be >= 1"), std::string::npos) << e.what();
    }
  }
  for (const double lead : {0.0, -1.0, 1.0, 3.0}) {
    WalkingParameters p;
    p.max_heel_lead = lead;
    EXPECT_NO_THROW(WalkingModule(model, FootGeometry{}, p)) << lead;
  }
}

// Step widths and feet: the feet stand `spacing` apart beside the heel, so a step width
// range without the spacing never lets a walk end (NAO's feet are 0.10 m apart, H1's
// 0.41 m, the defaults allow 0.14-0.30 m: both stepped in place until the end). The library
// refuses such parameters; a scenario that does not give the widths scales them to its feet.
TEST(Walking, StepWidthsMustIncludeTheFootSpacing) {
  const Model model = make_paper_model();
  FootGeometry feet;
  for (const auto& [spacing, text] : std::vector<std::pair<double, std::string>>{{0.10, "0.1"}, {0.41, "0.41"}}) {
    feet.spacing = spacing;
    try {
      WalkingModule walking(model, feet, WalkingParameters{});
      ADD_FAILURE() << "spacing " << spacing << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("walking: the feet stand " + text +
                                           " m apart (foot spacing), outside the step widths [0.14, 0.3] m"),
                std::string::npos)
          << e.what();
    }
  }
  feet.spacing = 0.14;  // the bounds themselves are fine
  EXPECT_NO_THROW(WalkingModule(model, feet, WalkingParameters{}));
  // A scenario's own widths are kept, and checked with its line.
  try {
    run_scenario(parse_scenario("name: w\nrobot: {builtin: paper}\nduration: 1\nfrozen: [heel_x, heel_y, heel_yaw]\n"
                                "walking: {enabled: true, min_step_width: 0.2, max_step_width: 0.4}\n"
                                "tasks: [{name: h, type: position, frame: l_hand_ref}]\n",
                                "w.yaml", "."));
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("w.yaml:5: walking: the feet stand 0.18 m apart"), std::string::npos) << e.what();
  }
  // One width given, the other scaled: the message has both values, and says which the file
  // did not give (it said "must be positive (and max_step_width > min_step_width)").
  try {
    run_scenario(parse_scenario("name: w\nrobot: {builtin: paper}\nduration: 1\nfrozen: [heel_x, heel_y, heel_yaw]\n"
                                "walking: {enabled: true, max_step_width: 0.1}\n"
                                "tasks: [{name: h, type: position, frame: l_hand_ref}]\n",
                                "w.yaml", "."));
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("w.yaml:5: walking: max_step_width (0.1 m) must be above min_step_width "
                                         "(0.14 m) (not given, scaled to the robot's feet and height: min_step_width "
                                         "0.14, max_step_length 0.25, step_duration 0.6)"),
              std::string::npos)
        << e.what();
  }
  // Every WalkingParameters field is a scenario field (trigger_time was refused as unknown).
  const Scenario with_trigger_time = parse_scenario(
      "name: w\nrobot: {builtin: paper}\nduration: 1\nwalking: {enabled: true, trigger_time: 0.2}\n"
      "tasks: [{name: h, type: position, frame: l_hand_ref}]\n",
      "w.yaml", ".");
  EXPECT_EQ(with_trigger_time.walking.parameters.trigger_time, 0.2);
}

// The support to balance over during a walk: both feet standing beside the heel of q (the
// floating heel), whatever the feet do; a q of another size is a ConfigError.
TEST(Walking, PlannedSupportStandsBesideTheHeelOfQ) {
  const Model model = make_paper_model();
  const WalkingModule walking(model, FootGeometry{}, WalkingParameters{});
  VectorXd q = model.home();
  const VirtualDofs& v = model.virtual_dofs();
  q[v.heel_x] = 0.7;
  q[v.heel_y] = -0.2;
  q[v.heel_yaw] = 1.1;
  const SupportPolygon planned = walking.planned_support(q);
  const SupportPolygon standing = SupportPolygon::standing(Vector2(0.7, -0.2), 1.1, FootGeometry{});
  EXPECT_LT((planned.centroid() - standing.centroid()).norm(), 1e-12);
  EXPECT_NEAR(planned.area(), standing.area(), 1e-12);
  EXPECT_GT((planned.centroid() - walking.support().centroid()).norm(), 0.5);  // not the feet at the origin
  // Standing, the support to balance over is the feet's (planned only while walking).
  EXPECT_EQ(walking.balance_support(q).centroid(), walking.support().centroid());
  try {
    walking.planned_support(VectorXd::Zero(3));
    ADD_FAILURE() << "accepted a q of 3 entries";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("q has 3 entries, the model 21 dofs"), std::string::npos) << e.what();
  }
}

// An attitude target a whole turn from the hand's angles is where the hand is: the walking
// module's distance to it is the wrapped difference (0), not 2 pi, which, not falling, read
// as a stalled task and started a walk.
TEST(Walking, AnAttitudeTargetAWholeTurnAwayIsReachedWithoutWalking) {
  const auto run = run_scenario(parse_scenario(
      "name: w\nrobot: {builtin: paper}\nduration: 3\nfrozen: [heel_x, heel_y, heel_yaw]\n"
      "walking: {enabled: true}\n"
      "tasks: [{name: a, type: attitude, frame: l_hand_ref}]\n"
      "timeline: [{t: 0.1, activate: [a], relative_targets: {a: [0, 0, 6.283185307179586]}}]\n",
      "w.yaml", "."));
  EXPECT_EQ(walks(*run), 0);
  EXPECT_TRUE(run->footsteps.empty());
  EXPECT_LT(run->error.back()[run->element("a")], 1e-6);
}

/// NAO (feet 0.10 m apart) and H1 (0.41 m): the hand that walks and the ankles the feet are
/// measured from.
struct WalkingRobot {
  std::string id, hand, left_foot, right_foot;
};
const WalkingRobot kNarrowAndWideFeet[] = {{"nao", "l_gripper", "l_ankle", "r_ankle"},
                                           {"h1", "left_elbow_link", "left_ankle_link", "right_ankle_link"}};

/// 16 s of walking: the robot's hand (element "hand") sent to `offset` [m] from where it is;
/// `feet` gives the feet's size fields, `extra` more scenario lines, `walking` more fields of
/// the walking section (", max_step_length: 0.25").
Scenario walk_scenario(const WalkingRobot& r, const std::string& feet, const std::string& offset,
                       const std::string& extra = "", const std::string& walking = "") {
  const wbm_test::ShippedModel& m = wbm_test::shipped_model(r.id);
  std::string legs;
  for (const std::string& leg : m.options.legs) legs += (legs.empty() ? "" : ", ") + leg;
  return parse_scenario(
      "name: walk\nrobot: {urdf: '" + m.path + "', legs: [" + legs + "]}\nduration: 16\n"
      "frozen: [heel_x, heel_y, heel_yaw]\nwalking: {enabled: true" + walking + "}\n" + extra + "feet: {" + feet +
          "left_frame: " + r.left_foot + ", right_frame: " + r.right_foot + "}\n"
          "tasks: [{name: hand, type: position, frame: " + r.hand + ", filter: {bandwidth: 3, max_speed: 0.4}}]\n"
          "timeline: [{t: 0.2, activate: [hand], relative_targets: {hand: [" + offset + "]}}]\n",
      "walk.yaml", ".");
}

TEST(Walking, RobotsWithNarrowAndWideFeetFinishTheirWalk) {
  for (const WalkingRobot& r : kNarrowAndWideFeet) {
    const auto run = run_scenario(walk_scenario(r, "length: 0.15, width: 0.07, ", "1.5, 0.4, 0.0"));
    EXPECT_EQ(walks(*run), 1) << r.id;
    EXPECT_EQ(final_walking(*run)[3], 0.0) << r.id << ": still walking after " << run->footsteps.size() << " steps";
    EXPECT_LT(run->error.back()[run->element("hand")], 1e-3) << r.id;
  }
}

// A walk that a stalled error alone starts (no joint-limit or cost trigger) walks: the
// stall that triggered it also ended it in the same cycle, before the heel was released
// (0 footsteps in 3 walks, the hand 1.5 m short; Darwin-OP with balance, whose joint limits
// and cost did not trigger first, stopped 0.5-0.9 m short of reachable targets).
TEST(Walking, AStallAloneStartsAWalkThatMoves) {
  const auto run = run_scenario(parse_scenario(
      "name: w\nrobot: {builtin: paper}\nduration: 24\nfrozen: [heel_x, heel_y, heel_yaw]\n"
      "walking: {enabled: true, cost_threshold: 0, trigger_on_joint_limit: false}\n"
      "tasks: [{name: hand, type: position, frame: l_hand_ref, filter: {bandwidth: 3, max_speed: 0.4}}]\n"
      "timeline: [{t: 0.2, activate: [hand], relative_targets: {hand: [1.92, 0, 0]}}]\n",
      "w.yaml", "."));
  EXPECT_EQ(walks(*run), 1);
  EXPECT_GE(run->footsteps.size(), 5u);
  EXPECT_EQ(final_walking(*run)[3], 0.0);
  EXPECT_LT(run->error.back()[run->element("hand")], 1e-3);
}

// Every shipped element says the unit of its rows: walking compares each row's error with
// the tolerance of its unit.
TEST(RowUnits, LengthsAndAnglesAsTheElementsRowsAre) {
  const Model model = make_paper_model();
  const auto units = [](const TaskElement& element) {
    std::string text;
    for (int row = 0; row < element.dim(); ++row) text += element.row_unit(row) == RowUnit::kAngle ? 'a' : 'l';
    return text;
  };
  EXPECT_EQ(units(PositionTask(model, "p", "l_hand_ref")), "lll");
  EXPECT_EQ(units(CenterOfMassTask(model, "c", "heel")), "lll");
  EXPECT_EQ(units(AxisTask(model, "x", "l_hand_ref")), "aa");
  EXPECT_EQ(units(AttitudeTask(model, "t", "l_hand_ref")), "aaa");
  EXPECT_EQ(units(JointTask(model, "j", {"l_elbow", "upper_body_z", "heel_yaw", "heel_x"})), "alal");
}

/// Whether a walk starts within 3 s on the paper model while one joint row's target lies
/// `beyond` its upper limit: the dof starts 1 mm or mrad below it and is clamped there, and the
/// row's error stays at `beyond` (the null-space cost trigger off: near a limit it is high).
bool walks_for_joint_error(const std::string& dof, double beyond, double position_tolerance, double angle_tolerance) {
  const Model model = make_paper_model();
  Controller c(model);
  c.add_task(std::make_unique<JointTask>(model, "j", std::vector<std::string>{dof}), {3.0, 0.4, 2});
  const int d = model.dof_index(dof);
  Eigen::VectorXd q = model.home();
  q[d] = model.dof(d).upper - 0.001;
  c.reset(q);
  Command cmd = c.make_command();
  cmd.task_active.setConstant(true);
  cmd.targets[0] = model.dof(d).upper + beyond;
  WalkingParameters p;
  p.cost_threshold = 0.0;
  p.position_tolerance = position_tolerance;
  p.angle_tolerance = angle_tolerance;
  WalkingModule walking(model, FootGeometry{}, p);
  ControllerStatus last;
  for (int k = 0; k < 1500; ++k) {
    if ((walking.update(c, last, k * 0.002, 0.002, cmd) & kWalkTriggered) != 0) return true;
    last = c.update(cmd, 0.002);
  }
  return false;
}

// A row's error counts against the tolerance of its unit: 3 mrad left on the elbow (an
// angle) starts a walk only with angle_tolerance below it, whatever position_tolerance is;
// 3 mm left on upper_body_z (a length) only with position_tolerance below it. One tolerance
// for both (error_tolerance) compared millimetres with radians.
TEST(Walking, ARowsErrorCountsAgainstTheToleranceOfItsUnit) {
  EXPECT_FALSE(walks_for_joint_error("l_elbow", 0.003, 0.005, 0.005));
  EXPECT_TRUE(walks_for_joint_error("l_elbow", 0.003, 0.005, 0.002));
  EXPECT_FALSE(walks_for_joint_error("l_elbow", 0.003, 0.001, 0.005));
  EXPECT_FALSE(walks_for_joint_error("upper_body_z", 0.003, 0.005, 0.005));
  EXPECT_TRUE(walks_for_joint_error("upper_body_z", 0.003, 0.002, 0.005));
  EXPECT_FALSE(walks_for_joint_error("upper_body_z", 0.003, 0.005, 0.001));
  for (const auto& [position, angle] : {std::pair{0.0, 0.005}, std::pair{0.005, -1.0}, std::pair{std::numeric_limits<double>::quiet_NaN(), 0.005}}) {
    WalkingParameters p;
    p.position_tolerance = position;
    p.angle_tolerance = angle;
    try {
      WalkingModule(make_paper_model(), FootGeometry{}, p);
      ADD_FAILURE() << position << " " << angle << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(position > 0.0 ? "angle_tolerance" : "position_tolerance"), std::string::npos)
          << e.what();
    }
  }
}

// A walk that max_steps ends says so: the heel is frozen where the body went and the feet
// stay behind it, which the summary gives (and the balance advice points to, instead of a
// range to widen: Bioloid 2.6 m from its target was told to widen upper_body_y_range to
// [-1.02, 0.08] for a 0.26 m robot).
TEST(Walking, AWalkEndedByMaxStepsSaysSoAndHowFarTheFeetAreBehind) {
  Scenario s = shipped("walk_object_ahead");
  s.walking.parameters.max_steps = 3;
  s.balance.enabled = true;
  const auto run = run_scenario(s);
  const nlohmann::json summary = summarize(*run);
  EXPECT_GE(summary["walking"]["walks_at_step_limit"].get<int>(), 1) << summary["walking"].dump();
  EXPECT_EQ(summary["walking"]["steps"]["max_steps"].get<int>(), 3);
  EXPECT_GT(summary["walking"]["feet_from_body"].get<double>(), 0.1) << summary["walking"].dump();
  const auto full = run_scenario(shipped("walk_object_ahead"));
  const nlohmann::json ended = summarize(*full);
  EXPECT_EQ(ended["walking"]["walks_at_step_limit"].get<int>(), 0);
  EXPECT_LT(ended["walking"]["feet_from_body"].get<double>(), 0.02);
}

// The walking defaults are the paper model's (upper body 0.6 m up, feet 0.18 m apart):
// scaled to a robot's height and feet, NAO (0.34 m at its root) no longer takes the paper
// model's 0.25 m strides. The paper model keeps the defaults exactly; a base on the ground
// (root height 0) keeps the length and duration.
TEST(Walking, TheDefaultsScaleToTheRobotsHeightAndFeet) {
  const WalkingParameters defaults;
  const WalkingParameters paper = scaled_walking_parameters(make_paper_model(), FootGeometry{});
  EXPECT_EQ(paper.max_step_length, defaults.max_step_length);
  EXPECT_EQ(paper.step_duration, defaults.step_duration);
  EXPECT_EQ(paper.position_tolerance, defaults.position_tolerance);
  EXPECT_EQ(paper.min_step_width, defaults.min_step_width);
  EXPECT_EQ(paper.max_step_width, defaults.max_step_width);
  for (const char* id : {"nao", "h1", "g1_29dof"}) {
    const Model model = wbm_test::shipped_model(id).load();
    const double height = model.dof(model.virtual_dofs().ub_z).upper;
    FootGeometry feet;
    feet.spacing = 0.5 * height;
    const WalkingParameters p = scaled_walking_parameters(model, feet);
    EXPECT_NEAR(p.max_step_length, 0.25 * height / 0.6, 1e-12) << id;
    EXPECT_NEAR(p.step_duration, 0.6 * std::sqrt(height / 0.6), 1e-12) << id;
    EXPECT_NEAR(p.position_tolerance, 0.005 * height / 0.6, 1e-15) << id;
    EXPECT_EQ(p.angle_tolerance, defaults.angle_tolerance) << id;
    EXPECT_NEAR(p.min_step_width, std::max(0.14 * feet.spacing / 0.18, 1.1 * feet.width), 1e-12) << id;
    EXPECT_NEAR(p.max_step_width, 0.30 * feet.spacing / 0.18, 1e-12) << id;
    EXPECT_NO_THROW(WalkingModule(model, feet, p)) << id;
    // The heel's speed scales alike (the paper model's 0.5 m/s at 0.6 m), so that the
    // floating heel does not outrun the feet of a small robot.
    const VirtualDofs& v = model.virtual_dofs();
    EXPECT_NEAR(model.dof(v.heel_x).max_speed, 0.5 * std::sqrt(height / 0.6), 1e-12) << id;
    EXPECT_NEAR(model.dof(v.heel_y).max_speed, 0.5 * std::sqrt(height / 0.6), 1e-12) << id;
  }
  EXPECT_EQ(make_paper_model().dof(make_paper_model().virtual_dofs().heel_x).max_speed, 0.5);
  EXPECT_EQ(default_virtual_dofs(0.0)[0].max_speed, 0.5);  // a base on the ground
  // The smaller width keeps the feet apart (a tenth of their width between them), but not
  // beyond where they stand: Bioloid's feet, 0.05 m wide and 0.056 m apart, got 0.044 m and
  // landed on each other in half their steps.
  const Model paper_model = make_paper_model();
  for (const auto& [spacing, width, expected] : {std::tuple{0.056, 0.05, 0.055}, std::tuple{0.056, 0.053, 0.056},
                                                  std::tuple{0.18, 0.12, 0.14}, std::tuple{0.10, 0.02, 0.14 * 0.10 / 0.18}}) {
    FootGeometry feet;
    feet.spacing = spacing;
    feet.width = width;
    const WalkingParameters p = scaled_walking_parameters(paper_model, feet);
    EXPECT_NEAR(p.min_step_width, expected, 1e-12) << spacing << " " << width;
    EXPECT_NO_THROW(WalkingModule(paper_model, feet, p));
  }
  const wbm_test::ShippedModel& dual_arm = wbm_test::shipped_model("dual_arm");
  const Model on_the_ground = dual_arm.load();
  ASSERT_EQ(on_the_ground.dof(on_the_ground.virtual_dofs().ub_z).upper, 0.0);
  const WalkingParameters ground = scaled_walking_parameters(on_the_ground, FootGeometry{});
  EXPECT_EQ(ground.max_step_length, defaults.max_step_length);
  EXPECT_EQ(ground.step_duration, defaults.step_duration);
}

// A scenario that does not give the step length and duration walks with the scaled ones
// (NAO: at most 0.14 m ahead of the support foot, a step every 0.45 s); given, they are kept.
TEST(Walking, AScenarioWalksWithTheScaledStepsUnlessItGivesItsOwn) {
  const WalkingRobot& nao = kNarrowAndWideFeet[0];
  const Model model = wbm_test::shipped_model(nao.id).load();
  const double height = model.dof(model.virtual_dofs().ub_z).upper;
  ASSERT_NEAR(height, 0.336, 0.01);
  // The largest step ahead of the support foot (the previous footstep, or the other foot
  // standing beside the heel at the origin, facing along x) and the time between footsteps.
  auto steps = [&](const ScenarioRun& run) {
    double longest = run.footsteps.empty() ? 0.0 : run.footsteps[0].pose.position.x(), first_interval = 0.0;
    for (size_t i = 1; i < run.footsteps.size(); ++i) {
      const FootPose& support = run.footsteps[i - 1].pose;
      const Vector2 d = run.footsteps[i].pose.position - support.position;
      longest = std::max(longest, std::cos(support.yaw) * d.x() + std::sin(support.yaw) * d.y());
      if (i == 2) first_interval = run.footsteps[i].time - run.footsteps[i - 1].time;
    }
    return std::make_pair(longest, first_interval);
  };
  const auto scaled = run_scenario(walk_scenario(nao, "length: 0.15, width: 0.07, ", "1.5, 0.4, 0.0"));
  ASSERT_GE(scaled->footsteps.size(), 8u);
  const auto [longest, interval] = steps(*scaled);
  EXPECT_NEAR(longest, 0.25 * height / 0.6, 1e-9);
  EXPECT_NEAR(interval, 0.6 * std::sqrt(height / 0.6), 1.5e-3);  // on the 1 ms grid
  EXPECT_EQ(final_walking(*scaled)[3], 0.0);
  EXPECT_LT(scaled->error.back()[scaled->element("hand")], 1e-3);
  const auto given = run_scenario(walk_scenario(nao, "length: 0.15, width: 0.07, ", "1.5, 0.4, 0.0", "",
                                                ", max_step_length: 0.25, step_duration: 0.6"));
  const auto [given_longest, given_interval] = steps(*given);
  // Longer than the scaled limit, within the given one (the heel, at NAO's 0.37 m/s, does
  // not get a whole 0.25 m ahead in one step's time).
  EXPECT_GT(given_longest, 0.25 * height / 0.6 + 0.05);
  EXPECT_LE(given_longest, 0.25 + 1e-9);
  EXPECT_NEAR(given_interval, 0.6, 1.5e-3);
  // The position tolerance too: scaled, unless given.
  EXPECT_NEAR(scaled->walking_parameters.position_tolerance, 0.005 * height / 0.6, 1e-15);
  EXPECT_NEAR(given->walking_parameters.position_tolerance, 0.005 * height / 0.6, 1e-15);
  const auto tolerance_given = run_scenario(walk_scenario(nao, "length: 0.15, width: 0.07, ", "1.5, 0.4, 0.0", "",
                                                          ", position_tolerance: 0.004, angle_tolerance: 0.01"));
  EXPECT_EQ(tolerance_given->walking_parameters.position_tolerance, 0.004);
  EXPECT_EQ(tolerance_given->walking_parameters.angle_tolerance, 0.01);
  // summary.json says which tolerances the walk used.
  const nlohmann::json trigger = summarize(*tolerance_given)["walking"]["trigger"];
  EXPECT_EQ(trigger["position_tolerance"].get<double>(), 0.004) << trigger.dump();
  EXPECT_EQ(trigger["angle_tolerance"].get<double>(), 0.01) << trigger.dump();
  EXPECT_NEAR(summarize(*scaled)["walking"]["trigger"]["position_tolerance"].get<double>(), 0.005 * height / 0.6, 1e-15);
}

// The tolerance of one number for metres and radians is gone: a scenario giving it is told
// what replaced it, on its line.
TEST(Walking, TheOldErrorToleranceNamesItsReplacements) {
  try {
    parse_scenario("name: w\nrobot: {builtin: paper}\nduration: 1\nwalking:\n  enabled: true\n  error_tolerance: 0.01\n"
                   "tasks: [{name: hand, type: position, frame: l_hand_ref}]\n",
                   "w.yaml", ".");
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("w.yaml:6: walking.error_tolerance: replaced by position_tolerance [m]"),
              std::string::npos)
        << e.what();
  }
}

// A walk to a floating heel more than two steps away faces the way there and walks forward,
// then turns to the heel's yaw. Romeo sent 2.8 m behind-left, its heel turned to face left,
// sidestepped most of the way: still walking at 16 s after 17 footsteps, none of full length;
// now done after 15 at 13.8 s, three of full length (the helpers' 72 walks on nine robots:
// never more footsteps, the walks done 12 % sooner in all; full Romeo 22 -> 15 footsteps).
// The rule is checked on the paper's unbounded planner (max_heel_lead 0), as it was written;
// with the default bound (two steps) the body is held nearer the feet, so the first forward
// steps are shorter (0.28-0.31 m of 0.37 against 0.37), and the walk ends after as many
// footsteps.
TEST(Walking, AFarWalkFacesTheWayThere) {
  const WalkingRobot romeo{"romeo_small", "l_gripper", "l_ankle", "r_ankle"};
  auto forward_steps = [](const ScenarioRun& run, double share) {
    int n = 0;
    for (size_t i = 1; i < run.footsteps.size(); ++i) {
      const FootPose& support = run.footsteps[i - 1].pose;
      const Vector2 d = run.footsteps[i].pose.position - support.position;
      n += std::cos(support.yaw) * d.x() + std::sin(support.yaw) * d.y() > share * run.walking_parameters.max_step_length;
    }
    return n;
  };
  const auto run = run_scenario(walk_scenario(romeo, "length: 0.22, width: 0.11, ", "-2.81, 0.84, 0.0", "",
                                              ", max_heel_lead: 0"));
  EXPECT_EQ(final_walking(*run)[3], 0.0) << "still walking after " << run->footsteps.size() << " steps";
  EXPECT_LT(run->error.back()[run->element("hand")], 1e-3);
  EXPECT_GE(forward_steps(*run, 0.9), 3) << run->footsteps.size() << " footsteps";
  const auto bounded = run_scenario(walk_scenario(romeo, "length: 0.22, width: 0.11, ", "-2.81, 0.84, 0.0"));
  EXPECT_EQ(final_walking(*bounded)[3], 0.0) << "still walking after " << bounded->footsteps.size() << " steps";
  EXPECT_LT(bounded->error.back()[bounded->element("hand")], 1e-3);
  EXPECT_LE(bounded->footsteps.size(), run->footsteps.size());
  EXPECT_GE(forward_steps(*bounded, 0.75), 3) << bounded->footsteps.size() << " footsteps";
}

// The default bound on the heel's lead (two steps) leaves the shipped walks, whose body
// stays nearer its feet, exactly as the paper's unbounded planner walks them.
TEST(Walking, TheHeelLeadBoundLeavesTheShippedWalksAlone) {
  for (const std::string name : {"walk_object_ahead", "walk_object_behind"}) {
    Scenario s = shipped(name);
    const auto bounded = run_scenario(s);
    s.walking.parameters.max_heel_lead = 0.0;
    const auto free_run = run_scenario(s);
    int held = 0;
    for (const Eigen::VectorXd& w : bounded->walking) held += (static_cast<std::uint32_t>(w[4]) & kHeelHeld) != 0;
    EXPECT_EQ(held, 0) << name;
    ASSERT_EQ(bounded->q.size(), free_run->q.size()) << name;
    EXPECT_EQ(bounded->q.back(), free_run->q.back()) << name;
    EXPECT_EQ(bounded->footsteps.size(), free_run->footsteps.size()) << name;
  }
}

// Walking with balance on: during a walk the upper body is balanced over the feet as
// planned beside the floating heel (WalkingModule::planned_support). Balanced over the feet
// left behind, the upper-body shift and the floating heel fought each other: the paper
// model, NAO and H1 stepped in place for as long as they ran (38, 38 and 38 footsteps in
// 24 s, the hand long at its target), and the walk never ended.
TEST(Walking, WithBalanceTheWalkEnds) {
  auto check = [](const Scenario& s, const std::string& hand, const std::string& id) {
    const auto run = run_scenario(s);
    EXPECT_EQ(walks(*run), 1) << id;
    EXPECT_EQ(final_walking(*run)[3], 0.0) << id << ": still walking after " << run->footsteps.size() << " steps";
    // Not stepping in place: at most three quarters of the steps the run's time allows (the
    // three stepped in every step's time), the last well before the end (paper 6 at 4.7 s of
    // 14 s, NAO 15 at 7.9 s of 16 s with its 0.14 m steps, H1 7 at 6.5 s of 16 s).
    EXPECT_LE(static_cast<double>(run->footsteps.size()), 0.75 * s.duration / run->walking_parameters.step_duration) << id;
    ASSERT_FALSE(run->footsteps.empty()) << id;
    EXPECT_LT(run->footsteps.back().time, s.duration - 3.0) << id;
    EXPECT_LT(run->error.back()[run->element(hand)], 1e-3) << id;
    EXPECT_GT(run->balance.back()[6], 0.05) << id << ": the centre of mass over the feet at the end";
  };
  Scenario paper = shipped("walk_object_ahead");
  paper.balance.enabled = true;
  check(paper, "l_hand", "paper");
  // NAO on feet of its size: the default ones, 0.12 m wide, overlap where its feet stand
  // 0.10 m apart (the smallest step width is then the spacing: 16 steps instead of 15).
  for (const WalkingRobot& r : kNarrowAndWideFeet)
    check(walk_scenario(r, r.id == "nao" ? "length: 0.15, width: 0.07, " : "", "-1.4, 0.6, 0.0",
                        "balance: {enabled: true}\n"),
          "hand", r.id);
}

TEST(Walking, TargetMovingWhileWalking) {
  Scenario s = shipped("walk_object_ahead");
  s.duration = 20.0;
  ScenarioEvent move;
  move.time = 2.0;
  move.targets.emplace_back("l_hand", Eigen::Vector3d(1.2, -0.6, 0.8));
  s.events.push_back(move);
  const auto run = run_scenario(s);
  EXPECT_GE(walks(*run), 1);
  EXPECT_EQ(final_walking(*run)[3], 0.0);
  EXPECT_LE(static_cast<int>(run->footsteps.size()), s.walking.parameters.max_steps);
  EXPECT_LT(run->error.back()[run->element("l_hand")], 0.01);
}

// Targets out of reach: the hands stop short and the robot comes to rest. Before, the arm
// chattered for as long as the target stayed: the null-space motion (the joint-limit
// criterion bending the stretched elbow) grew the damped task part until it crossed a speed
// limit, where the null space was dropped at once (3,000 rad/s^2 every 50 ms on the paper
// model, with or without balance); and G1 flipped between two configurations every cycle
// (25,000 rad/s^2) under an error feedback of 1.6 m/s, now bounded by the hands' trajectory
// speed (error clamping).
TEST(Scenarios, TargetsOutOfReachSettleWithoutChattering) {
  const std::string paper =
      "name: far\nrobot: {builtin: paper}\ndt: 0.001\nduration: 4\nfrozen: [heel_x, heel_y, heel_yaw]\n"
      "tasks: [{name: l, type: position, frame: l_hand_ref, filter: {bandwidth: 4, max_speed: 0.4}},\n"
      "        {name: r, type: position, frame: r_hand_ref, filter: {bandwidth: 4, max_speed: 0.4}}]\n"
      "timeline: [{t: 0.2, activate: [l, r], targets: {l: [0.9, 0.2, 0.8], r: [0.9, -0.2, 0.8]}}]\n";
  const std::string g1 = "name: far\nrobot: {urdf: '" + wbm_test::shipped_model("g1_29dof").path +
                         "', root: pelvis, legs: [left_hip_pitch_link, right_hip_pitch_link]}\n"
                         "dt: 0.002\nduration: 4\nfrozen: [heel_x, heel_y, heel_yaw]\n"
                         "feet: {length: 0.20, width: 0.08, left_frame: left_ankle_roll_link, "
                         "right_frame: right_ankle_roll_link}\n"
                         "tasks: [{name: l, type: position, frame: left_rubber_hand, filter: {bandwidth: 4, max_speed: 0.4}},\n"
                         "        {name: r, type: position, frame: right_rubber_hand, filter: {bandwidth: 4, max_speed: 0.4}}]\n"
                         "timeline: [{t: 0.2, activate: [l, r], relative_targets: {l: [0.5, 0, 0.2], r: [0.5, 0, 0.2]}}]\n";
  const std::string balance = "balance: {enabled: true, compensate: true, gain: 4.0}\n";
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"paper", paper}, {"paper with balance", paper + balance}, {"G1 with balance", g1 + balance}}) {
    const auto run = run_scenario(parse_scenario(text, "far.yaml", "."));
    EXPECT_GT(run->error.back()[run->element("l")], 0.02) << name << ": the target should be out of reach";
    const auto [acceleration, dof] = largest_acceleration_after(*run, 2.5);
    EXPECT_LT(acceleration, 10.0) << name << ": " << dof << " still accelerates at " << acceleration
                                  << " rad/s^2 in the last 1.5 s";
  }
}

// Out of reach with dofs held at their limits: G1 23-dof with balance, the hands crossed
// (0.6 m to the other side) or straight up. Before, a shoulder joint was released from its
// limit and, the jerk limit scaling the null space down at that instant, driven back into
// it, again every 20 ms for as long as the target stayed (3,900 and 1,200 rad/s^2 at 10 s).
TEST(Scenarios, DofsHeldAtTheirLimitsComeToRest) {
  const std::string g1 = "name: held\nrobot: {urdf: '" + wbm_test::shipped_model("g1_23dof").path +
                         "', legs: [left_hip_pitch_link, right_hip_pitch_link]}\n"
                         "dt: 0.002\nduration: 10\nfrozen: [heel_x, heel_y, heel_yaw]\n"
                         "feet: {length: 0.20, width: 0.08, left_frame: left_ankle_roll_link, "
                         "right_frame: right_ankle_roll_link}\n"
                         "balance: {enabled: true, compensate: true, gain: 4.0}\n"
                         "tasks: [{name: l, type: position, frame: left_wrist_roll_rubber_hand, "
                         "filter: {bandwidth: 4, max_speed: 0.4}},\n"
                         "        {name: r, type: position, frame: right_wrist_roll_rubber_hand, "
                         "filter: {bandwidth: 4, max_speed: 0.4}}]\n";
  for (const auto& [name, targets] : std::vector<std::pair<std::string, std::string>>{
           {"crossed", "{l: [0.3, -0.6, 0.1], r: [0.3, 0.6, 0.1]}"},
           {"straight up", "{l: [0, 0, 0.8], r: [0, 0, 0.8]}"}}) {
    const auto run = run_scenario(parse_scenario(
        g1 + "timeline: [{t: 0.2, activate: [l, r], relative_targets: " + targets + "}]\n", "held.yaml", "."));
    EXPECT_GT(run->error.back()[run->element("r")], 0.02) << name << ": the target should be out of reach";
    const auto [acceleration, dof] = largest_acceleration_after(*run, 8.5);
    EXPECT_LT(acceleration, 10.0) << name << ": " << dof << " still accelerates at " << acceleration
                                  << " rad/s^2 in the last 1.5 s";
  }
}

// A joint without limits at a singularity: a two-link arm whose continuous elbow
// straightens towards a target out of reach. With the damping of sigma_min alone the
// damped step overshot the stretched configuration and the elbow swung through it and back
// every cycle (4,400 rad/s^2); the solver now raises the damping where q_dot turns back
// under an unchanged command, and the arm comes to rest.
TEST(Scenarios, AJointWithoutLimitsComesToRestAtASingularity) {
  const Scenario s = parse_scenario(
      "name: stretch\nrobot: {urdf: '" + wbm_test::source_path("tests/data/continuous_elbow.urdf") +
          "', fixed_base: true}\n"
          "dt: 0.002\nduration: 6\nrecord_every: 1\ninitial: {elbow: -0.5, shoulder: -0.5}\n"
          "tasks: [{name: tool, type: position, frame: tool, filter: {bandwidth: 4, max_speed: 0.4}}]\n"
          "timeline: [{t: 0.1, activate: [tool], relative_targets: {tool: [0.6, 0, 0.3]}}]\n",
      "stretch.yaml", ".");
  const auto run = run_scenario(s);
  EXPECT_GT(run->error.back()[run->element("tool")], 0.3);  // out of reach
  const auto [acceleration, dof] = largest_acceleration_after(*run, 4.5);
  EXPECT_LT(acceleration, 10.0) << dof << " still accelerates at " << acceleration << " rad/s^2 in the last 1.5 s";
  int raised = 0;
  for (const std::uint32_t flags : run->flags) raised += (flags & kDampingRaised) ? 1 : 0;
  EXPECT_GT(raised, 0);
  // The target back within reach, 2 cm from the stretched arm's end: tracked as closely as
  // without the raise (0.058 mm; the arm's 3 rows on 2 dofs keep it damped, and a raise
  // that held at full strength left 0.23 mm), since the raise shrinks with the command.
  Scenario back = s;
  ScenarioEvent move;
  move.time = 3.0;
  move.relative_targets.emplace_back("tool", Eigen::Vector3d(-0.02, 0.0, -0.01));
  back.events.push_back(move);
  back.duration = 10.0;
  const auto again = run_scenario(back);
  EXPECT_LT(again->error.back()[again->element("tool")], 1e-4);
}

// A robot whose joints are all continuous (NimbRo-OP's URDF, every joint without position
// limits): summary.json has no min_distance_to_limit and the report says there is none.
// Before, both gave 0 at dof 0 (heel_x, 10 m from its limits), read as a dof on its limit.
TEST(Scenarios, NoPositionLimitsNoDistanceToALimit) {
  std::string xml = wbm_test::read_file(wbm_test::source_path("tests/data/continuous_elbow.urdf"));
  const std::string shoulder = "type=\"revolute\">";
  const std::string range = "lower=\"-2.5\" upper=\"2.5\" ";
  ASSERT_NE(xml.find(shoulder), std::string::npos);
  ASSERT_NE(xml.find(range), std::string::npos);
  xml.replace(xml.find(shoulder), shoulder.size(), "type=\"continuous\">");
  xml.erase(xml.find(range), range.size());
  const std::string file = testing::TempDir() + "wbm_all_continuous.urdf";
  std::ofstream(file) << xml;
  const std::string rest = "duration: 0.1\ntasks: [{name: tool, type: position, frame: tool}]\n";
  const auto free = run_scenario(
      parse_scenario("name: c\nrobot: {urdf: '" + file + "', fixed_base: true}\n" + rest, "c.yaml", "."));
  EXPECT_FALSE(summarize(*free).contains("min_distance_to_limit")) << summarize(*free)["min_distance_to_limit"];
  const nlohmann::json report = report_data(*free);  // kept: a range-for over a temporary's member dangles
  int rows = 0;
  for (const auto& row : report["summary"])
    if (row[0] == "min distance to a joint limit") {
      EXPECT_EQ(row[1], "none: no joint has position limits");
      ++rows;
    }
  EXPECT_EQ(rows, 1);
  std::remove(file.c_str());
  // The file as it is: the shoulder's distance to its limits.
  const auto limited = run_scenario(parse_scenario(
      "name: l\nrobot: {urdf: '" + wbm_test::source_path("tests/data/continuous_elbow.urdf") + "', fixed_base: true}\n" + rest,
      "l.yaml", "."));
  const nlohmann::json summary = summarize(*limited);
  ASSERT_TRUE(summary.contains("min_distance_to_limit"));
  EXPECT_EQ(summary["min_distance_to_limit"]["dof"], "shoulder");
  EXPECT_NEAR(summary["min_distance_to_limit"]["value"].get<double>(), 2.5, 0.1);
  // The report's row has the unit and three digits ("2.5 rad (shoulder)", not "2.500000").
  const nlohmann::json limited_report = report_data(*limited);
  int found = 0;
  for (const auto& row : limited_report["summary"]) {
    if (row[0] == "min distance to a joint limit") {
      EXPECT_NE(row[1].get<std::string>().find(" rad (shoulder)"), std::string::npos) << row[1];
      ++found;
    }
  }
  EXPECT_EQ(found, 1);
}

// A gripper's joint task while the arm is stretched towards a target out of reach: the
// finger (5 cm stroke, outside the tool's chain) is a block of the task matrix of its own.
// With one damping for all rows, the arm's singularity damped the finger's row too and the
// damped projector let the joint-limit criterion's gradient through to it: the finger
// stopped 5.4 mm short of its target (as OpenArm's, 6.75 mm: docs/solver.md). Damped by its
// own singular value alone (0.05 m, above the threshold: not at all) it is met exactly.
TEST(Scenarios, AGripperStaysExactWhileTheArmIsDamped) {
  const auto run = run_scenario(parse_scenario(
      "name: grip\nrobot: {urdf: '" + wbm_test::source_path("tests/data/gripper_arm.urdf") +
          "', fixed_base: true}\n"
          "dt: 0.002\nduration: 6\ninitial: {elbow: -0.8, shoulder_pitch: -0.3, finger_slide: 0.01}\n"
          "tasks: [{name: tool, type: position, frame: tool, filter: {bandwidth: 4, max_speed: 0.4}},\n"
          "        {name: grip, type: joints, dofs: [finger_slide], filter: {bandwidth: 4, max_speed: 0.05}}]\n"
          "timeline: [{t: 0.1, activate: [tool, grip], relative_targets: {tool: [0.8, 0, 0.3]}, "
          "targets: {grip: [0.045]}}]\n",
      "grip.yaml", "."));
  EXPECT_GT(run->error.back()[run->element("tool")], 0.3);  // out of reach
  EXPECT_TRUE(run->flags.back() & kDamped);
  EXPECT_LT(run->error.back()[run->element("grip")], 1e-4);
}

// The dual-arm robot on its fixed base, the torso lift frozen: the arms share no free dof.
// The left tool is sent out of reach, the right tool to a target within reach. With one
// damping and one speed scaling for all rows, the left arm's damped rates (at their speed
// limits) scaled the right arm's task part down and the damped projector let the
// joint-limit gradient through to it: the right tool was still 10 mm off after 8 s
// (125 mm at 4 s). Each block damped and scaled on its own, the right arm moves as if the
// left had no target.
TEST(Scenarios, OneArmOutOfReachDoesNotHoldTheOtherBack) {
  const std::string head = "name: arms\nrobot: {urdf: '" + wbm_test::source_path("models/dual_arm/dual_arm.urdf") +
                           "', root_height: 0.5, fixed_base: true}\n"
                           "dt: 0.002\nduration: 5\nfrozen: [torso_lift]\n"
                           "initial: {left_joint1: 0.6, left_joint4: 1.4, left_joint6: 0.4, right_joint1: 0.6, "
                           "right_joint4: 1.4, right_joint6: 0.4}\n"
                           "tasks: [{name: l, type: position, frame: left_tool, filter: {bandwidth: 4, max_speed: 0.4}},\n"
                           "        {name: r, type: position, frame: right_tool, filter: {bandwidth: 4, max_speed: 0.4}}]\n";
  const std::string targets = "targets: {l: [1.8, 0.6, 1.3], r: [0.45, -0.25, 1.35]}}]\n";
  const auto both = run_scenario(parse_scenario(head + "timeline: [{t: 0, activate: [l, r], " + targets, "a.yaml", "."));
  const auto alone = run_scenario(parse_scenario(head + "timeline: [{t: 0, activate: [r], " + targets, "b.yaml", "."));
  EXPECT_GT(both->error.back()[both->element("l")], 0.5);  // out of reach
  EXPECT_TRUE(both->flags.back() & kDamped);
  EXPECT_LT(both->error.back()[both->element("r")], 1e-6);
  // Step by step within 0.1 % of the run without the left arm's target (what still couples
  // them: the null-space part's speed and jerk scaling and the Controller's bound on the
  // change of q_dot, early on).
  for (size_t k = 0; k < both->time.size(); k += 10) {
    const double a = both->error[k][both->element("r")], b = alone->error[k][alone->element("r")];
    ASSERT_NEAR(a, b, 1e-3 * b + 1e-9) << "t = " << both->time[k];
  }
}

// An attitude target pitched past 90 degrees: the dual-arm robot's tools turned by Kardan
// angles (0, 3, 1) rad from where they are, a rotation the arms reach. With the error taken
// as differences of the angles, whose pitch never exceeds 90 degrees, the tools pitched to
// gimbal lock, where the frame's angles jump by pi, and the arms chattered at every cycle
// (225 rad/s^2, 183 degrees short); the rotation error reaches the target.
TEST(Scenarios, AttitudeTargetPitchedPastNinetyDegreesIsReached) {
  const Scenario s = parse_scenario(
      "name: turn\nrobot: {urdf: '" + wbm_test::shipped_model("dual_arm").path +
          "', fixed_base: true}\ndt: 0.002\nduration: 8\nrecord_every: 1\n"
          "tasks: [{name: a, type: attitude, frame: left_tool, filter: {bandwidth: 4, max_speed: 0.8}},\n"
          "        {name: b, type: attitude, frame: right_tool, filter: {bandwidth: 4, max_speed: 0.8}}]\n"
          "timeline: [{t: 0.2, activate: [a, b], relative_targets: {a: [0, 3, 1], b: [0, 3, 1]}}]\n",
      "turn.yaml", ".");
  const auto run = run_scenario(s);
  for (const char* element : {"a", "b"}) {
    const int i = run->element(element);
    EXPECT_LT(run->error.back()[i], 1e-4) << element << ": " << run->error.back()[i] << " rad short";
    // The Kardan angles of the frame differ from the target's (pitch within 90 degrees),
    // the rotation is the same.
    EXPECT_GT(std::abs(run->actual_of(element, static_cast<int>(run->time.size()) - 1)[1] -
                       run->commanded_of(element, static_cast<int>(run->time.size()) - 1)[1]),
              1.0);
  }
  const auto [acceleration, dof] = largest_acceleration_after(*run, 6.5);
  EXPECT_LT(acceleration, 10.0) << dof << " still accelerates at " << acceleration << " rad/s^2 in the last 1.5 s";
  // The pitch row alone, and with the roll row: the angle differences, to the target with
  // its pitch written within 90 degrees (pi - 3 rad and roll + pi). Against the pitch of 3
  // rad itself the tool pitched to gimbal lock and on, 270 and 400-900 rad/s^2 at 10 s.
  for (const std::string rows : {"[a.1]", "[a.0, a.1]"}) {
    Scenario partial = parse_scenario(
        "name: pitch\nrobot: {urdf: '" + wbm_test::shipped_model("dual_arm").path +
            "', fixed_base: true}\ndt: 0.002\nduration: 8\nrecord_every: 1\n"
            "tasks: [{name: a, type: attitude, frame: left_tool, filter: {bandwidth: 4, max_speed: 0.8}}]\n"
            "timeline: [{t: 0.2, activate: " + rows + ", relative_targets: {a: [0, 3, 0]}}]\n",
        "pitch.yaml", ".");
    const auto pitched = run_scenario(partial);
    EXPECT_LT(pitched->error.back()[pitched->element("a")], 1e-4) << rows;
    // Over the whole run: where the filtered target passes 90 degrees, the canonical pitch
    // turns back, and so does its feed-forward rate (without that, 270 rad/s^2 there).
    const auto [partial_acceleration, partial_dof] = largest_acceleration_after(*pitched, 0.0);
    EXPECT_LT(partial_acceleration, 10.0) << rows << ": " << partial_dof;
  }
}

// An axis task with `axis` (G1's camera link looks along x): the view converges, and the
// report draws that axis at the frame (its arrow ends on the target direction), not z.
TEST(Scenarios, AxisTaskWithAnAxisInItsFrameConvergesAndIsDrawn) {
  const std::string g1 = wbm_test::shipped_model("g1_29dof").path;
  const Scenario s = parse_scenario("name: gaze\nrobot: {urdf: '" + g1 +
                                        "', legs: [left_hip_pitch_link, right_hip_pitch_link]}\n"
                                        "duration: 3\nfrozen: [heel_x, heel_y, heel_yaw]\n"
                                        "tasks: [{name: view, type: axis, frame: d435_link, axis: [1, 0, 0]}]\n"
                                        "timeline: [{t: 0.1, activate: [view], targets: {view: [1, 0.6, -0.2]}}]\n",
                                    "gaze.yaml", ".");
  const auto run = run_scenario(s);
  const Vector3 target = Vector3(1, 0.6, -0.2).normalized();
  Data data(*run->model);
  forward_kinematics(*run->model, data, run->controller->q());
  const Vector3 view = frame_pose(*run->model, data, run->model->frame_index("d435_link")).R.col(0);
  EXPECT_LT(std::acos(std::min(1.0, view.dot(target))), 1e-3) << view.transpose();

  const nlohmann::json report = report_data(*run);
  const std::vector<double> drawn = report["frame_z"].back();
  const auto& frames = report["robot"]["frames"];
  int index = -1;
  for (size_t i = 0; i < frames.size(); ++i)
    if (frames[i]["name"] == "d435_link") index = static_cast<int>(i);
  ASSERT_GE(index, 0);
  const Vector3 arrow(drawn[3 * index], drawn[3 * index + 1], drawn[3 * index + 2]);
  EXPECT_LT((arrow - view).norm(), 1e-6) << arrow.transpose();
}

/// Checks that the report draws every frame of the run's model as a link node hanging from
/// the node of the frame it hangs from (Frame::parent, else its body's origin, a body's own
/// frame from the parent body's), at the position forward kinematics gives. Returns the nodes'
/// indices by name.
std::map<std::string, int> expect_report_draws_every_link(const ScenarioRun& run) {
  const Model& model = *run.model;
  const nlohmann::json report = report_data(run);
  const auto& nodes = report["robot"]["bodies"];
  const nlohmann::json& positions = report["body_pos"].back();
  EXPECT_EQ(positions.size(), 3 * nodes.size());
  Data data(model);
  forward_kinematics(model, data, run.q.back());
  const LegPoser legs(run.scenario, model, run.feet.spacing);
  std::map<std::string, int> node;
  for (size_t i = 0; i < nodes.size(); ++i) node[nodes[i]["name"]] = static_cast<int>(i);
  EXPECT_EQ(node.size(), static_cast<size_t>(model.num_frames()));
  // The virtual chain: its inner bodies are not drawn (no position, no link), the heel is a
  // point, the upper body hangs from it only where that link stands for the legs.
  const VirtualDofs& v = model.virtual_dofs();
  const bool legs_as_one_link = run.scenario.urdf.empty() || run.scenario.urdf_options.leg_mode == LegMode::kDrop;
  for (int f = 0; f < model.num_frames(); ++f) {
    const wbm::Frame& frame = model.frame(f);
    if (!node.count(frame.name)) {
      ADD_FAILURE() << frame.name << " is not drawn";
      continue;
    }
    const int i = node[frame.name];
    const int parent = nodes[i]["parent"];
    const int parent_body = model.body(frame.body).parent;
    const bool own = frame.name == model.body(frame.body).name;
    const int dof = model.body(frame.body).dof;
    const DofRole role = dof >= 0 ? model.dof(dof).role : DofRole::kJoint;
    const bool inner_virtual = own && role != DofRole::kJoint && role != DofRole::kHeelYaw && frame.body != v.upper_body;
    const std::string expected = inner_virtual || (own && role == DofRole::kHeelYaw) ? ""
                                 : own && frame.body == v.upper_body ? (legs_as_one_link ? "heel" : "")
                                 : frame.parent >= 0                 ? model.frame(frame.parent).name
                                 : !own                              ? model.body(frame.body).name
                                 : parent_body >= 0                  ? model.body(parent_body).name
                                                                     : "";
    EXPECT_EQ(parent >= 0 ? nodes[parent]["name"].get<std::string>() : "", expected) << frame.name;
    if (inner_virtual) {
      EXPECT_TRUE(positions[3 * i].is_null()) << frame.name << " is drawn";
      continue;
    }
    if (legs.leg_frame_position(f)) continue;  // posed on the feet: LockedLegsAreDrawnStandingOnTheFeet
    const Vector3 drawn(positions[3 * i].get<double>(), positions[3 * i + 1].get<double>(), positions[3 * i + 2].get<double>());
    EXPECT_LE((drawn - frame_pose(model, data, f).p).cwiseAbs().maxCoeff(), 0.5e-6 + 1e-12) << frame.name;  // rounded to 1 um
  }
  return node;
}

/// A scenario on a URDF with one position task on `frame`, `duration` seconds.
Scenario reach_scenario(const std::string& urdf, const std::string& robot_options, const std::string& frame) {
  return parse_scenario("name: reach\nrobot: {urdf: '" + urdf + "', " + robot_options + "}\nduration: 0.2\n" +
                            "tasks: [{name: hand, type: position, frame: " + frame + "}]\n" +
                            "timeline: [{t: 0, activate: [hand], relative_targets: {hand: [0.1, 0, 0.1]}}]\n",
                        "reach.yaml", ".");
}

// The report draws every link of the URDF: the welded ones too (G1's locked legs, head and
// sensors are frames on the pelvis and torso), each from the link it hangs from; and a
// joint that hangs from a welded link (the synthetic robot's mount, also re-rooted at its
// tool, where joints reverse) from that link, not from its body's origin.
// Of the virtual chain only the heel and the upper body are drawn: its inner bodies were
// drawn as a rod along x on the floor and a pole up to the pelvis between the locked legs;
// the paper model, whose legs are virtual, keeps one link from the heel to the upper body.
TEST(Scenarios, ReportDrawsEveryLinkFromTheLinkItHangsFrom) {
  const auto paper = run_scenario(shipped("walk_object_ahead"));
  std::map<std::string, int> paper_node = expect_report_draws_every_link(*paper);
  EXPECT_EQ(report_data(*paper)["robot"]["bodies"][paper_node["upper_body"]]["parent"], paper_node["heel"]);
  const auto g1 = run_scenario(reach_scenario(wbm_test::shipped_model("g1_29dof").path,
                                              "legs: [left_hip_pitch_link, right_hip_pitch_link]", "left_rubber_hand"));
  std::map<std::string, int> node = expect_report_draws_every_link(*g1);
  // 22 welded: 12 leg links, the pelvis contour and IMU, 6 on the torso, 2 hands.
  EXPECT_EQ(g1->model->num_frames() - g1->model->num_bodies(), 22);
  const nlohmann::json nodes = report_data(*g1)["robot"]["bodies"];
  EXPECT_EQ(nodes[node["left_ankle_roll_link"]]["parent"], node["left_ankle_pitch_link"]);
  EXPECT_EQ(nodes[node["left_hip_pitch_link"]]["parent"], node["pelvis"]);
  for (const std::string root : {"base", "tool"}) {
    const auto run = run_scenario(reach_scenario(wbm_test::source_path("tests/data/mimic_prismatic.urdf"),
                                                 "root: " + root + ", legs: [leg], root_height: 0.7",
                                                 root == "tool" ? "base" : "tool"));
    node = expect_report_draws_every_link(*run);
    // Its few frames are drawn with their axes, but not those of the locked leg.
    const nlohmann::json frames = report_data(*run)["robot"]["frames"];
    std::set<std::string> drawn;
    for (const auto& f : frames) drawn.insert(f["name"].get<std::string>());
    EXPECT_TRUE(drawn.count("mount")) << frames.dump();
    EXPECT_FALSE(drawn.count("leg") || drawn.count("foot")) << frames.dump();
    const nlohmann::json synthetic = report_data(*run)["robot"]["bodies"];
    if (root == "base") {
      EXPECT_EQ(synthetic[node["link_c"]]["parent"], node["mount"]);
    } else {  // reversed: mount hangs from the body of j_mimic, which sits on link_c's origin
      EXPECT_EQ(synthetic[node["mount"]]["parent"], node["j_mimic"]);
      EXPECT_EQ(synthetic[node["j_mimic"]]["parent"], node["link_c"]);
    }
  }
}

/// The drawn position of node `i` in sample `k` of the report's data.
Vector3 drawn_position(const nlohmann::json& report, int k, int i) {
  const nlohmann::json& p = report["body_pos"][k];
  return Vector3(p[3 * i].get<double>(), p[3 * i + 1].get<double>(), p[3 * i + 2].get<double>());
}

/// Checks the drawn legs of a run with locked legs: every leg link keeps its distance to the
/// link it hangs from (joints turn about a link's origin), the legs were posed (a knee
/// drawn away from where the locked leg has it), and until `reachable_until` [s] each of
/// `points` (per side: the ankle and frames fixed below it, which a tilted or turned foot
/// moves), between its steps, stands at its place on its foot to within `tolerance` [m]: as
/// in the upright pose with straight legs, its position there (the heel at the origin facing
/// x) moved from the foot standing beside that heel to the foot it stands on now.
void expect_legs_stand_on_the_feet(const ScenarioRun& run, const std::array<std::vector<std::string>, 2>& points,
                                   const std::array<std::string, 2>& knees, double reachable_until, double tolerance) {
  const Model& model = *run.model;
  const nlohmann::json report = report_data(run);
  std::map<std::string, int> node;
  const auto& nodes = report["robot"]["bodies"];
  for (size_t i = 0; i < nodes.size(); ++i) node[nodes[i]["name"]] = static_cast<int>(i);
  const LegPoser legs(run.scenario, model, run.feet.spacing);
  ASSERT_TRUE(legs.usable());
  Data up(model), data(model);
  forward_kinematics(model, up, upright_base_configuration(model, Eigen::VectorXd::Zero(model.num_dofs())));
  const int samples = static_cast<int>(report["time"].size());
  double knee_moved = 0.0;
  int rest_checks = 0;
  for (int k = 0; k < samples; ++k) {
    const double t = report["time"][k].get<double>();
    const int cycle = static_cast<int>(std::lower_bound(run.time.begin(), run.time.end(), t - 1e-12) - run.time.begin());
    forward_kinematics(model, data, run.q[cycle]);
    for (int f = 0; f < model.num_frames(); ++f) {
      if (!legs.leg_frame_position(f)) continue;
      const int i = node[model.frame(f).name];
      const int parent = nodes[i]["parent"];
      ASSERT_GE(parent, 0) << model.frame(f).name;
      const int pf = model.frame_index(nodes[parent]["name"]);
      const double length = (frame_pose(model, data, f).p - frame_pose(model, data, pf).p).norm();
      EXPECT_NEAR((drawn_position(report, k, i) - drawn_position(report, k, parent)).norm(), length, 3e-6)
          << model.frame(f).name << " at t = " << t;
    }
    for (int side = 0; side < 2; ++side) {
      const int knee = model.frame_index(knees[side]);
      knee_moved = std::max(knee_moved, (drawn_position(report, k, node[knees[side]]) - frame_pose(model, data, knee).p).norm());
      // Between steps: no footstep of this foot lands within a step duration from t.
      bool swinging = false;
      FootPose foot = drawn_feet(run, run.time.front()).pose[side];
      for (const Footstep& step : run.footsteps)
        if (step.left == (side == 0)) {
          if (step.time <= t) foot = step.pose;
          else if (step.time - run.walking_parameters.step_duration < t) swinging = true;
        }
      if (swinging || t > reachable_until) continue;
      const FootPose beside = standing_foot(side == 0, Vector2::Zero(), 0.0, run.feet.spacing);
      for (const std::string& point : points[side]) {
        const Vector3 up_point = frame_pose(model, up, model.frame_index(point)).p;
        const Vector2 in_foot = Eigen::Rotation2Dd(-beside.yaw) * (up_point.head<2>() - beside.position);
        Vector3 expected;
        expected << foot.position + Eigen::Rotation2Dd(foot.yaw) * in_foot, up_point.z();
        EXPECT_LE((drawn_position(report, k, node[point]) - expected).norm(), tolerance) << point << " at t = " << t;
        ++rest_checks;
      }
    }
  }
  EXPECT_GT(knee_moved, 0.01);
  EXPECT_GT(rest_checks, 10);
}

// A URDF robot's locked legs are drawn standing on the feet (LegPoser): not rigid under the
// upper body, whose home pose leans 0.15 rad forward (the ankles swung back behind the heel),
// which balance shifts over the feet and which walks (the legs slid over the floor).
TEST(Scenarios, LockedLegsAreDrawnStandingOnTheFeet) {
  // G1 reaching with balance, standing turned away from the world's axes.
  Scenario g1_turned = shipped("g1_reach_with_balance");
  g1_turned.initial = {{"heel_x", 0.3}, {"heel_y", -0.2}, {"heel_yaw", 2.5}};
  const auto g1 = run_scenario(g1_turned);
  expect_legs_stand_on_the_feet(*g1, {{{"left_ankle_roll_link"}, {"right_ankle_roll_link"}}},
                                {"left_knee_link", "right_knee_link"}, 1e9, 3e-6);
  // The same G1 with its root link turned half round (root_rpy; it faces backward): the
  // URDF's right leg stands at the heel's left.
  Scenario g1_backward = shipped("g1_reach_with_balance");
  g1_backward.urdf_options.root_rpy = Vector3(0, 0, std::numbers::pi);
  expect_legs_stand_on_the_feet(*run_scenario(g1_backward), {{{"right_ankle_roll_link"}, {"left_ankle_roll_link"}}},
                                {"right_knee_link", "left_knee_link"}, 1e9, 3e-6);
  // H1 standing with balance: its knees' range starts 0.26 rad below straight, so a straight
  // seed stayed straight (singular) and its legs missed the feet by 98 mm.
  const auto h1 = run_scenario(parse_scenario(
      "name: h1\nrobot: {urdf: '" + wbm_test::shipped_model("h1").path +
          "', legs: [left_hip_yaw_link, right_hip_yaw_link]}\nduration: 1\nfrozen: [heel_x, heel_y, heel_yaw]\n" +
          "balance: {enabled: true}\ntasks: [{name: hand, type: position, frame: left_elbow_link}]\n" +
          "timeline: [{t: 0, activate: [hand], relative_targets: {hand: [0.1, 0, 0.1]}}]\n",
      "h1.yaml", "."));
  expect_legs_stand_on_the_feet(*h1, {{{"left_ankle_link"}, {"right_ankle_link"}}}, {"left_knee_link", "right_knee_link"}, 1e9,
                                1e-3);
  // NAO walks to a target 1 m ahead. Its ankles and soles stand on the feet in the home pose,
  // until the hand's target is switched on at 0.2 s (the soles' places check that the feet
  // are neither tilted nor turned); then the upper body leans and shifts, and later runs
  // ahead of the feet, further than NAO's short legs reach (up to 0.14 m forward:
  // upper_body_x's range is the paper model's), and they are drawn as near as they get.
  const auto nao = run_scenario(parse_scenario(
      "name: nao_walk\nrobot: {urdf: '" + wbm_test::shipped_model("nao").path + "', legs: [LPelvis, RPelvis]}\n" +
          "duration: 6\nfrozen: [heel_x, heel_y, heel_yaw]\nwalking: {enabled: true}\n" +
          "feet: {length: 0.16, width: 0.09, left_frame: l_sole, right_frame: r_sole}\n" +
          "tasks: [{name: hand, type: position, frame: l_gripper}]\n" +
          "timeline: [{t: 0.2, activate: [hand], relative_targets: {hand: [1.0, 0.3, 0]}}]\n",
      "nao_walk.yaml", "."));
  ASSERT_GE(nao->footsteps.size(), 4u);
  expect_legs_stand_on_the_feet(*nao, {{{"l_ankle", "l_sole"}, {"r_ankle", "r_sole"}}}, {"LTibia", "RTibia"}, 0.2, 3e-6);
  // A swing foot: half-way through its step it is half-way there and lifted by 0.2
  // max_step_length; it lands on its footstep.
  const Footstep& step = nao->footsteps[1];
  const int side = step.left ? 0 : 1;
  const FootPose from = drawn_feet(*nao, step.time - nao->walking_parameters.step_duration).pose[side];
  const DrawnFeet middle = drawn_feet(*nao, step.time - 0.5 * nao->walking_parameters.step_duration);
  EXPECT_NEAR((middle.pose[side].position - 0.5 * (from.position + step.pose.position)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(middle.lift[side], 0.2 * nao->walking_parameters.max_step_length, 1e-12);
  // Moved along the floor by a smooth step (3 s^2 - 2 s^3): a quarter of the swing's time
  // covers 5/32 of the way, and the foot starts and lands at rest.
  const DrawnFeet quarter = drawn_feet(*nao, step.time - 0.75 * nao->walking_parameters.step_duration);
  EXPECT_NEAR((quarter.pose[side].position - (from.position + 0.15625 * (step.pose.position - from.position))).norm(), 0.0,
              1e-12);
  // Each leg is posed on its own foot: H1 (whose legs reach its feet while it walks) half-way
  // through a step draws the swinging foot's ankle higher than the standing foot's, by most of
  // the lift (the legs reach the feet as near as their joints allow).
  {
    const auto h1_walk = run_scenario(walk_scenario(kNarrowAndWideFeet[1], "length: 0.15, width: 0.07, ", "1.5, 0.4, 0.0"));
    const Model& m = *h1_walk->model;
    ASSERT_GE(h1_walk->footsteps.size(), 4u);
    const std::array<int, 2> ankles = {m.frame_index("left_ankle_link"), m.frame_index("right_ankle_link")};
    Data data(m);
    for (const int n : {2, 3}) {
      const Footstep& swing = h1_walk->footsteps[n];
      const int swing_side = swing.left ? 0 : 1;
      LegPoser poser(h1_walk->scenario, m, h1_walk->feet.spacing);
      ASSERT_TRUE(poser.usable());
      const double t_mid = swing.time - 0.5 * h1_walk->walking_parameters.step_duration;
      const auto cycle = std::lower_bound(h1_walk->time.begin(), h1_walk->time.end(), t_mid - 1e-12) - h1_walk->time.begin();
      forward_kinematics(m, data, h1_walk->q[cycle]);
      const DrawnFeet feet = drawn_feet(*h1_walk, t_mid);
      poser.pose(data, feet);
      const double raised =
          poser.leg_frame_position(ankles[swing_side])->z() - poser.leg_frame_position(ankles[1 - swing_side])->z();
      EXPECT_GT(raised, 0.5 * feet.lift[swing_side]) << "footstep " << n;  // 74 and 83 of 86 mm
      EXPECT_GT(feet.lift[swing_side], 0.02);
    }
  }
  // The built-in model has no legs to pose (its heel-to-pelvis link stands for them).
  const Model paper = make_paper_model();
  EXPECT_FALSE(LegPoser(shipped("fig7_top_right_hand"), paper, 0.18).usable());
}

// A drawn swing foot turns the short way round: a step from yaw pi - 0.02 to -pi + 0.02
// (0.04 rad across the +-pi cut) passes pi half-way, not zero.
TEST(Scenarios, ADrawnSwingFootTurnsTheShortWayAcrossPi) {
  ScenarioRun run;
  run.model = std::make_unique<Model>(make_paper_model());
  const VirtualDofs& v = run.model->virtual_dofs();
  VectorXd q = run.model->home();
  q[v.heel_yaw] = M_PI - 0.02;
  run.q.push_back(q);
  const double T = run.walking_parameters.step_duration;
  Footstep step;
  step.time = 1.0;
  step.left = true;
  step.pose = standing_foot(true, Vector2(0.05, 0.0), -M_PI + 0.02, run.feet.spacing);
  run.footsteps.push_back(step);
  const DrawnFeet middle = drawn_feet(run, step.time - 0.5 * T);
  EXPECT_NEAR(std::remainder(middle.pose[0].yaw - M_PI, 2 * M_PI), 0.0, 1e-12) << middle.pose[0].yaw;
  EXPECT_NEAR(std::remainder(drawn_feet(run, step.time).pose[0].yaw - step.pose.yaw, 2 * M_PI), 0.0, 1e-12);
  EXPECT_NEAR(drawn_feet(run, step.time - T).pose[0].yaw, M_PI - 0.02, 1e-12);  // not moved before the swing
}

// A task on a frame in a locked leg: the controller moves the leg with the upper body (it
// is rigid there), the 3D view draws the leg standing on its foot, and the task's frame with
// the drawn leg, not where the locked leg has it; a task note says so.
TEST(Scenarios, ATaskOnALockedLegsFrameIsDrawnWithTheDrawnLeg) {
  auto scenario_text = [](const std::string& frame, const std::string& reference) {
    return "name: g1_leg_task\nrobot: {urdf: '" + wbm_test::shipped_model("g1_29dof").path +
           "', root: pelvis, legs: [left_hip_pitch_link, right_hip_pitch_link]}\nduration: 1\n" +
           "frozen: [heel_x, heel_y, heel_yaw]\nfeet: {length: 0.2, width: 0.08, left_frame: left_ankle_roll_link, " +
           "right_frame: right_ankle_roll_link}\ntasks: [{name: knee, type: position, frame: " + frame +
           (reference.empty() ? "" : ", reference: " + reference) +
           "}, {name: hand, type: position, frame: left_rubber_hand}]\n" +
           "timeline: [{t: 0, activate: [knee, hand], relative_targets: {knee: [0.1, 0, 0.1], hand: [0.1, 0, 0.1]}}]\n";
  };
  const auto run = run_scenario(parse_scenario(scenario_text("left_knee_link", ""), "leg_task.yaml", "."));
  const nlohmann::json notes = summarize(*run)["task_notes"];
  ASSERT_EQ(notes.size(), 1u) << notes.dump();
  EXPECT_NE(notes[0].get<std::string>().find("task 'knee': its frame 'left_knee_link' is in the locked leg from "
                                              "'left_hip_pitch_link'"),
            std::string::npos)
      << notes.dump();
  const nlohmann::json report = report_data(*run);
  std::map<std::string, int> node;
  const auto& nodes = report["robot"]["bodies"];
  for (size_t i = 0; i < nodes.size(); ++i) node[nodes[i]["name"]] = static_cast<int>(i);
  int j = -1;  // the knee's index among the drawn frames
  for (size_t i = 0; i < report["robot"]["frames"].size(); ++i)
    if (report["robot"]["frames"][i]["name"] == "left_knee_link") j = static_cast<int>(i);
  ASSERT_GE(j, 0);
  const Model& model = *run->model;
  const int knee = model.frame_index("left_knee_link");
  Data data(model);
  double locked_apart = 0.0;  // how far the locked knee is from the drawn one
  for (size_t k = 0; k < report["time"].size(); ++k) {
    const nlohmann::json& fp = report["frame_pos"][k];
    const Vector3 drawn_frame(fp[3 * j].get<double>(), fp[3 * j + 1].get<double>(), fp[3 * j + 2].get<double>());
    // The link's drawn origin is rounded to micrometres.
    EXPECT_LE((drawn_frame - drawn_position(report, static_cast<int>(k), node["left_knee_link"])).norm(), 1e-6) << k;
    const double t = report["time"][k].get<double>();
    const auto cycle = std::lower_bound(run->time.begin(), run->time.end(), t - 1e-12) - run->time.begin();
    forward_kinematics(model, data, run->q[cycle]);
    locked_apart = std::max(locked_apart, (frame_pose(model, data, knee).p - drawn_frame).norm());
  }
  EXPECT_GT(locked_apart, 0.01);  // the check above tells the two apart
  // Relative to a frame in the other leg: noted too; tasks on the arms and the torso are not.
  const auto relative = run_scenario(parse_scenario(scenario_text("left_rubber_hand", "right_ankle_roll_link"),
                                                    "leg_task.yaml", "."));
  const nlohmann::json relative_notes = summarize(*relative)["task_notes"];
  ASSERT_EQ(relative_notes.size(), 1u) << relative_notes.dump();
  EXPECT_NE(relative_notes[0].get<std::string>().find("its reference 'right_ankle_roll_link' is in the locked leg from "
                                                       "'right_hip_pitch_link'"),
            std::string::npos);
  EXPECT_EQ(summarize(*run_scenario(parse_scenario(scenario_text("torso_link", ""), "leg_task.yaml", ".")))["task_notes"],
            nlohmann::json::array());
}

// Balance without walking: the report draws the feet the centre of mass is kept over (both
// feet at their place beside the heel, from the start) and the centre of mass on the ground.
TEST(Scenarios, BalanceReportDrawsTheFeetAndTheCentreOfMass) {
  const auto run = run_scenario(shipped("g1_reach_with_balance"));
  const nlohmann::json report = report_data(*run);
  const auto& prints = report["footprints"];
  ASSERT_EQ(prints.size(), 2u);
  // Together the two feet span the support polygon the balance module used.
  const SupportPolygon& support = run->support.front();
  double x_min = 1e9, x_max = -1e9, y_min = 1e9, y_max = -1e9;
  for (const auto& foot : prints) {
    EXPECT_EQ(foot["t"].get<double>(), run->time.front());
    for (const auto& p : foot["polygon"]) {
      x_min = std::min(x_min, p[0].get<double>()), x_max = std::max(x_max, p[0].get<double>());
      y_min = std::min(y_min, p[1].get<double>()), y_max = std::max(y_max, p[1].get<double>());
    }
  }
  double sx_min = 1e9, sx_max = -1e9, sy_min = 1e9, sy_max = -1e9;
  for (const Vector2& p : support.vertices()) {
    sx_min = std::min(sx_min, p.x()), sx_max = std::max(sx_max, p.x());
    sy_min = std::min(sy_min, p.y()), sy_max = std::max(sy_max, p.y());
  }
  EXPECT_NEAR(x_min, sx_min, 1e-12);
  EXPECT_NEAR(x_max, sx_max, 1e-12);
  EXPECT_NEAR(y_min, sy_min, 1e-12);
  EXPECT_NEAR(y_max, sy_max, 1e-12);
  EXPECT_EQ(prints[0]["side"], "L");
  EXPECT_GT(prints[0]["polygon"][0][1].get<double>(), prints[1]["polygon"][0][1].get<double>() - 1e-12);
  const nlohmann::json* com = nullptr;
  for (const auto& path : report["paths"])
    if (path["name"] == "centre of mass (on the ground)") com = &path;
  ASSERT_NE(com, nullptr);
  const auto& last = (*com)["points"].back();
  EXPECT_NEAR(last[0].get<double>(), run->balance.back()[0], 1e-12);
  EXPECT_NEAR(last[1].get<double>(), run->balance.back()[1], 1e-12);
  EXPECT_EQ(last[2].get<double>(), 0.0);
}

std::vector<std::string> csv_fields(const std::string& line);

/// Every shipped scenario runs cleanly, writes its three (or four) files (a trajectory row
/// every record_every cycles, a footstep row per landing with its foot) and keeps every
/// joint's acceleration within the Controller's bound.
TEST(Scenarios, EveryShippedScenarioRunsAndWritesItsOutputs) {
  namespace fs = std::filesystem;
  const fs::path out = fs::temp_directory_path() / ("wbm_scenarios_test_" + std::to_string(getpid()));
  int count = 0, strided = 0;
  for (const auto& entry : fs::directory_iterator(wbm_test::source_path("scenarios"))) {
    if (entry.path().extension() != ".yaml") continue;
    ++count;
    const Scenario s = load_scenario(entry.path());
    const auto run = run_scenario(s);
    for (std::uint32_t f : run->flags) ASSERT_EQ(f & (std::uint32_t{kInvalidInput} | kInvalidCommand), 0u) << s.name;
    write_outputs(*run, (out / s.name).string(), false);
    EXPECT_TRUE(fs::exists(out / s.name / "trajectory.csv")) << s.name;
    EXPECT_TRUE(fs::exists(out / s.name / "summary.json")) << s.name;
    EXPECT_EQ(fs::exists(out / s.name / "footsteps.csv"), s.walking.enabled) << s.name;
    std::ifstream csv(out / s.name / "trajectory.csv");
    std::string header;
    std::getline(csv, header);
    EXPECT_EQ(header.rfind("time,status,q.", 0), 0u) << header;
    int rows = 0;
    for (std::string line; std::getline(csv, line);) ++rows;
    strided += s.record_every > 1;
    EXPECT_EQ(rows, (run->num_cycles() + s.record_every - 1) / s.record_every) << s.name;
    if (s.walking.enabled) {
      std::ifstream steps(out / s.name / "footsteps.csv");
      std::string line;
      std::getline(steps, line);
      EXPECT_EQ(line, "time,foot,x,y,yaw");
      for (const Footstep& f : run->footsteps) {
        ASSERT_TRUE(std::getline(steps, line)) << s.name;
        EXPECT_EQ(csv_fields(line).at(1), f.left ? "L" : "R") << s.name << ": " << line;
      }
      EXPECT_FALSE(std::getline(steps, line)) << s.name;
    }
    // No joint's rate changed faster than the Controller's bound k v_max (the balance
    // shift's start: 6x it before the bound covered external velocities).
    const nlohmann::json summary = summarize(*run);
    ASSERT_TRUE(summary.contains("max_joint_acceleration_to_bound")) << s.name;
    EXPECT_LE(summary["max_joint_acceleration_to_bound"]["ratio"].get<double>(), 1.0 + 1e-9)
        << s.name << ": " << summary["max_joint_acceleration_to_bound"].dump();
  }
  EXPECT_GE(count, 10);
  EXPECT_GT(strided, 0) << "no scenario records every n-th cycle only";
  fs::remove_all(out);
}

/// The fields of one CSV line (RFC 4180: quoted fields may hold commas and doubled quotes).
std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') fields.back() += line[++i];
    else if (c == '"') quoted = !quoted;
    else if (c == ',' && !quoted) fields.emplace_back();
    else fields.back() += c;
  }
  return fields;
}

// Element names head CSV columns: one with a comma and a quote is quoted there, so the
// header has as many fields as every row (it had one more per comma).
TEST(Scenarios, TrajectoryHeaderQuotesNamesWithCommasAndQuotes) {
  namespace fs = std::filesystem;
  const auto run = run_scenario(parse_scenario(
      "name: csv\nduration: 0.05\ntasks: [{name: 'left, \"the\" hand', type: position, frame: l_hand_ref, active: true}]\n",
      "csv.yaml", "."));
  const fs::path out = fs::temp_directory_path() / ("wbm_csv_quoting_" + std::to_string(getpid()));
  write_outputs(*run, out.string(), false);
  std::ifstream csv(out / "trajectory.csv");
  std::string header, row;
  std::getline(csv, header);
  std::getline(csv, row);
  fs::remove_all(out);
  EXPECT_NE(header.find(",\"left, \"\"the\"\" hand.target.0\","), std::string::npos) << header;
  const std::vector<std::string> names = csv_fields(header);
  EXPECT_EQ(names.size(), csv_fields(row).size()) << header;
  EXPECT_NE(std::find(names.begin(), names.end(), "left, \"the\" hand.error"), names.end()) << header;
}

// Errors of joint elements are given in the dofs' unit: a torso lift (prismatic) in m, not
// in rad as every joint element's were; a lift and an arm joint together in "rad, m".
TEST(Scenarios, JointElementErrorsCarryTheUnitOfTheirDofs) {
  const auto run = run_scenario(parse_scenario(
      "name: units\nrobot: {urdf: '" + wbm_test::shipped_model("dual_arm").path +
          "', fixed_base: true}\ndt: 0.01\nduration: 0.1\n"
          "tasks: [{name: lift, type: joints, dofs: [torso_lift]}, {name: arm, type: joints, dofs: [left_joint1]},\n"
          "        {name: both, type: joints, dofs: [torso_lift, left_joint1]}, {name: tool, type: position, frame: left_tool},\n"
          "        {name: grasp, type: axis, frame: left_tool}]\n",
      "units.yaml", "."));
  const nlohmann::json summary = summarize(*run);
  EXPECT_EQ(summary["elements"]["lift"]["unit"], "m");
  EXPECT_EQ(summary["elements"]["arm"]["unit"], "rad");
  EXPECT_EQ(summary["elements"]["both"]["unit"], "rad, m");
  EXPECT_EQ(summary["elements"]["tool"]["unit"], "mm");
  EXPECT_EQ(summary["elements"]["grasp"]["unit"], "deg");
}

// A robot on a fixed base (robot.fixed_base): the nine virtual dofs stay exactly upright
// (the root link at its height, not shifted, not tilted) while the arms and the torso lift
// take a box from the sides, lift it and push it.
TEST(FixedBase, DualArmTakesLiftsAndPushesABoxWithItsBaseUprightAndFrozen) {
  const auto run = run_scenario(shipped("dual_arm_fixed_base"));
  const Model& m = *run->model;
  const Eigen::VectorXd upright = upright_base_configuration(m, m.home());
  const int lift = m.dof_index("torso_lift");
  double lift_travel = 0.0;
  for (int k = 0; k < run->num_cycles(); ++k) {
    for (const int i : m.virtual_dofs().all()) ASSERT_EQ(run->q[k][i], upright[i]) << m.dof(i).name << " at t = " << run->time[k];
    for (int i = 0; i < m.num_dofs(); ++i) {
      ASSERT_GE(run->q[k][i], m.dof(i).lower) << m.dof(i).name;
      ASSERT_LE(run->q[k][i], m.dof(i).upper) << m.dof(i).name;
    }
    lift_travel = std::max(lift_travel, std::abs(run->q[k][lift] - run->q[0][lift]));
  }
  EXPECT_GT(lift_travel, 0.05) << "the torso lift takes no share of the motion";
  const int last = run->num_cycles() - 1;
  for (const char* tool : {"l_tool", "r_tool"})
    EXPECT_LT((run->actual_of(tool, last) - run->commanded_of(tool, last)).norm(), 1e-3) << tool;
  for (const char* axis : {"l_grasp", "r_grasp"})
    EXPECT_LT(deg(std::acos(std::min(1.0, run->actual_of(axis, last).dot(run->commanded_of(axis, last).normalized())))), 0.1)
        << axis;
  // Lifted 0.3 m and pushed 0.1 m from where the box was taken (0.45 m ahead, 0.95 m up;
  // relative targets add to the value at their time, which lags the target a little).
  EXPECT_NEAR(run->actual_of("l_tool", last).z(), 0.95 + 0.3, 0.02);
  // The base link stands on the ground, at the URDF's world origin (the world link is a frame).
  Data data(m);
  wbm::forward_kinematics(m, data, run->q[last]);
  EXPECT_EQ(wbm::frame_position(m, data, m.frame_index("base")), Eigen::Vector3d::Zero());
  EXPECT_EQ(wbm::frame_position(m, data, m.frame_index("world")), Eigen::Vector3d::Zero());
  EXPECT_NEAR(run->actual_of("l_tool", last).x(), 0.45 + 0.1, 0.02);
}

// The summary's numbers against their definitions, on a run in which nothing moves (every dof
// frozen, so that each error stays what the timeline made it): an axis element's error is the
// angle between its axis and the target, an attitude element's the angle of the rotation
// between value and target, both in degrees; max_error counts the cycles an element is active
// only (1 m off while inactive, 10 mm once active); min_distance_to_limit is a joint's distance
// to its nearer limit. An event at t = 0 is in the first cycle's command, and duration / dt
// (0.3 / 0.1 = 2.9999999999999996 in floating point) rounds to whole cycles.
TEST(Scenarios, TheSummaryMeasuresWhatItsFieldsSay) {
  const Model paper = make_paper_model();
  std::string frozen;
  for (int i = 0; i < paper.num_dofs(); ++i) frozen += (i ? ", " : "") + paper.dof(i).name;
  const Dof& elbow = paper.dof(paper.dof_index("l_elbow"));
  std::ostringstream yaml;
  yaml << std::setprecision(17) << "name: summary\nrobot: {builtin: paper}\ndt: 0.1\nduration: 0.3\nfrozen: [" << frozen
       << "]\ninitial: {l_elbow: " << elbow.upper - 0.001 << "}\n"
       << "tasks:\n"
          "  - {name: grasp, type: axis, frame: l_hand_ref}\n"
          "  - {name: head, type: attitude, frame: head_camera}\n"
          "  - {name: late, type: position, frame: r_hand_ref}\n"
          "timeline:\n"
          "  - {t: 0, activate: [grasp, head], targets: {grasp: [0, 1, 0]}, relative_targets: {head: [0.3, -0.2, 0.4], "
          "late: [1, 0, 0]}}\n"
          "  - {t: 0.2, activate: [late], relative_targets: {late: [0.01, 0, 0]}}\n";
  const auto run = run_scenario(parse_scenario(yaml.str(), "summary.yaml", "."));
  ASSERT_EQ(run->num_cycles(), 4);  // t = 0, 0.1, 0.2, 0.3
  EXPECT_EQ(run->commanded_of("grasp", 1), Eigen::Vector3d(0, 1, 0));
  const nlohmann::json summary = summarize(*run);
  const nlohmann::json& elements = summary["elements"];
  const Eigen::Vector3d axis = run->actual_of("grasp", 3).head<3>().normalized();
  const double axis_angle = std::acos(std::clamp(axis.y(), -1.0, 1.0)) * 180.0 / M_PI;
  EXPECT_GT(axis_angle, 10.0);
  EXPECT_NEAR(elements["grasp"]["final_error"].get<double>(), axis_angle, 1e-9);
  const Eigen::Matrix3d R_value = AttitudeTask::kardan_rotation(run->actual_of("head", 3).head<3>());
  const Eigen::Matrix3d R_target = AttitudeTask::kardan_rotation(run->commanded_of("head", 3).head<3>());
  const double turn = std::acos(std::clamp(((R_value.transpose() * R_target).trace() - 1.0) / 2.0, -1.0, 1.0));
  EXPECT_GT(turn, 0.2);
  EXPECT_NEAR(elements["head"]["final_error"].get<double>(), turn * 180.0 / M_PI, 1e-6);
  EXPECT_NEAR(elements["late"]["max_error"].get<double>(), 10.0, 1e-9);  // mm
  EXPECT_NEAR(summary["min_distance_to_limit"]["value"].get<double>(), 0.001, 1e-12);
  EXPECT_EQ(summary["min_distance_to_limit"]["dof"], "l_elbow");
}

// The summary's numbers, recomputed from the run's records on a walk that max_steps ends
// with the feet left behind and balance holding the upper body at its shift limit: walks
// counted as starts (not walking cycles), the body's lead over the walking cycles, the feet's
// distance from the body in x and y, the least com margin, the largest null-space cost, the
// dofs nearest their speed limit and their rate-change bound (ratios, not absolute values: the heel and the joints have different
// limits) and the cycle time's median; and the remedy that names max_steps.
TEST(Scenarios, TheSummaryOfAWalkAndBalanceIsItsRecords) {
  const auto run = run_scenario(parse_scenario(
      "name: w\nrobot: {builtin: paper}\ndt: 0.002\nduration: 4\nbalance: {enabled: true}\n"
      "walking: {enabled: true, max_steps: 2}\n"
      "tasks: [{name: hand, type: position, frame: l_hand_ref, active: true},\n"
      "        {name: look, type: joints, dofs: [head_pan], active: true, filter: {max_speed: 0.5}}]\n"
      "timeline:\n  - {t: 0, relative_targets: {hand: [1.0, 0.6, 0], look: [0.8]}}\n",
      "w.yaml", "."));
  const nlohmann::json summary = summarize(*run);
  const Model& model = *run->model;
  const VirtualDofs& v = model.virtual_dofs();
  const int K = run->num_cycles();
  int walks = 0, walking_cycles = 0;
  double lead = 0.0;
  for (int k = 0; k < K; ++k) {
    walks += k > 0 && run->walking[k][3] > 0.0 && run->walking[k - 1][3] == 0.0;
    walking_cycles += run->walking[k][3] > 0.0;
    if (run->walking[k][3] > 0.0) lead = std::max(lead, body_lead(*run, k));
  }
  const nlohmann::json& w = summary["walking"];
  ASSERT_EQ(walks, 1);
  ASSERT_GT(walking_cycles, 1);
  EXPECT_EQ(w["walks"].get<int>(), walks);
  EXPECT_EQ(w["walks_at_step_limit"].get<int>(), 1);
  EXPECT_FALSE(w["walking_at_end"].get<bool>());
  EXPECT_EQ(w["max_body_lead"].get<double>(), lead);
  const Eigen::VectorXd& h = run->walking.back();
  const Eigen::VectorXd& q = run->q.back();
  ASSERT_GT(std::abs(h[1] - q[v.heel_y]), 0.01);
  EXPECT_NEAR(w["feet_from_body"].get<double>(), std::hypot(h[0] - q[v.heel_x], h[1] - q[v.heel_y]), 1e-12);

  double min_margin = 1e300;
  for (const Eigen::VectorXd& b : run->balance) min_margin = std::min(min_margin, b[6]);
  ASSERT_LT(min_margin, run->balance.back()[6] - 1e-6);
  EXPECT_EQ(summary["balance"]["min_com_margin"].get<double>(), min_margin);
  const nlohmann::json& held = summary["balance"]["shift_at_limit"];
  ASSERT_FALSE(held.empty()) << summary["balance"];
  EXPECT_NE(held[0]["remedy"].get<std::string>().find("raise walking.max_steps"), std::string::npos) << held;

  const double max_cost = *std::max_element(run->cost.begin(), run->cost.end());
  ASSERT_GT(max_cost, run->cost.back());
  EXPECT_EQ(summary["nullspace_cost"]["max"].get<double>(), max_cost);

  double speed_ratio = 0.0, acc_ratio = 0.0, fastest = 0.0, largest_acc = 0.0;
  int speed_dof = -1, acc_dof = -1, fastest_dof = -1, largest_acc_dof = -1;
  const double k_rate = run->scenario.solver.nullspace_rate_change_limit;
  for (int k = 0; k < K; ++k)
    for (int i = 0; i < model.num_dofs(); ++i) {
      const double rate = std::abs(run->qdot[k][i]);
      if (rate / model.dof(i).max_speed > speed_ratio) speed_ratio = rate / model.dof(i).max_speed, speed_dof = i;
      if (rate > fastest) fastest = rate, fastest_dof = i;
      const double a = k > 0 ? std::abs(run->qdot[k][i] - run->qdot[k - 1][i]) / run->scenario.dt : 0.0;
      if (a / (k_rate * model.dof(i).max_speed) > acc_ratio) acc_ratio = a / (k_rate * model.dof(i).max_speed), acc_dof = i;
      if (a > largest_acc) largest_acc = a, largest_acc_dof = i;
    }
  ASSERT_NE(speed_dof, fastest_dof) << "the test needs a dof nearest its limit that is not the fastest";
  EXPECT_EQ(summary["max_joint_speed"]["dof"], model.dof(speed_dof).name);
  EXPECT_NEAR(summary["max_joint_speed"]["ratio_to_limit"].get<double>(), speed_ratio, 1e-12);
  ASSERT_NE(acc_dof, largest_acc_dof) << "the test needs a dof nearest its rate-change bound that is not the fastest to "
                                          "change: both " << model.dof(acc_dof).name;
  EXPECT_EQ(summary["max_joint_acceleration"]["dof"], model.dof(largest_acc_dof).name);
  EXPECT_EQ(summary["max_joint_acceleration_to_bound"]["dof"], model.dof(acc_dof).name);
  EXPECT_NEAR(summary["max_joint_acceleration_to_bound"]["ratio"].get<double>(), acc_ratio, 1e-12);

  std::vector<double> us(run->cycle_us.begin() + 1, run->cycle_us.end());
  std::sort(us.begin(), us.end());
  EXPECT_EQ(summary["cycle_time_us"]["median"].get<double>(), us[us.size() / 2]);
}

// The lines `wbm run` prints from the summary: counts and shares as numbers say them.
TEST(Scenarios, TheSummaryLinesSayTheirNumbers) {
  const nlohmann::json entry = {{"dof", "upper_body_x"}, {"cycles", 30}, {"limit", 0.14}, {"needed", 0.2}, {"remedy", "r"}};
  EXPECT_EQ(describe_shift_at_limit(entry, 120),
            "upper_body_x held at its limit 14.0 cm in 30 of 120 balanced cycles (25.0 %); the centre of mass would "
            "have needed 20.0 cm: r");
  nlohmann::json walking = {{"walks", 1}, {"footsteps", 3}, {"walking_at_end", false}, {"max_body_lead", 0.2},
                            {"walks_at_step_limit", 0}, {"feet_from_body", 0.0},
                            {"steps", {{"max_step_length", 0.25}, {"min_step_width", 0.14}, {"max_step_width", 0.3},
                                       {"step_duration", 0.6}, {"max_steps", 60}, {"max_heel_lead", 2.0}}}};
  EXPECT_EQ(describe_walking(walking)[0].rfind("3 footsteps in 1 walk (", 0), 0u) << describe_walking(walking)[0];
  walking["walks"] = 2;
  EXPECT_EQ(describe_walking(walking)[0].rfind("3 footsteps in 2 walks (", 0), 0u) << describe_walking(walking)[0];
  const nlohmann::json at_end = {{"damped", true},
                                 {"dofs_at_limit", {{{"dof", "a"}, {"limit", "lower"}}, {{"dof", "b"}, {"limit", "upper"}}}}};
  EXPECT_EQ(describe_last_cycle(at_end),
            "damped (near a singularity, or a target out of reach); at a position limit: a (lower), b (upper)");
}

// The report's condition number of a hand's position rows weighs each dof's column by its
// work range (so that metres of the upper body's shift and radians of a joint count by how
// far each can move), and leaves the virtual dofs out for the limb's alone.
TEST(Scenarios, ThePositionConditionNumberWeighsEachDofByItsWorkRange) {
  const Model m = make_paper_model();
  Data d(m);
  std::mt19937_64 rng(36);
  const int f = m.frame_index("l_hand_ref");
  for (int c = 0; c < 20; ++c) {
    forward_kinematics(m, d, wbm_test::random_configuration(m, rng));
    Eigen::MatrixXd J(6, m.num_dofs());
    frame_jacobian(m, d, f, J);
    for (const bool joints_only : {false, true}) {
      Eigen::MatrixXd Jp = J.topRows<3>();
      for (int i = 0; i < m.num_dofs(); ++i)
        Jp.col(i) *= joints_only && m.dof(i).role != DofRole::kJoint ? 0.0 : m.dof(i).work_range;
      const Eigen::VectorXd sv = Eigen::JacobiSVD<Eigen::MatrixXd>(Jp).singularValues();
      EXPECT_NEAR(position_condition_number(m, d, f, joints_only) / (sv[0] / sv[2]), 1.0, 1e-9) << c;
    }
  }
}

// Switched off by the timeline, balance hands the upper body's shift dofs back to the solver
// (b_C = 1, no x_bal): a joint element can then move them (they stayed frozen, driven by the
// last balance velocity, if nothing released them).
TEST(Balance, SwitchedOffItHandsTheUpperBodysShiftBackToTheSolver) {
  const std::string yaml =
      "name: off\nrobot: {builtin: paper}\ndt: 0.002\nduration: 3\nfrozen: [heel_x, heel_y, heel_yaw]\n"
      "balance: {enabled: true}\n"
      "tasks: [{name: shift, type: joints, dofs: [upper_body_x]}]\n"
      "timeline:\n  - {t: 1, balance: false, activate: [shift], targets: {shift: [0.1]}}\n";
  const auto run = run_scenario(parse_scenario(yaml, "off.yaml", "."));
  const int ub_x = run->model->virtual_dofs().ub_x;
  EXPECT_LT(std::abs(run->q.front()[ub_x] - 0.1), 0.09);
  EXPECT_NEAR(run->q.back()[ub_x], 0.1, 1e-3);
  EXPECT_FALSE(run->balance_on_at_end);
}

// A walk given up on (a target 2.5 m up: four short walks, the last step at 6 s) starts
// again when a relative target moves the hand's target where walking helps (1 m further
// ahead, down to table height): a relative target is a new target as an absolute one is.
TEST(Walking, ARelativeTargetAfterGivingUpStartsANewWalk) {
  std::string yaml = wbm_test::read_file(wbm_test::source_path("scenarios/walk_object_ahead.yaml"));
  const std::string target = "targets: {l_hand: [1.5, 0.5, 0.75]";
  ASSERT_NE(yaml.find(target), std::string::npos);
  yaml.replace(yaml.find(target), target.size(), "targets: {l_hand: [0.5, 0.3, 2.5]");
  yaml.replace(yaml.find("duration: 14.0"), 14, "duration: 24.0");
  yaml += "  - {t: 12, relative_targets: {l_hand: [1.0, 0.2, -0.3]}}\n";
  const auto run = run_scenario(parse_scenario(yaml, "walk_again.yaml", "."));
  ASSERT_FALSE(run->footsteps.empty());
  EXPECT_LT(run->footsteps.front().time, 6.0);
  const auto steps_between = [&](double t0, double t1) {
    return std::count_if(run->footsteps.begin(), run->footsteps.end(),
                         [&](const Footstep& f) { return f.time > t0 && f.time < t1; });
  };
  EXPECT_EQ(steps_between(7.0, 12.0), 0);  // given up
  EXPECT_GE(steps_between(12.0, 24.0), 4);
  EXPECT_LT(run->error.back()[run->element("l_hand")], 1e-3);
}

// The report draws at most 1500 samples, the last cycle always among them; an element's target
// only while the element is active (null, a gap, before and after); a position target given
// relative to a frame where that frame puts it in the world at the sample, an axis target
// turned as that frame is.
TEST(Scenarios, TheReportDrawsTargetsInTheWorldWhileActive) {
  const auto run = run_scenario(parse_scenario(
      "name: r\nrobot: {builtin: paper}\ndt: 0.001\nduration: 4\nfrozen: [heel_x, heel_y, heel_yaw]\n"
      "tasks: [{name: rel, type: position, frame: l_hand_ref, reference: upper_body},\n"
      "        {name: grasp, type: axis, frame: r_hand_ref, reference: upper_body}]\n"
      "timeline:\n  - {t: 1, activate: [rel, grasp], relative_targets: {rel: [0.1, 0, 0.1]}, targets: {grasp: [0, 0.6, "
      "0.8]}}\n  - {t: 3, deactivate: [rel, grasp]}\n",
      "r.yaml", "."));
  const Model& m = *run->model;
  const nlohmann::json report = report_data(*run);
  const nlohmann::json& time = report["time"];
  ASSERT_EQ(run->num_cycles(), 4001);
  EXPECT_LE(time.size(), 1500u);
  EXPECT_EQ(time.back().get<double>(), run->time.back());
  const nlohmann::json& targets = report["targets"];
  ASSERT_EQ(targets.size(), 2u);
  Data d(m);
  const int reference = m.frame_index("upper_body");
  int drawn = 0, gaps = 0;
  for (size_t j = 0; j < time.size(); ++j) {
    const double t = time[j].get<double>();
    const auto k = std::lower_bound(run->time.begin(), run->time.end(), t - 1e-12) - run->time.begin();
    const bool active = run->active[k][run->element("rel")] > 0.0;
    ++(active ? drawn : gaps);  // samples
    for (const int e : {0, 1}) {
      const nlohmann::json& value = targets[e]["values"][j];
      if (!active) {
        EXPECT_TRUE(value.is_null()) << "t = " << t;
        continue;
      }
      forward_kinematics(m, d, run->q[k]);
      const Transform X_WR = frame_pose(m, d, reference);
      const Vector3 v = run->commanded_of(e == 0 ? "rel" : "grasp", static_cast<int>(k)).head<3>();
      const Vector3 expected = e == 0 ? Vector3(X_WR * v) : Vector3(X_WR.R * v.normalized());
      ASSERT_FALSE(value.is_null()) << "t = " << t;
      EXPECT_LT((Vector3(value[0].get<double>(), value[1].get<double>(), value[2].get<double>()) - expected).norm(),
                1e-12)
          << "t = " << t;
    }
  }
  EXPECT_GT(drawn, 100);
  EXPECT_GT(gaps, 100);
}

struct BadScenario {
  std::string yaml;
  const char* message;
};

TEST(Scenarios, BadFilesNameTheLineAndField) {
  const BadScenario cases[] = {
      {"name: x\ntasks: [\n", "bad.yaml:3: malformed YAML"},
      {"tasks: [{name: a, type: position, frame: l_hand_ref}]\n", "bad.yaml:1: name: missing"},
      {"name: x\ndt: -1\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n", "bad.yaml:2: dt: expected a number > 0"},
      {"name: x\ndt: fast\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n", "bad.yaml:2: dt: expected a number, got 'fast'"},
      {"name: x\nspeed: 3\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n", "bad.yaml:2: speed: unknown field"},
      {"name: x\ntasks:\n  - {name: a, type: pos, frame: l_hand_ref}\n", "bad.yaml:3: tasks[0].type: unknown type 'pos'"},
      {"name: x\ntasks:\n  - {name: a, type: position}\n", "bad.yaml:3: tasks[0].frame: missing"},
      {"name: x\ntasks:\n  - {name: a, type: position, frame: f, gain: -2}\n", "bad.yaml:3: tasks[0].gain: expected a number >= 0"},
      {"name: x\ntasks:\n  - {name: a, type: position, frame: f, filter: {order: 1}}\n", "bad.yaml:3: tasks[0].filter.order: expected an integer in [2, 6]"},
      {"name: x\ntasks:\n  - {name: a, type: position, frame: f, filter: {order: 7}}\n", "bad.yaml:3: tasks[0].filter.order: expected an integer in [2, 6]"},
      {"name: x\ntasks:\n  - {name: a, type: position, frame: f, filter: {max_speed: 0}}\n", "bad.yaml:3: tasks[0].filter.max_speed: expected a number > 0"},
      // A denormal bandwidth passed "> 0", and the filter's start from a moving value
      // (x + lag * v / bandwidth) overflowed to NaN.
      {"name: x\ntasks:\n  - {name: a, type: position, frame: f, filter: {bandwidth: 1e-320}}\n",
       "bad.yaml:3: tasks[0].filter.bandwidth: expected a number >= 0.001 [1/s]"},
      {"name: x\ntasks:\n  - {name: a, type: position, frame: f}\n  - {name: a, type: axis, frame: f}\n", "bad.yaml:4: tasks[1].name: duplicate element name 'a'"},
      {"name: x\ntasks: [{name: a, type: position, frame: f}]\ntimeline:\n  - {targets: {a: [1, 2, 3]}}\n", "bad.yaml:4: timeline[0].t: missing"},
      {"name: x\nrobot: {builtin: asimo}\ntasks: [{name: a, type: position, frame: f}]\n", "bad.yaml:2: robot.builtin: expected 'paper'"},
      {"name: x\ntasks:\n  - {name: a, type: axis, frame: f, axis: [0, 0]}\n",
       "bad.yaml:3: tasks[0].axis: expected a direction [x, y, z] in the frame"},
      {"name: x\ntasks:\n  - name: a\n    type: position\n    frame: f\n    axis: [1, 0, 0]\n",
       "bad.yaml:6: tasks[0].axis: only for axis tasks"},
      {"name: x\nrobot:\n  builtin: paper\n  root_height: 0.8\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:4: robot.root_height: an option of the URDF import; the built-in paper model takes none"},
      {"name: x\nrobot: {builtin: paper, urdf: g1.urdf}\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: robot.builtin: robot.urdf names the robot; give one of the two"},
      {"name: x\nrobot:\n  urdf: g1.urdf\n  root_rpy: [0, 3.1]\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:4: robot.root_rpy: expected [roll, pitch, yaw] in rad"},
      // Degrees: named at the option's line (it was the URDF's line, in load_urdf's words).
      {"name: x\nrobot:\n  urdf: g1.urdf\n  legs: [a, b]\n  root_rpy: [90, 0, 180]\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:5: robot.root_rpy: expected [roll, pitch, yaw] in rad, each within [-2 pi, 2 pi] (degrees?), got 90, 0, 180"},
      {"name: x\nrobot:\n  urdf: g1.urdf\n  upper_body_pivot: -0.5\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:4: robot.upper_body_pivot: expected a number >= 0"},
      {"name: x\nrobot:\n  builtin: paper\n  upper_body_pivot: 0.5\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:4: robot.upper_body_pivot: an option of the URDF import; the built-in paper model takes none"},
      {"name: x\nrobot:\n  urdf: g1.urdf\n  root_height: -1\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:4: robot.root_height: expected a number >= 0"},
      {"name: x\nrobot:\n  builtin: paper\n  upper_body_x_range: [0, 0.3]\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:4: robot.upper_body_x_range: an option of the URDF import; the built-in paper model takes none"},
      {"name: x\nrobot:\n  urdf: g1.urdf\n  upper_body_x_range: [0.3]\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:4: robot.upper_body_x_range: expected [lower, upper] in m, finite, lower < upper"},
      {"name: x\nrobot:\n  urdf: g1.urdf\n  upper_body_y_range: [0.1, -0.1]\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:4: robot.upper_body_y_range: expected [lower, upper] in m, finite, lower < upper"},
      {"name: x\nrobot:\n  urdf: g1.urdf\n  upper_body_y_range: [-1e7, 0.1]\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:4: robot.upper_body_y_range: expected [lower, upper] in m, finite, lower < upper"},
      {"name: x\ncriterion: {type: cubic, band: 1.5}\ntasks: [{name: a, type: position, frame: f}]\n", "bad.yaml:2: criterion.band: expected a number in [0, 1)"},
      // Sizes that overflowed the cycle count or hung the writer.
      {"name: x\nduration: 1e9\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: duration: duration / dt = 1e+09 s / 0.001 s = 1e+12 cycles; a scenario runs 1 to 1000000 cycles"},
      {"name: x\ndt: 1e-300\ntasks: [{name: a, type: position, frame: f}]\n", "bad.yaml:2: duration: duration / dt = 1 s / 1e-300 s = 1e+300 cycles"},
      {"name: x\ndt: 0.01\nduration: 0.001\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:3: duration: duration / dt = 0.001 s / 0.01 s = 0.1 cycles"},
      {"name: x\nduration: 1\ntasks: [{name: a, type: position, frame: f}]\ntimeline:\n  - t: 5\n    activate: [a]\n",
       "bad.yaml:5: timeline[0].t: 5 s is after the start of the scenario's last cycle (0.999 s; duration 1 s)"},
      // Events out of order (a typo that ran, re-sorted, with its effect at another time).
      {"name: x\nduration: 5\ntasks: [{name: a, type: position, frame: f}]\ntimeline:\n  - t: 3\n    activate: [a]\n"
       "  - t: 3\n    deactivate: [a]\n  - t: 2\n    activate: [a]\n",
       "bad.yaml:9: timeline[2].t: 2 s is before the previous event's 3 s (timeline[1], line 7): list the events in the "
       "order of their times"},
      // Within the last dt before the end: no cycle starts there either.
      {"name: x\ndt: 0.1\nduration: 1\ntasks: [{name: a, type: position, frame: f}]\ntimeline:\n  - t: 0.93\n"
       "    activate: [a]\n",
       "bad.yaml:6: timeline[0].t: 0.93 s is after the start of the scenario's last cycle (0.9 s"},
      {"name: x\nrecord_every: 0.5\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: record_every: expected a whole number of cycles >= 1"},
      {"name: x\nrecord_every: 1e12\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: record_every: expected a whole number of cycles >= 1"},
      // A fixed base keeps the virtual dofs frozen: balance and walking cannot move them.
      {"name: x\nrobot: {fixed_base: true}\nbalance: {enabled: true}\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:3: balance.enabled: balance moves the virtual dofs, which robot.fixed_base keeps frozen"},
      {"name: x\nrobot: {fixed_base: true}\nwalking:\n  enabled: true\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:4: walking.enabled: walking moves the virtual dofs, which robot.fixed_base keeps frozen"},
      {"name: x\nrobot: {fixed_base: true}\ntasks: [{name: a, type: position, frame: f}]\ntimeline:\n  - t: 0.5\n"
       "    balance: true\n",
       "bad.yaml:6: timeline[0].balance: balance moves the virtual dofs, which robot.fixed_base keeps frozen"},
      {"name: x\nrobot: {fixed_base: yes please}\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: robot.fixed_base: expected true or false"},
      {"name: x\nrobot: {builtin: paper, ignore_xacro_elements: true}\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: robot.ignore_xacro_elements: an option of the URDF import; the built-in paper model takes none"},
      {"name: x\nrobot: {urdf: g1.urdf, ignore_xacro_elements: 1.5}\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: robot.ignore_xacro_elements: expected true or false"},
      // The scenario's name is its output directory when several run: it may not leave --out
      // or be --out itself; element names head CSV columns and messages (found by fuzzing).
      {"name: ../elsewhere\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:1: name: '../elsewhere' cannot name the output directory (expected no '/' or '\\', not '.' or '..')"},
      {"name: a/b\ntasks: [{name: a, type: position, frame: f}]\n", "bad.yaml:1: name: 'a/b' cannot name the output directory"},
      {"name: '..'\ntasks: [{name: a, type: position, frame: f}]\n", "bad.yaml:1: name: '..' cannot name the output directory"},
      {"name: " + std::string(256, 'n') + "\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:1: name: a name of 256 bytes cannot name the output directory (at most 255)"},
      {"name: ''\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:1: name: expected a non-empty name without control characters"},
      {"name: x\ntasks:\n  - {name: '', type: position, frame: f}\n",
       "bad.yaml:3: tasks[0].name: expected a non-empty name without control characters"},
      {"name: x\ntasks:\n  - {name: \"a\\tb\", type: position, frame: f}\n",
       "bad.yaml:3: tasks[0].name: expected a non-empty name without control characters"},
      // Each bound at its edge (the cases above lay far beyond most of them, where a bound
      // moved by half or one would still have caught them).
      {"name: x\ndt: .inf\ntasks: [{name: a, type: position, frame: f}]\n", "bad.yaml:2: dt: expected a finite number, got '.inf'"},
      {"name: x\ntasks:\n  - {name: a, type: position, frame: f, filter: {bandwidth: 0.0007}}\n",
       "bad.yaml:3: tasks[0].filter.bandwidth: expected a number >= 0.001 [1/s]"},
      {"name: x\ntasks:\n  - {name: a, type: position, frame: f, gain: -0.5}\n", "bad.yaml:3: tasks[0].gain: expected a number >= 0"},
      {"name: x\nrobot:\n  urdf: g1.urdf\n  upper_body_x_range: [0.1, 0.1]\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:4: robot.upper_body_x_range: expected [lower, upper] in m, finite, lower < upper"},
      {"name: x\nrecord_every: 2.5\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: record_every: expected a whole number of cycles >= 1"},
      {"name: x\nsolver: {nullspace_gain: -0.5}\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: solver.nullspace_gain: expected a number >= 0"},
      {"name: x\ncriterion: {type: cubic, band: 1}\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: criterion.band: expected a number in [0, 1)"},
      {"name: x\nfeet: {left_frame: l_foot}\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: feet: give both left_frame and right_frame, or neither"},
      {"name: x\nfeet: {spacing: 0.2, left_frame: l_foot, right_frame: r_foot}\ntasks: [{name: a, type: position, frame: f}]\n",
       "bad.yaml:2: feet: give the spacing or the foot frames to measure it from, not both"},
      {"name: x\ntasks:\n  - {name: a, type: attitude}\n", "bad.yaml:3: tasks[0].frame: missing (the frame this attitude task moves)"},
      {"name: x\ntasks:\n  - {name: a, type: joints}\n", "bad.yaml:3: tasks[0].dofs: missing (the dofs of this joints task)"},
      {"name: x\ntasks: [{name: a, type: position, frame: f}]\ntimeline:\n  - {t: -0.5, activate: [a]}\n",
       "bad.yaml:4: timeline[0].t: expected a time >= 0 s"},
  };
  for (const BadScenario& c : cases) {
    try {
      parse_scenario(c.yaml, "bad.yaml", ".");
      ADD_FAILURE() << "no error for:\n" << c.yaml;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos) << "got: " << e.what() << "\nwanted: " << c.message;
    }
  }
}

// What a scenario leaves out takes the documented defaults (docs/scenarios.md): the
// trajectory filter's speed limit is 1 rad/s for the angle elements (axis and attitude) and
// FilterParameters' 0.5 m/s for the others; walking's counts are read as given.
TEST(Scenarios, DefaultsAndCountsAreRead) {
  const Scenario s = parse_scenario(
      "name: x\ntasks:\n  - {name: p, type: position, frame: f}\n  - {name: x, type: axis, frame: f}\n"
      "  - {name: t, type: attitude, frame: f}\n  - {name: c, type: com}\n"
      "  - {name: s, type: axis, frame: f, filter: {max_speed: 2}}\nwalking: {max_walks: 5, max_steps: 7}\n",
      "defaults.yaml", ".");
  ASSERT_EQ(s.tasks.size(), 5u);
  EXPECT_EQ(s.tasks[0].filter.max_speed, FilterParameters{}.max_speed);
  EXPECT_EQ(s.tasks[1].filter.max_speed, 1.0);
  EXPECT_EQ(s.tasks[2].filter.max_speed, 1.0);
  EXPECT_EQ(s.tasks[3].filter.max_speed, FilterParameters{}.max_speed);
  EXPECT_EQ(s.tasks[4].filter.max_speed, 2.0);
  EXPECT_EQ(s.walking.parameters.max_walks, 5);
  EXPECT_EQ(s.walking.parameters.max_steps, 7);
  EXPECT_EQ(parse_scenario("name: x\ntasks: [{name: p, type: position, frame: f}]\n", "d.yaml", ".").walking.parameters.max_walks,
            WalkingParameters{}.max_walks);
}

// The record at t = 0 shows the rows as the file starts them (`active: true` on); balance
// switched on only by an event (no balance section) balances from then on; an event's
// deactivate and freeze apply in its cycle (the left elbow then stays put, exactly, while
// the left hand's element, switched on in the same event, moves the rest of the arm).
TEST(Scenarios, TheStartIsRecordedAsGivenAndEventsApplyInTheirCycle) {
  const auto run = run_scenario(parse_scenario(
      "name: s\nduration: 0.2\ntasks:\n  - {name: a, type: position, frame: l_hand_ref, active: false}\n"
      "  - {name: b, type: position, frame: r_hand_ref, active: true}\ntimeline:\n  - {t: 0.1, balance: true}\n"
      "  - {t: 0.15, deactivate: [b], freeze: [l_elbow], activate: [a], relative_targets: {a: [0.1, 0.1, -0.1]}}\n",
      "s.yaml", "."));
  ASSERT_EQ(run->active.size(), 201u);
  EXPECT_EQ(run->active[0][0], 0.0);
  EXPECT_EQ(run->active[0][1], 1.0);
  EXPECT_EQ(summarize(*run)["balance"]["balanced_cycles"].get<int>(), 100);
  EXPECT_EQ(run->active[150][1], 1.0);
  EXPECT_EQ(run->active[151][1], 0.0);
  EXPECT_EQ(run->active.back()[1], 0.0);
  const int elbow = run->model->dof_index("l_elbow"), shoulder = run->model->dof_index("l_shoulder_pitch");
  for (int k = 151; k < 201; ++k) ASSERT_EQ(run->q[k][elbow], run->q[150][elbow]) << k;
  EXPECT_GT(std::abs(run->q.back()[shoulder] - run->q[150][shoulder]), 1e-4);
}

// A scenario built in code can hold a NaN target (files cannot): the controller keeps the
// last valid one (kInvalidTarget) and the recorded distance to the NaN target is NaN, not the
// distance of the other components.
TEST(Scenarios, ANaNTargetBuiltInCodeHasANaNDistance) {
  Scenario s = parse_scenario(
      "name: s\nduration: 0.02\ntasks:\n  - {name: a, type: position, frame: l_hand_ref, active: true}\n"
      "  - {name: j, type: joints, dofs: [l_elbow, head_pan], active: true}\n"
      "timeline:\n  - {t: 0.01, targets: {a: [0.3, 0.2, 0.9], j: [-0.5, 0.3]}}\n",
      "s.yaml", ".");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  s.events[0].targets[0].second[1] = nan;
  s.events[0].targets[1].second[0] = nan;  // a joint row: not hidden by the other's distance
  const auto run = run_scenario(s);
  for (const int e : {0, 1}) {
    EXPECT_TRUE(std::isnan(run->error.back()[e])) << e << ": " << run->error.back()[e];
    EXPECT_TRUE(std::isfinite(run->error[5][e])) << e;
  }
  EXPECT_GT(summarize(*run)["status_cycles"]["invalid_target"].get<int>(), 0);
  for (int k = 0; k < run->num_cycles(); ++k) {
    ASSERT_TRUE(run->q[k].allFinite()) << k;
    ASSERT_TRUE(run->filtered[k].allFinite()) << k;  // the last valid targets kept
  }
}

// Foot frames give the feet's spacing as their lateral distance in the heel frame, whichever
// way the two lie about the heel (here a right foot frame moved 5 cm inwards).
TEST(Scenarios, FootFramesGiveTheSpacingBetweenThem) {
  const wbm_test::ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const auto spacing = [&](const std::string& right) {
    RunOptions options;
    options.check_only = true;
    const auto run = run_scenario(
        parse_scenario("name: f\nrobot:\n  urdf: " + g1.path + "\n  legs: [left_hip_pitch_link, right_hip_pitch_link]\n"
                       "  add_frames: [{name: inner, parent: right_ankle_roll_link, xyz: [0, 0.05, 0]}]\n"
                       "feet: {length: 0.2, width: 0.08, left_frame: left_ankle_roll_link, right_frame: " + right + "}\n"
                       "balance: {enabled: true}\ntasks: [{name: a, type: com}]\n",
                       "f.yaml", "."),
        options);
    return run->feet.spacing;
  };
  const double apart = spacing("right_ankle_roll_link");
  EXPECT_GT(apart, 0.1);
  EXPECT_NEAR(spacing("inner"), apart - 0.05, 1e-12);
}

TEST(Scenarios, UnknownNamesInTheTimelineAreReportedBeforeRunning) {
  const BadScenario cases[] = {
      // The event's field and the entry's line; the closest element name, or all of them.
      {"name: x\ntasks: [{name: a, type: position, frame: l_hand_ref}]\ntimeline:\n  - t: 0.5\n    targets: {nope: [1, 2, 3]}\n",
       "bad.yaml:5: timeline[0].targets: no task element named 'nope' (the elements: a)"},
      {"name: x\ntasks: [{name: l_hand, type: position, frame: l_hand_ref}]\ntimeline:\n  - t: 0.5\n    targets:\n"
       "      l_hand: [1, 2, 3]\n      l_hnd: [1, 2, 3]\n",
       "bad.yaml:7: timeline[0].targets: no task element named 'l_hnd' (did you mean 'l_hand'?)"},
      {"name: x\ntasks: [{name: a, type: position, frame: l_hand_ref}]\ntimeline:\n  - t: 0.5\n    targets: {a: [1, 2]}\n",
       "bad.yaml:5: timeline[0].targets.a: expected 3 values, got 2"},
      {"name: x\ntasks: [{name: a, type: joints, dofs: [l_elbow]}]\ntimeline:\n  - t: 0.5\n    relative_targets: {a: [1, 2]}\n",
       "bad.yaml:5: timeline[0].relative_targets.a: expected 1 value, got 2"},
      {"name: x\ntasks: [{name: a, type: position, frame: l_hand_ref}]\ntimeline:\n  - t: 0.5\n    activate: [a.w]\n",
       "bad.yaml:5: timeline[0].activate: task element 'a' has no row 'w' (its rows: a.x, a.y, a.z)"},
      {"name: x\ntasks: [{name: t, type: attitude, frame: l_hand_ref}]\ntimeline:\n  - t: 0.5\n    activate: [t.w]\n",
       "bad.yaml:5: timeline[0].activate: task element 't' has no row 'w' (its rows: t.roll, t.pitch, t.yaw)"},
      {"name: x\ntasks: [{name: v, type: axis, frame: head_camera}]\ntimeline:\n  - t: 0.5\n    relative_targets: {v: [0, 0, 1]}\n",
       "bad.yaml:5: timeline[0].relative_targets.v: axis targets must be absolute directions"},
      {"name: x\ntasks: [{name: v, type: axis, frame: head_camera}]\ntimeline:\n  - t: 0.5\n    targets: {v: [0, 0, 0]}\n",
       "bad.yaml:5: timeline[0].targets.v: the direction must not be zero"},
      {"name: x\ntasks: [{name: hand, type: position, frame: l_hand_ref}]\ntimeline:\n  - t: 0.5\n    deactivate: [hnd]\n",
       "bad.yaml:5: timeline[0].deactivate: no task element named 'hnd' (did you mean 'hand'?)"},
      // Names the model lacks: the scenario's line and field, then the model's message.
      {"name: x\ntasks:\n  - {name: b, type: axis, frame: head_camera}\n  - {name: a, type: position, frame: no_frame}\n",
       "bad.yaml:4: tasks[1]: model 'paper_asimo_like' has no frame named 'no_frame'"},
      {"name: x\ntasks:\n  - {name: a, type: position, frame: l_hand_ref, reference: nope}\n",
       "bad.yaml:3: tasks[0]: model 'paper_asimo_like' has no frame named 'nope'"},
      {"name: x\ntasks:\n  - {name: a, type: joints, dofs: [l_elbow, nope]}\n",
       "bad.yaml:3: tasks[0]: model 'paper_asimo_like' has no dof named 'nope'"},
      {"name: x\nfrozen: [heel_x, nope]\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n",
       "bad.yaml:2: frozen: model 'paper_asimo_like' has no dof named 'nope'"},
      {"name: x\ninitial: {nope: 0.1}\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n",
       "bad.yaml:2: initial: model 'paper_asimo_like' has no dof named 'nope'"},
      {"name: x\ninitial: {l_shoulder_pitch: 0.1, l_elbow: 5}\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n",
       "bad.yaml:2: initial: configuration value 5 of dof 'l_elbow' is outside [-2.4, 0]"},
      {"name: x\nfeet: {left_frame: nope, right_frame: r_hand}\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n",
       "bad.yaml:2: feet: model 'paper_asimo_like' has no frame named 'nope'"},
      // Two bad names: the first in the file, whichever is used first (tasks are built first).
      {"name: x\nfrozen: [heel_x, nope]\ntasks: [{name: a, type: position, frame: no_frame}]\n",
       "bad.yaml:2: frozen: model 'paper_asimo_like' has no dof named 'nope'"},
      {"name: x\ntasks: [{name: a, type: position, frame: no_frame}]\nfrozen: [heel_x, nope]\ninitial: {nope: 0.1}\n",
       "bad.yaml:2: tasks[0]: model 'paper_asimo_like' has no frame named 'no_frame'"},
      {"name: x\ntasks:\n  - {name: a, type: position, frame: l_hand_ref}\n  - {name: b, type: axis, frame: no_frame}\n"
       "initial: {nope: 0.1}\n",
       "bad.yaml:4: tasks[1]: model 'paper_asimo_like' has no frame named 'no_frame'"},
      // Values the library refuses: its message, with the scenario's line.
      {"name: x\ntasks:\n  - {name: a, type: axis, frame: head_camera, axis: [0, 0, 0]}\n",
       "bad.yaml:3: tasks[0]: axis task 'a': the axis in frame 'head_camera' must be a finite, non-zero vector"},
      {"name: x\nrobot: {urdf: no_such.urdf}\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n",
       "bad.yaml:2: robot: ./no_such.urdf: cannot open the file"},
      {"name: x\nrobot: {urdf: .}\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n",
       "bad.yaml:2: robot: ./.: is a directory, not a URDF file"},
      {"name: x\ntasks: [{name: a, type: position, frame: l_hand_ref}]\ntimeline:\n  - t: 0.5\n    release: [nope]\n",
       "bad.yaml:4: release: model 'paper_asimo_like' has no dof named 'nope'"},
      {"name: x\nrobot: {fixed_base: true}\ntasks: [{name: a, type: position, frame: l_hand_ref}]\ntimeline:\n"
       "  - t: 0.5\n    release: [l_elbow, upper_body_pitch]\n",
       "bad.yaml:5: release: 'upper_body_pitch' is a virtual dof, which robot.fixed_base keeps frozen"},
  };
  for (const BadScenario& c : cases) {
    // check_only looks every name up as the full run does (the CLI checks all files first).
    for (const bool check_only : {true, false}) {
      RunOptions options;
      options.check_only = check_only;
      try {
        run_scenario(parse_scenario(c.yaml, "bad.yaml", "."), options);
        ADD_FAILURE() << "no error (check_only " << check_only << ") for:\n" << c.yaml;
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos) << "got: " << e.what() << "\nwanted: " << c.message;
      }
    }
  }
}

// robot.ignore_xacro_elements is the import option: a file with xacro leftovers (docs/model.md)
// loads with it, and without it the import's message stands at the robot's line.
TEST(Scenarios, IgnoreXacroElementsIsTheImportOption) {
  const std::string xml = wbm_test::read_file(wbm_test::source_path("models/dual_arm/dual_arm.urdf"));
  const std::string file = testing::TempDir() + "wbm_scenario_xacro.urdf";
  const std::string robot_tag = "<robot name=\"dual_arm\">";
  ASSERT_NE(xml.find(robot_tag), std::string::npos);
  std::ofstream(file) << std::string(xml).replace(xml.find(robot_tag), robot_tag.size(),
                                                  robot_tag + "<xacro:property name=\"h\" value=\"1\"/>");
  const std::string rest = "tasks: [{name: a, type: position, frame: left_tool}]\nduration: 0.01\n";
  const Scenario s = parse_scenario("name: x\nrobot: {urdf: '" + file + "', fixed_base: true, ignore_xacro_elements: true}\n" + rest,
                                    "ok.yaml", ".");
  EXPECT_TRUE(s.urdf_options.ignore_xacro_elements);
  EXPECT_NO_THROW(run_scenario(s));
  try {
    run_scenario(parse_scenario("name: x\nrobot: {urdf: '" + file + "', fixed_base: true}\n" + rest, "bad.yaml", "."));
    ADD_FAILURE() << "xacro leftovers accepted without the option";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml:2: robot: "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("<xacro:property> is a xacro element"), std::string::npos) << e.what();
  }
  std::remove(file.c_str());
}

// A robot whose root link is turned without robot.root_rpy (its legs point backward) runs;
// summary.json's model_notes and the report's summary table say so; as it is, no note.
TEST(Scenarios, TheModelsNotesAreInTheSummaryAndTheReport) {
  const std::string g1 = wbm_test::shipped_model("g1_29dof").path;
  const std::string robot = "robot: {urdf: '" + g1 + "', legs: [left_hip_pitch_link, right_hip_pitch_link]";
  const std::string rest = "duration: 0.02\nfrozen: [heel_x, heel_y, heel_yaw]\n"
                           "tasks: [{name: a, type: position, frame: left_rubber_hand}]\n";
  const auto turned = run_scenario(
      parse_scenario("name: t\n" + robot + ", root_rpy: [0, 1.5707963, 0], root_height: 0.8}\n" + rest, "t.yaml", "."));
  const nlohmann::json notes = summarize(*turned)["model_notes"];
  ASSERT_EQ(notes.size(), 1u) << notes;
  EXPECT_EQ(notes[0].get<std::string>().rfind("the legs point backward rather than down", 0), 0u) << notes;
  int rows = 0;
  const nlohmann::json report = report_data(*turned);  // kept: a range-for over a temporary's member dangles
  for (const auto& row : report["summary"])
    if (row[0] == "note on the model") {
      EXPECT_EQ(row[1], notes[0]);
      ++rows;
    }
  EXPECT_EQ(rows, 1);
  const auto plain = run_scenario(parse_scenario("name: p\n" + robot + "}\n" + rest, "p.yaml", "."));
  EXPECT_EQ(summarize(*plain)["model_notes"], nlohmann::json::array());
  EXPECT_EQ(summarize(*run_scenario(parse_scenario("name: x\n" + rest.substr(0, rest.find("tasks")) +
                                                   "tasks: [{name: a, type: position, frame: l_hand_ref}]\n",
                                                   "x.yaml", ".")))["model_notes"],
            nlohmann::json::array());
}

// An element that no dof free in the scenario moves is noted before the run (summary.json
// task_notes, the report, wbm run's console): on a fixed base a view axis on the torso, which
// only the (frozen) virtual dofs turn (Kuavo's camera on its base link ran with a 48 degree
// error and every cycle damped, without a word). Dofs released by an event count as free;
// elements never switched on are not noted.
// A joint target outside the dof's range ran without a word and ended with the element's
// error (an initial value there is an error; a target is a wish the joint cannot meet).
TEST(Scenarios, AJointTargetOutsideItsRangeIsNoted) {
  const wbm::Model paper = wbm::make_paper_model();
  const wbm::Dof& elbow = paper.dof(paper.dof_index("l_elbow"));
  const auto notes = [&](const std::string& targets) {
    const auto run = run_scenario(parse_scenario(
        "name: n\nduration: 0.01\ntasks: [{name: j, type: joints, dofs: [head_pan, l_elbow]}]\n"
        "timeline:\n  - t: 0.005\n    activate: [j]\n    " + targets + "\n",
        "n.yaml", "."));
    return summarize(*run)["task_notes"];
  };
  const nlohmann::json outside = notes("targets: {j: [0.1, " + std::to_string(elbow.lower - 1.0) + "]}");
  ASSERT_EQ(outside.size(), 1u) << outside;
  std::ostringstream expected;
  expected << "task 'j': the target of 'l_elbow', " << elbow.lower - 1.0 << " (timeline[0].targets, line 7), lies outside "
           << "its range [" << elbow.lower << ", " << elbow.upper << "]: the joint stops at its limit, 1 rad short";
  EXPECT_EQ(outside[0].get<std::string>(), expected.str()) << outside;
  EXPECT_EQ(notes("targets: {j: [0.1, " + std::to_string(elbow.lower + 0.1) + "]}"), nlohmann::json::array());
  const nlohmann::json above = notes("targets: {j: [0.1, " + std::to_string(elbow.upper + 0.5) + "]}");
  ASSERT_EQ(above.size(), 1u) << above;
  EXPECT_NE(above[0].get<std::string>().find("the joint stops at its limit, 0.5 rad short"), std::string::npos) << above;
  // A relative target's value is known only when the event applies: not noted.
  EXPECT_EQ(notes("relative_targets: {j: [0.1, -9]}"), nlohmann::json::array());
}

// Balance on a URDF robot without its feet uses the paper robot's: noted (the margin it reports
// is for those feet); with feet given, or on the paper model, nothing.
TEST(Scenarios, DefaultFeetOnAUrdfRobotAreNoted) {
  const wbm_test::ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const auto notes = [&](const std::string& robot, const std::string& rest) {
    const auto run = run_scenario(parse_scenario("name: f\n" + robot + "duration: 0.01\nfrozen: [heel_x, heel_y, heel_yaw]\n"
                                                 "tasks: [{name: a, type: com}]\n" + rest,
                                                 "f.yaml", "."));
    return summarize(*run)["task_notes"];
  };
  const std::string urdf = "robot: {urdf: '" + g1.path + "', legs: [left_hip_pitch_link, right_hip_pitch_link]}\n";
  const nlohmann::json defaults = notes(urdf, "balance: {enabled: true}\n");
  ASSERT_EQ(defaults.size(), 1u) << defaults;
  EXPECT_EQ(defaults[0].get<std::string>(),
            "balance and walking use the default feet (0.22 m long, 0.12 m wide, 0.18 m apart: the paper's robot's), "
            "not this robot's: give them with feet: {length, width, left_frame, right_frame} (docs/scenarios.md)");
  EXPECT_EQ(notes(urdf, "timeline: [{t: 0.005, balance: true}]\n").size(), 1u);  // switched on later
  EXPECT_EQ(notes(urdf, "balance: {enabled: true}\nfeet: {length: 0.2, width: 0.08}\n"), nlohmann::json::array());
  EXPECT_EQ(notes(urdf, ""), nlohmann::json::array());  // no balance
  EXPECT_EQ(notes("", "balance: {enabled: true}\n"), nlohmann::json::array());  // the paper model's own feet
}

// robot.add_frames: a hand point at the end of H1's forearm (no URDF link marks it) is a
// frame like any other: a position task on it reaches its target.
TEST(Scenarios, AddedFramesCanCarryTasks) {
  const wbm_test::ShippedModel& h1 = wbm_test::shipped_model("h1");
  const auto run = run_scenario(parse_scenario(
      "name: a\nrobot:\n  urdf: '" + h1.path + "'\n  legs: [left_hip_yaw_link, right_hip_yaw_link]\n"
      "  add_frames: [{name: left_hand_point, parent: left_elbow_link, xyz: [0.3, 0, 0]}]\n"
      "duration: 2\nfrozen: [heel_x, heel_y, heel_yaw]\n"
      "tasks: [{name: hand, type: position, frame: left_hand_point}]\n"
      "timeline: [{t: 0.1, activate: [hand], relative_targets: {hand: [0.05, 0.0, 0.05]}}]\n",
      "a.yaml", "."));
  const nlohmann::json summary = summarize(*run);
  EXPECT_LT(summary["elements"]["hand"]["final_error"].get<double>(), 1.0) << summary["elements"];  // [mm], of 71
  // Errors name the field and line; the built-in model takes no URDF options.
  const auto error = [](const std::string& text) {
    try {
      parse_scenario(text, "bad.yaml", ".");
    } catch (const wbm::Error& e) {
      return std::string(e.what());
    }
    return std::string("(parsed)");
  };
  const std::string head = "name: x\nrobot:\n  urdf: h1.urdf\n";
  const std::string tasks = "tasks: [{name: a, type: position, frame: f}]\n";
  EXPECT_EQ(error(head + "  add_frames: {name: p}\n" + tasks),
            "bad.yaml:4: robot.add_frames: expected a list of {name, parent, xyz, rpy}");
  EXPECT_EQ(error(head + "  add_frames: [{name: p, xyz: [0, 0, 0]}]\n" + tasks),
            "bad.yaml:4: robot.add_frames[0]: expected name and parent (a frame of the robot)");
  EXPECT_EQ(error(head + "  add_frames: [{name: p, parent: l, xyz: [0, 0]}]\n" + tasks),
            "bad.yaml:4: robot.add_frames[0].xyz: expected [x, y, z] in m, finite");
  EXPECT_EQ(error(head + "  add_frames: [{name: p, parent: l, rpy: [0, 0, 1e9]}]\n" + tasks),
            "bad.yaml:4: robot.add_frames[0].rpy: expected [roll, pitch, yaw] in rad, finite");
  EXPECT_EQ(error("name: x\nrobot:\n  builtin: paper\n  add_frames: [{name: p, parent: l}]\n" + tasks),
            "bad.yaml:4: robot.add_frames: an option of the URDF import; the built-in paper model takes none (add robot.urdf)");
}

TEST(Scenarios, AnElementNoFreeDofMovesIsNoted) {
  const std::string robot =
      "robot: {urdf: '" + wbm_test::source_path("models/dual_arm/dual_arm.urdf") + "', fixed_base: true}\n";
  const std::string tasks =
      "tasks: [{name: view, type: axis, frame: torso, axis: [1, 0, 0], active: true},\n"
      "        {name: lift, type: position, frame: torso, active: true},\n"
      "        {name: left, type: position, frame: left_tool, active: true},\n"
      "        {name: idle, type: axis, frame: base}]\n";
  const std::string arm =
      "[torso_lift, left_joint1, left_joint2, left_joint3, left_joint4, left_joint5, left_joint6, left_joint7]";
  const auto notes = [&](const std::string& rest) {
    const auto run = run_scenario(parse_scenario("name: n\n" + robot + "duration: 0.01\n" + tasks + rest, "n.yaml", "."));
    return summarize(*run)["task_notes"];
  };
  const nlohmann::json frozen_arm = notes("frozen: " + arm + "\n");
  ASSERT_EQ(frozen_arm.size(), 3u) << frozen_arm;  // view, lift, left
  EXPECT_EQ(frozen_arm[0].get<std::string>().rfind("task 'view': only frozen dofs move it (heel_yaw, upper_body_roll, "
                                                   "upper_body_pitch, upper_body_yaw; frozen by robot.fixed_base",
                                                   0),
            0u)
      << frozen_arm;
  EXPECT_EQ(frozen_arm[1].get<std::string>().rfind("task 'lift': only frozen dofs move it (", 0), 0u) << frozen_arm;
  EXPECT_EQ(frozen_arm[2].get<std::string>().rfind("task 'left': only frozen dofs move it (", 0), 0u) << frozen_arm;
  // Six named, then how many more: every virtual dof, the torso lift and six arm joints (the
  // seventh turns the tool about its own axis, so its position column is zero; a mover is any
  // entry above rounding, not only a large one).
  EXPECT_EQ(frozen_arm[2].get<std::string>().rfind("task 'left': only frozen dofs move it (heel_x, heel_y, heel_yaw, "
                                                   "upper_body_x, upper_body_y, upper_body_z and 10 more; frozen by",
                                                   0),
            0u)
      << frozen_arm;
  // One arm joint released later: the hand can move.
  const nlohmann::json released = notes("frozen: " + arm + "\ntimeline: [{t: 0.005, release: [left_joint3]}]\n");
  ASSERT_EQ(released.size(), 2u) << released;  // view, and lift: the torso_lift stays frozen
  EXPECT_EQ(released[0].get<std::string>().rfind("task 'view': ", 0), 0u) << released;
  // The idle element's frame is welded to the root: noted once it is switched on.
  const nlohmann::json idle = notes("timeline: [{t: 0.005, activate: [idle]}]\n");
  ASSERT_EQ(idle.size(), 2u) << idle;
  EXPECT_EQ(idle[1].get<std::string>().rfind("task 'idle': ", 0), 0u) << idle;
  // Without the fixed base the virtual dofs turn the torso: nothing to note.
  const auto free_base = run_scenario(parse_scenario(
      "name: f\nrobot: {urdf: '" + wbm_test::source_path("models/dual_arm/dual_arm.urdf") + "'}\nduration: 0.01\n" + tasks,
      "f.yaml", "."));
  EXPECT_EQ(summarize(*free_base)["task_notes"], nlohmann::json::array());
  // A dof moves an element where any entry of its column is above rounding: the left arm's last
  // joint turns a tool axis 3 degrees off its own (entries about 0.05), not one along it.
  const auto wrist_notes = [&](const std::string& axis) {
    const auto wrist = run_scenario(parse_scenario(
        "name: w\n" + robot + "duration: 0.01\n" +
            "frozen: [torso_lift, left_joint1, left_joint2, left_joint3, left_joint4, left_joint5, left_joint6]\n" +
            "tasks: [{name: tilt, type: axis, frame: left_tool, axis: [" + axis + "], active: true}]\n",
        "w.yaml", "."));
    return summarize(*wrist)["task_notes"].size();
  };
  EXPECT_EQ(wrist_notes("0.05, 0, 0.99875"), 0u);
  EXPECT_EQ(wrist_notes("0, 0, 1"), 1u);
  // The dofs balance (the upper body's shift) and walking (the heel) drive count as free: with
  // every dof frozen, the centre of mass is noted unless balance is on, a hand unless walking is.
  const Model paper = make_paper_model();
  std::string all_dofs;
  for (int i = 0; i < paper.num_dofs(); ++i) all_dofs += (i ? ", " : "") + paper.dof(i).name;
  const auto paper_notes = [&](const std::string& rest) {
    const auto frozen_run = run_scenario(parse_scenario(
        "name: p\nrobot: {builtin: paper}\nduration: 0.01\nfrozen: [" + all_dofs + "]\n" + rest, "p.yaml", "."));
    return summarize(*frozen_run)["task_notes"].size();
  };
  const std::string com = "tasks: [{name: c, type: com, active: true}]\n";
  const std::string hand = "tasks: [{name: h, type: position, frame: l_hand_ref, active: true}]\n";
  EXPECT_EQ(paper_notes(com), 1u);
  EXPECT_EQ(paper_notes("balance: {enabled: true}\n" + com), 0u);
  EXPECT_EQ(paper_notes(hand), 1u);
  EXPECT_EQ(paper_notes("walking: {enabled: true}\n" + hand), 0u);
  // The report's table has the note.
  const auto run = run_scenario(parse_scenario("name: r\n" + robot + "duration: 0.01\n" + tasks, "r.yaml", "."));
  const nlohmann::json report = report_data(*run);  // kept: a range-for over a temporary's member dangles
  int rows = 0;
  for (const auto& row : report["summary"]) rows += row[0] == "note on a task" ? 1 : 0;
  EXPECT_EQ(rows, 1);
}

// root_rpy's range is load_urdf's rule: its message, at the scenario's robot line.
TEST(Scenarios, RootRpyOutOfRangeNamesTheRobotLine) {
  const std::string g1 = wbm_test::shipped_model("g1_29dof").path;
  try {
    run_scenario(parse_scenario("name: x\nrobot: {urdf: '" + g1 + "', root_rpy: [0, 0, 7]}\n"
                                "tasks: [{name: a, type: position, frame: pelvis}]\n",
                                "bad.yaml", "."));
    ADD_FAILURE() << "root_rpy 7 rad accepted";
  } catch (const Error& e) {
    // Checked by the scenario at the option's line (load_urdf's own check names the option too).
    EXPECT_EQ(std::string(e.what()), "bad.yaml:2: robot.root_rpy: expected [roll, pitch, yaw] in rad, each within "
                                     "[-2 pi, 2 pi] (degrees?), got 0, 0, 7")
        << e.what();
  }
}

TEST(Scenarios, ATargetFarOutOfReachHasAFiniteErrorAndMotion) {
  // 1e308 m away: the squared distance overflowed, the error column read inf and the hand
  // did not move (the filter stepped by max_speed dt / sqrt(inf) = 0).
  const Scenario s = parse_scenario(
      "name: x\nduration: 0.5\nfrozen: [heel_x, heel_y, heel_yaw]\n"
      "tasks: [{name: a, type: position, frame: l_hand_ref}, {name: j, type: joints, dofs: [l_elbow]}]\n"
      "timeline:\n  - t: 0.05\n    activate: [a, j]\n    targets: {a: [1e308, 1e308, 0.8], j: [-1e308]}\n",
      "far.yaml", ".");
  const auto run = run_scenario(s);
  const int last = run->num_cycles() - 1;
  const int a = run->element("a"), j = run->element("j");
  EXPECT_NEAR(run->error[last][a] / (std::sqrt(2.0) * 1e308), 1.0, 1e-12);
  EXPECT_NEAR(run->error[last][j] / 1e308, 1.0, 1e-12);
  for (int k = 0; k <= last; ++k) ASSERT_TRUE(run->q[k].allFinite() && run->error[k].allFinite()) << "cycle " << k;
  // The hand heads for the target (x = y) at up to 0.5 m/s (the default speed limit): 0.14 m in 0.45 s.
  const Eigen::Vector3d moved = run->actual_of("a", last).head<3>() - run->actual_of("a", 0).head<3>();
  EXPECT_GT(moved.dot(Eigen::Vector3d(1.0, 1.0, 0.0).normalized()), 0.05) << moved.transpose();
}

// Why a target is left unmet, for the console line "last cycle: ...": summary.json's at_end
// says whether the last cycle was damped and which joints sit at a position limit (a Jaco
// hand stopped 37.6 mm short with a shoulder at its limit, and only the error was printed).
TEST(Scenarios, TheSummarySaysWhatHeldTheLastCycle) {
  const std::string head = "name: x\nduration: 3\nfrozen: [heel_x, heel_y, heel_yaw]\n"
                           "tasks: [{name: a, type: position, frame: l_hand_ref}, {name: j, type: joints, dofs: [l_elbow]}]\n";
  const auto at_end = [&](const std::string& timeline) {
    return summarize(*run_scenario(parse_scenario(head + timeline, "x.yaml", ".")))["at_end"];
  };
  // The elbow driven past its lower limit: held there, the joint row damped.
  const nlohmann::json held = at_end("timeline: [{t: 0.05, activate: [j], relative_targets: {j: [-5]}}]\n");
  EXPECT_TRUE(held["damped"].get<bool>()) << held;
  EXPECT_EQ(held["dofs_at_limit"], nlohmann::json::parse(R"([{"dof": "l_elbow", "limit": "lower"}])")) << held;
  // The hand 2 m out: the stretched arm damped, no joint at a limit.
  const nlohmann::json far = at_end("timeline: [{t: 0.05, activate: [a], relative_targets: {a: [0, 2, 0]}}]\n");
  EXPECT_TRUE(far["damped"].get<bool>()) << far;
  // Reached: nothing held it.
  const nlohmann::json reached = at_end("timeline: [{t: 0.05, activate: [a], relative_targets: {a: [0.05, 0, 0.05]}}]\n");
  EXPECT_FALSE(reached["damped"].get<bool>()) << reached;
  EXPECT_EQ(reached["dofs_at_limit"], nlohmann::json::array()) << reached;
}

TEST(Scenarios, CheckOnlyBuildsEverythingAndSimulatesNothing) {
  const Scenario s = parse_scenario(
      "name: x\nduration: 2\ntasks: [{name: a, type: position, frame: l_hand_ref}]\ntimeline:\n  - t: 0.5\n"
      "    activate: [a]\n    relative_targets: {a: [0.1, 0, 0]}\n",
      "ok.yaml", ".");
  RunOptions options;
  options.check_only = true;
  const auto checked = run_scenario(s, options);
  ASSERT_TRUE(checked->controller);
  EXPECT_EQ(checked->num_cycles(), 0);
  EXPECT_EQ(run_scenario(s)->num_cycles(), 2001);
}

}  // namespace
