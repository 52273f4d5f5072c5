// Kinematic core: Jacobians against finite differences of forward kinematics on every
// shipped model, allocation-free evaluation, the paper model's layout, re-rooting and the
// URDF export round trip.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_counter.hpp"
#include "closest_names.hpp"
#include "fast_trig.hpp"
#include "zero_block.hpp"
#include "shipped_models.hpp"
#include "test_util.hpp"
#include "wbm/errors.hpp"
#include "wbm/kinematics.hpp"
#include "wbm/paper_model.hpp"
#include "wbm/urdf_import.hpp"

namespace {

using wbm::Data;
using wbm::Model;
using wbm::Transform;
using wbm::Vector3;
using wbm_test::ShippedModel;

constexpr int kConfigurations = 1000;  // per model
constexpr int kFramesPerConfiguration = 8;
constexpr double kStep = 1e-6;         // central-difference step [rad] or [m]
constexpr double kFdTolerance = 1e-6;  // |analytic - finite difference|, per entry
constexpr int kMaxReportedFailures = 8;

/// The shipped models plus the import variants (re-rooted, legs dropped, synthetic).
std::vector<ShippedModel> kinematic_cases() {
  std::vector<ShippedModel> cases = wbm_test::shipped_models();
  for (const ShippedModel& m : wbm_test::import_variants()) cases.push_back(m);
  return cases;
}

/// Deterministic seed per model id (std::hash is not portable across libraries).
std::uint64_t seed_for(const std::string& id) {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a
  for (unsigned char c : id) h = (h ^ c) * 1099511628211ull;
  return h;
}

/// Collects failures with context, reporting only the first few in detail.
class FailureLog {
 public:
  explicit FailureLog(std::string model) : model_(std::move(model)) {}
  void check(const Model& model, int config, const Eigen::VectorXd& q, const std::string& what, int column,
             const Eigen::VectorXd& analytic, const Eigen::VectorXd& numeric, double tolerance) {
    const double err = (analytic - numeric).cwiseAbs().maxCoeff();
    if (err <= tolerance && std::isfinite(err)) return;
    if (++failures_ > kMaxReportedFailures) return;
    ADD_FAILURE() << "model " << model_ << ", configuration #" << config << ", " << what << ", column " << column
                  << " (dof '" << model.dof(column).name << "'): analytic " << wbm_test::describe_vector(analytic)
                  << " vs finite difference " << wbm_test::describe_vector(numeric) << ", error " << err
                  << " > " << tolerance << "\n  q = " << wbm_test::describe_configuration(model, q);
  }
  int failures() const { return failures_; }

 private:
  std::string model_;
  int failures_ = 0;
};

class Kinematics : public testing::TestWithParam<ShippedModel> {};

// Every column of every Jacobian against central differences of forward kinematics:
// frame_jacobian (rows 0-2 translation, rows 3-5 rotation via the log of R+ R-^T),
// point_jacobian and rotational_jacobian of a random point/body, com_jacobian.
TEST_P(Kinematics, JacobiansMatchFiniteDifferences) {
  const ShippedModel& entry = GetParam();
  const Model model = entry.load();
  const int nq = model.num_dofs();
  const int nf = model.num_frames();
  const int nb = model.num_bodies();
  std::mt19937_64 rng(seed_for(entry.id));
  wbm_test::Deck frame_deck(nf, rng);
  wbm_test::Deck body_deck(nb, rng);
  std::vector<bool> frame_seen(nf, false), body_seen(nb, false);

  Data data(model), plus(model), minus(model);
  std::vector<int> frames(kFramesPerConfiguration);
  std::vector<Eigen::MatrixXd> J(kFramesPerConfiguration, Eigen::MatrixXd(6, nq));
  Eigen::MatrixXd Jp(3, nq), Jr(3, nq), Jc(3, nq);
  const bool has_mass = model.total_mass() > 0.0;  // else no centre of mass (a URDF without masses)
  FailureLog log(entry.id);

  for (int c = 0; c < kConfigurations && log.failures() <= kMaxReportedFailures; ++c) {
    const Eigen::VectorXd q = wbm_test::random_configuration(model, rng);
    wbm::forward_kinematics(model, data, q);
    if (has_mass) wbm::center_of_mass(model, data);
    for (int k = 0; k < kFramesPerConfiguration; ++k) {
      frames[k] = frame_deck.next();
      frame_seen[frames[k]] = true;
      wbm::frame_jacobian(model, data, frames[k], J[k]);
    }
    const int body = body_deck.next();
    body_seen[body] = true;
    const Vector3 r_BQ = wbm_test::random_vector3(rng, 0.3);  // point fixed to the body
    wbm::point_jacobian(model, data, body, data.X_WB[body] * r_BQ, Jp);
    wbm::rotational_jacobian(model, data, body, Jr);
    if (has_mass) wbm::com_jacobian(model, data, Jc);

    for (int i = 0; i < nq; ++i) {
      Eigen::VectorXd qp = q, qm = q;
      qp[i] += kStep;
      qm[i] -= kStep;
      wbm::forward_kinematics(model, plus, qp);
      wbm::forward_kinematics(model, minus, qm);
      for (int k = 0; k < kFramesPerConfiguration; ++k) {
        const Transform Xp = wbm::frame_pose(model, plus, frames[k]);
        const Transform Xm = wbm::frame_pose(model, minus, frames[k]);
        Eigen::VectorXd fd(6);
        fd.head<3>() = (Xp.p - Xm.p) / (2 * kStep);
        fd.tail<3>() = wbm_test::rotation_log(Xp.R * Xm.R.transpose()) / (2 * kStep);
        log.check(model, c, q, "frame_jacobian of '" + model.frame(frames[k]).name + "'", i, J[k].col(i), fd,
                  kFdTolerance);
      }
      const Eigen::VectorXd fd_point = (plus.X_WB[body] * r_BQ - minus.X_WB[body] * r_BQ) / (2 * kStep);
      log.check(model, c, q, "point_jacobian of body '" + model.body(body).name + "'", i, Jp.col(i), fd_point,
                kFdTolerance);
      const Eigen::VectorXd fd_rot =
          wbm_test::rotation_log(plus.X_WB[body].R * minus.X_WB[body].R.transpose()) / (2 * kStep);
      log.check(model, c, q, "rotational_jacobian of body '" + model.body(body).name + "'", i, Jr.col(i), fd_rot,
                kFdTolerance);
      if (!has_mass) continue;
      const Eigen::VectorXd fd_com =
          (wbm::center_of_mass(model, plus) - wbm::center_of_mass(model, minus)) / (2 * kStep);
      log.check(model, c, q, "com_jacobian", i, Jc.col(i), fd_com, kFdTolerance);
    }
  }
  EXPECT_EQ(log.failures(), 0) << "Jacobian mismatches in model " << entry.id;
  // Every frame and every body was checked at least once.
  for (int f = 0; f < nf; ++f) EXPECT_TRUE(frame_seen[f]) << "frame " << model.frame(f).name << " never checked";
  for (int b = 0; b < nb; ++b) EXPECT_TRUE(body_seen[b]) << "body " << model.body(b).name << " never checked";
}

// J q̇ against FK differentiated along a random direction, for all frames and the com at
// once: covers mimic joints, whose columns sum several bodies' contributions.
TEST_P(Kinematics, JacobianTimesVelocityMatchesDirectionalDerivative) {
  const ShippedModel& entry = GetParam();
  const Model model = entry.load();
  const int nq = model.num_dofs();
  std::mt19937_64 rng(seed_for(entry.id) + 1);
  Data data(model), plus(model), minus(model);
  Eigen::MatrixXd J(6, nq), Jc(3, nq);
  const bool has_mass = model.total_mass() > 0.0;  // else no centre of mass (a URDF without masses)
  int failures = 0;
  for (int c = 0; c < kConfigurations && failures < kMaxReportedFailures; ++c) {
    const Eigen::VectorXd q = wbm_test::random_configuration(model, rng);
    const Eigen::VectorXd v = wbm_test::random_direction(nq, rng);
    const Eigen::VectorXd qp = q + kStep * v, qm = q - kStep * v;
    wbm::forward_kinematics(model, data, q);
    wbm::forward_kinematics(model, plus, qp);
    wbm::forward_kinematics(model, minus, qm);
    for (int f = 0; f < model.num_frames(); ++f) {
      wbm::frame_jacobian(model, data, f, J);
      const Transform Xp = wbm::frame_pose(model, plus, f), Xm = wbm::frame_pose(model, minus, f);
      Eigen::VectorXd fd(6);
      fd.head<3>() = (Xp.p - Xm.p) / (2 * kStep);
      fd.tail<3>() = wbm_test::rotation_log(Xp.R * Xm.R.transpose()) / (2 * kStep);
      const Eigen::VectorXd Jv = J * v;
      const double err = (Jv - fd).cwiseAbs().maxCoeff();
      if (!(err <= kFdTolerance) && ++failures <= kMaxReportedFailures)
        ADD_FAILURE() << "model " << entry.id << ", configuration #" << c << ", frame '" << model.frame(f).name
                      << "': J v = " << wbm_test::describe_vector(Jv) << " vs d/dt FK = " << wbm_test::describe_vector(fd)
                      << ", error " << err << "\n  q = " << wbm_test::describe_configuration(model, q)
                      << "\n  v = " << wbm_test::describe_vector(v);
    }
    if (!has_mass) continue;
    wbm::center_of_mass(model, data);
    wbm::com_jacobian(model, data, Jc);
    const Eigen::VectorXd fd_com =
        (wbm::center_of_mass(model, plus) - wbm::center_of_mass(model, minus)) / (2 * kStep);
    const double err = (Jc * v - fd_com).cwiseAbs().maxCoeff();
    if (!(err <= kFdTolerance) && ++failures <= kMaxReportedFailures)
      ADD_FAILURE() << "model " << entry.id << ", configuration #" << c << ", com: error " << err
                    << "\n  q = " << wbm_test::describe_configuration(model, q);
  }
  EXPECT_EQ(failures, 0);
}

// The mimic coverage above is real: these models have dofs that drive several bodies.
// moving_bodies(b) lists exactly the bodies with a dof on the path from the root to b, b's
// side first, and a dof outside it has a zero Jacobian column at every configuration.
TEST_P(Kinematics, MovingBodiesAreTheChainToTheRoot) {
  const ShippedModel& entry = GetParam();
  const Model model = entry.load();
  std::mt19937_64 rng(seed_for(entry.id) + 7);
  Data data(model);
  Eigen::MatrixXd J(3, model.num_dofs());
  for (int b = 0; b < model.num_bodies(); ++b) {
    std::vector<int> expected;
    for (int a = b; a >= 0; a = model.body(a).parent)
      if (model.body(a).dof >= 0) expected.push_back(a);
    const std::span<const int> chain = model.moving_bodies(b);
    ASSERT_EQ(std::vector<int>(chain.begin(), chain.end()), expected) << entry.id << " body " << model.body(b).name;
    std::vector<bool> moves(model.num_dofs(), false);
    for (const int a : chain) moves[model.body(a).dof] = true;
    forward_kinematics(model, data, wbm_test::random_configuration(model, rng));
    point_jacobian(model, data, b, data.X_WB[b] * Vector3(0.1, -0.2, 0.3), J);
    for (int d = 0; d < model.num_dofs(); ++d) {
      if (!moves[d]) {
        ASSERT_TRUE(J.col(d).isZero(0.0)) << entry.id << " body " << b << " dof " << d;
      }
    }
  }
}

// Forward kinematics visits the bodies in depth_order(): every body once, each after its
// parent, the depths never falling, bodies of one depth in index order (so neighbours in
// the loop are mostly on different branches and their pose products can overlap).
TEST_P(Kinematics, DepthOrderVisitsEveryBodyOnceAfterItsParent) {
  const ShippedModel& entry = GetParam();
  const Model model = entry.load();
  const std::vector<int>& order = model.depth_order();
  ASSERT_EQ(static_cast<int>(order.size()), model.num_bodies()) << entry.id;
  std::vector<int> position(model.num_bodies(), -1), depth(model.num_bodies(), 0);
  for (int b = 0; b < model.num_bodies(); ++b)
    depth[b] = model.body(b).parent < 0 ? 0 : depth[model.body(b).parent] + 1;
  for (int i = 0; i < static_cast<int>(order.size()); ++i) {
    const int b = order[i];
    ASSERT_TRUE(b >= 0 && b < model.num_bodies() && position[b] < 0) << entry.id << " entry " << i;
    position[b] = i;
    const int parent = model.body(b).parent;
    if (parent >= 0) {
      EXPECT_LT(position[parent], i) << entry.id << " body " << model.body(b).name;
    }
    if (i > 0) {
      const int a = order[i - 1];
      EXPECT_TRUE(depth[a] < depth[b] || (depth[a] == depth[b] && a < b)) << entry.id << " entries " << i - 1 << ", " << i;
    }
  }
}

TEST_P(Kinematics, MimicModelsShareDofs) {
  const ShippedModel& entry = GetParam();
  if (!entry.has_mimic.has_value())
    GTEST_SKIP() << entry.id << ": not known whether its dofs should be shared (KdlComparison checks mimic joints)";
  const Model model = entry.load();
  std::vector<int> driven(model.num_dofs(), 0);
  int scaled = 0;
  for (const wbm::Body& b : model.bodies()) {
    if (b.dof < 0) continue;
    ++driven[b.dof];
    if (b.multiplier != 1.0 || b.offset != 0.0) ++scaled;
  }
  const bool shared = std::any_of(driven.begin(), driven.end(), [](int n) { return n > 1; });
  EXPECT_EQ(shared, *entry.has_mimic) << entry.id;
  if (entry.id.rfind("synthetic", 0) == 0 || entry.id == "nao") {
    EXPECT_GT(scaled, 0) << entry.id;
  }
}

// The frames named in shipped_models exist.
TEST_P(Kinematics, NamedFramesExist) {
  const ShippedModel& entry = GetParam();
  const Model model = entry.load();
  for (const std::string& name : {entry.left_hand, entry.right_hand, entry.head})
    if (!name.empty()) {
      EXPECT_GE(model.find_frame(name), 0) << entry.id << ": " << name;
    }
}

// upright_base_configuration: the root link (upper body) stands at (0, 0, root height) with
// the world's axes (or turned against them by root_rpy), whatever the other joints do; only the virtual dofs change. With the
// KDL comparison (poses relative to the root link), every link is then where the URDF puts
// it, lifted by the root height: the fixed base of e.g. models/dual_arm.
TEST_P(Kinematics, UprightBasePutsTheRootAtItsHeightWithTheWorldAxes) {
  const ShippedModel& entry = GetParam();
  const Model model = entry.load();
  const wbm::VirtualDofs& v = model.virtual_dofs();
  ASSERT_GE(v.ub_z, 0) << entry.id;
  // The root link's origin, below the upper body's pivot where it lies at the feet.
  const double pivot = wbm::upper_body_pivot_above_root(model);
  const double height = model.dof(v.ub_z).upper - pivot;
  std::mt19937_64 rng(seed_for(entry.id) + 5);
  Data data(model);
  for (int c = 0; c < 50; ++c) {
    const Eigen::VectorXd q = wbm_test::random_configuration(model, rng);
    const Eigen::VectorXd upright = wbm::upright_base_configuration(model, q);
    for (int i = 0; i < model.num_dofs(); ++i)
      if (model.dof(i).role == wbm::DofRole::kJoint) {
        ASSERT_EQ(upright[i], q[i]) << model.dof(i).name;
      }
    model.check_configuration(upright);
    wbm::forward_kinematics(model, data, upright);
    const Transform& X_WU = data.X_WB[v.upper_body];
    // The world's axes, or the root link's turn (root_rpy) against them.
    const wbm::Matrix3& R_UR = model.body(v.upper_body).X_PJ.R;
    ASSERT_LT((X_WU.R - R_UR).cwiseAbs().maxCoeff(), 1e-12) << entry.id;
    ASSERT_LT((X_WU.p - wbm::Vector3(0.0, 0.0, height)).cwiseAbs().maxCoeff(), 1e-12) << entry.id;
    ASSERT_LT(data.X_WB[v.heel_body].p.norm(), 1e-12) << entry.id;
  }
  if (entry.id == "dual_arm") {  // its URDF's world link, kept as a frame on the base
    wbm::forward_kinematics(model, data, wbm::upright_base_configuration(model, model.home()));
    const Transform X_WF = wbm::frame_pose(model, data, model.frame_index("world"));
    EXPECT_LT((X_WF.p - wbm::Vector3(0.0, 0.0, height)).norm(), 1e-12);
  }
  EXPECT_THROW(wbm::upright_base_configuration(model, Eigen::VectorXd::Zero(model.num_dofs() + 1)), wbm::ModelError);
}

// Forward kinematics, poses, Jacobians and the centre of mass allocate nothing, also when
// the Jacobian is a block of a larger matrix (as a solver stacks them).
TEST_P(Kinematics, EvaluationDoesNotAllocate) {
  const ShippedModel& entry = GetParam();
  const Model model = entry.load();
  const int nq = model.num_dofs();
  std::mt19937_64 rng(seed_for(entry.id) + 2);
  Data data(model);
  const Eigen::VectorXd q = wbm_test::random_configuration(model, rng);
  std::vector<double> raw(q.data(), q.data() + nq);
  const Eigen::Map<const Eigen::VectorXd> q_map(raw.data(), nq);
  Eigen::MatrixXd J6(6, nq), J3(3, nq), stacked(15, nq);
  Eigen::Matrix<double, 6, Eigen::Dynamic> J6_fixed(6, nq);
  const int hand = model.frame_index(entry.left_hand);
  const int body = model.frame(hand).body;
  double sink = 0.0;

  wbm_test::AllocationCounter counter;
  for (int rep = 0; rep < 3; ++rep) {
    wbm::forward_kinematics(model, data, q);
    wbm::forward_kinematics(model, data, q_map);
    for (int f = 0; f < model.num_frames(); ++f) {
      const Transform X = wbm::frame_pose(model, data, f);
      sink += X.p.x();
      wbm::frame_jacobian(model, data, f, J6);
    }
    wbm::frame_jacobian(model, data, hand, J6_fixed);
    wbm::frame_jacobian(model, data, hand, stacked.middleRows(3, 6));
    wbm::point_jacobian(model, data, body, data.X_WB[body].p, J3);
    wbm::point_jacobian(model, data, body, data.X_WB[body].p, stacked.topRows(3));
    wbm::rotational_jacobian(model, data, body, J3);
    wbm::rotational_jacobian(model, data, body, stacked.bottomRows(3));
    if (model.total_mass() > 0.0) {  // else no centre of mass (a URDF without masses)
      sink += wbm::center_of_mass(model, data).z();
      wbm::com_jacobian(model, data, J3);
      wbm::com_jacobian(model, data, stacked.middleRows(9, 3));
    }
  }
  const auto allocations = counter.count();
  EXPECT_EQ(allocations, 0) << entry.id << ": kinematics allocated " << allocations << " times";
  EXPECT_TRUE(std::isfinite(sink));
  EXPECT_TRUE(stacked.middleRows(3, 6).isApprox(J6_fixed));
}

// A Data reused along a trajectory (its joints' sines and cosines rotated from the anchors
// of earlier calls, fast_trig.hpp) gives the poses of a fresh Data to the last bits: random
// walks of up to 0.06 rad per dof and step, with jumps that move the anchors.
TEST_P(Kinematics, ReusedDataAgreesWithAFreshOne) {
  const ShippedModel& entry = GetParam();
  const Model model = entry.load();
  std::mt19937_64 rng(seed_for(entry.id) + 3);
  std::uniform_real_distribution<double> step(-0.06, 0.06);
  Data reused(model);
  double worst = 0.0;
  int anchored = 0;  // bodies whose sine and cosine came from an anchor
  for (int walk = 0; walk < 20; ++walk) {
    Eigen::VectorXd q = wbm_test::random_configuration(model, rng);
    for (int k = 0; k < 100; ++k) {
      for (int i = 0; i < q.size(); ++i) q[i] += step(rng);
      wbm::forward_kinematics(model, reused, q);
      Data fresh(model);
      wbm::forward_kinematics(model, fresh, q);
      for (int b = 0; b < model.num_bodies(); ++b) {
        const double error = std::max((reused.X_WB[b].R - fresh.X_WB[b].R).cwiseAbs().maxCoeff(),
                                      (reused.X_WB[b].p - fresh.X_WB[b].p).cwiseAbs().maxCoeff());
        worst = std::max(worst, error);
        ASSERT_LE(error, 1e-14) << entry.id << ": body " << model.body(b).name << ", walk " << walk << ", step " << k
                                << "\n  q = " << wbm_test::describe_configuration(model, q);
        // A fresh Data anchors every revolute joint at its angle (no anchor, NaN, otherwise).
        const double fresh_anchor = fresh.angle_anchor[b].angle;
        anchored += !std::isnan(fresh_anchor) && reused.angle_anchor[b].angle != fresh_anchor;
      }
    }
  }
  std::cout << entry.id << ": largest pose difference " << worst << ", anchored sines " << anchored << "\n";
  if (model.num_dofs() > 9) {
    EXPECT_GT(anchored, 0) << "the anchors were never used";
  }
}

INSTANTIATE_TEST_SUITE_P(Models, Kinematics, testing::ValuesIn(kinematic_cases()), wbm_test::ModelIdName());

// The anchored sine and cosine of forward kinematics against the library: inside the 1/8
// rad window (boundary included) within 2.5e-16 and the anchor stays; outside it and for a
// fresh (NaN) anchor the library's values exactly and the anchor moves. Long walks of small
// steps show that the error does not build up.
TEST(AnchoredSinCos, MatchesTheLibraryAndKeepsItsAnchor) {
  std::mt19937_64 rng(41);
  const double window = wbm::internal::kSeriesRange;  // 1/8
  std::uniform_real_distribution<double> where(-7.0, 7.0), within(-window, window), beyond(window + 0.005, 3.0);
  double worst = 0.0;
  const int cases = 10 * wbm_test::property_cases();
  for (int c = 0; c < cases; ++c) {
    wbm::Data::AngleAnchor anchor;
    double s, co;
    // On the window's boundary, anchors on a 2^-10 grid make angle - a0 = 1/8 exact.
    const double a0 = c % 4 < 2 ? std::ldexp(std::round(std::ldexp(where(rng), 10)), -10) : where(rng);
    wbm::internal::anchored_sin_cos(a0, anchor, s, co);
    ASSERT_EQ(anchor.angle, a0);
    ASSERT_EQ(s, std::sin(a0));
    ASSERT_EQ(co, std::cos(a0));
    const double d = c % 4 == 0 ? window : c % 4 == 1 ? -window : within(rng);
    const double angle = a0 + d;
    wbm::internal::anchored_sin_cos(angle, anchor, s, co);
    const double error = std::max(std::abs(s - std::sin(angle)), std::abs(co - std::cos(angle)));
    worst = std::max(worst, error);
    ASSERT_LE(error, 2.5e-16) << "anchor " << a0 << ", angle " << angle;
    ASSERT_EQ(anchor.angle, a0) << "the anchor moved for a step of " << d;
    // Just beyond the window, or farther.
    const double far = a0 + (c % 2 ? -1 : 1) * (c % 3 == 0 ? window + 1e-9 : beyond(rng));
    wbm::internal::anchored_sin_cos(far, anchor, s, co);
    ASSERT_EQ(anchor.angle, far);
    ASSERT_EQ(s, std::sin(far));
    ASSERT_EQ(co, std::cos(far));
  }
  wbm::Data::AngleAnchor anchor;
  double angle = 0.3, s, co;
  for (int k = 0; k < 1000000; ++k) {
    angle += 1e-3 * within(rng);
    wbm::internal::anchored_sin_cos(angle, anchor, s, co);
    worst = std::max(worst, std::max(std::abs(s - std::sin(angle)), std::abs(co - std::cos(angle))));
  }
  EXPECT_LE(worst, 2.5e-16);
  std::cout << "largest error " << worst << "\n";
}

// ---------------------------------------------------------------------------------------
// The allocation counter itself.

struct alignas(64) OverAligned {
  double v[8];
};

/// Keeps the optimiser from removing new/delete pairs (allowed since C++14).
void* volatile g_escape = nullptr;

// The Jacobian blocks' zeroing (one fixed-size loop per row count up to 8, a generic loop
// above, one pass where the block is whole columns): exactly the block, nothing around it.
TEST(ZeroBlock, ClearsExactlyTheBlockForEveryRowCount) {
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> value(1.0, 2.0);
  for (int rows = 1; rows <= 12; ++rows)
    for (const int extra : {0, 1, 5}) {  // stride - rows (0: whole columns)
      const int stride = rows + extra, cols = 7;
      std::vector<double> buffer(static_cast<std::size_t>(stride * (cols + 2)));
      for (double& x : buffer) x = value(rng);
      const std::vector<double> before = buffer;
      double* block = buffer.data() + stride;  // one column before and after left alone
      wbm::internal::zero_block(block, rows, cols, stride);
      for (int k = 0; k < static_cast<int>(buffer.size()); ++k) {
        const int offset = k - stride;
        const bool inside = offset >= 0 && offset < cols * stride && offset % stride < rows;
        if (inside)
          ASSERT_EQ(buffer[k], 0.0) << rows << " rows, stride " << stride << ", entry " << offset;
        else
          ASSERT_EQ(buffer[k], before[k]) << rows << " rows, stride " << stride << ", entry " << offset;
      }
    }
}

TEST(AllocationCounter, CountsVectorAllocations) {
  wbm_test::AllocationCounter counter;
  std::vector<double> v(100, 1.0);
  g_escape = v.data();
  EXPECT_GT(counter.count(), 0);
}

TEST(AllocationCounter, CountsEveryOperatorNewVariant) {
  wbm_test::AllocationCounter counter;
  int* a = new int(1);
  g_escape = a;
  delete a;
  EXPECT_EQ(counter.count(), 1);
  int* b = new int[7];
  g_escape = b;
  delete[] b;
  EXPECT_EQ(counter.count(), 2);
  int* c = new (std::nothrow) int(3);
  g_escape = c;
  delete c;
  EXPECT_EQ(counter.count(), 3);
  auto* d = new OverAligned;
  g_escape = d;
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(d) % 64, 0u);
  delete d;
  EXPECT_EQ(counter.count(), 4);
  auto* e = new OverAligned[3];
  g_escape = e;
  delete[] e;
  EXPECT_EQ(counter.count(), 5);
  auto* f = new (std::nothrow) OverAligned;
  g_escape = f;
  delete f;
  EXPECT_EQ(counter.count(), 6);
  const auto frees = wbm_test::deallocations();
  auto g = std::make_unique<double>(2.0);
  g_escape = g.get();
  g.reset();
  EXPECT_EQ(wbm_test::deallocations(), frees + 1);
}

TEST(AllocationCounter, SeesAllocationsInsideLibwbm) {
  const Model model = wbm::make_paper_model();
  wbm_test::AllocationCounter counter;
  Data data(model);  // sizes its buffers: allocates inside the library
  g_escape = data.X_WB.data();
  EXPECT_GT(counter.count(), 0);
  counter.reset();
  EXPECT_THROW(model.frame_index("no_such_frame"), wbm::ModelError);  // builds a message
  EXPECT_GT(counter.count(), 0);
}

// ---------------------------------------------------------------------------------------
// The built-in paper model (section II, eq. 1).

Eigen::VectorXd zero_arm_configuration(const Model& model) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(model.num_dofs());
  q[model.virtual_dofs().ub_z] = model.dof(model.virtual_dofs().ub_z).upper;  // standing straight
  return q;
}

TEST(PaperModel, DofsInTheOrderOfEquation1) {
  const Model model = wbm::make_paper_model();
  const std::vector<std::string> expected = {
      "heel_x", "heel_y", "heel_yaw", "upper_body_x", "upper_body_y", "upper_body_z", "upper_body_roll",
      "upper_body_pitch", "upper_body_yaw", "l_shoulder_pitch", "l_shoulder_roll", "l_shoulder_yaw", "l_elbow",
      "l_hand_rot", "r_shoulder_pitch", "r_shoulder_roll", "r_shoulder_yaw", "r_elbow", "r_hand_rot", "head_pan",
      "head_tilt"};
  ASSERT_EQ(model.num_dofs(), 21);
  for (int i = 0; i < 21; ++i) EXPECT_EQ(model.dof(i).name, expected[i]) << "dof " << i;
  const wbm::VirtualDofs& v = model.virtual_dofs();
  EXPECT_EQ(v.heel_x, 0);
  EXPECT_EQ(v.heel_y, 1);
  EXPECT_EQ(v.heel_yaw, 2);
  EXPECT_EQ(v.ub_x, 3);
  EXPECT_EQ(v.ub_y, 4);
  EXPECT_EQ(v.ub_z, 5);
  EXPECT_EQ(v.ub_roll, 6);
  EXPECT_EQ(v.ub_pitch, 7);
  EXPECT_EQ(v.ub_yaw, 8);
  EXPECT_EQ(model.dof(0).role, wbm::DofRole::kHeelX);
  EXPECT_EQ(model.dof(8).role, wbm::DofRole::kUpperBodyYaw);
  EXPECT_EQ(model.dof(9).role, wbm::DofRole::kJoint);
  EXPECT_EQ(model.dof(0).type, wbm::JointType::kPrismatic);
  EXPECT_EQ(model.dof(2).type, wbm::JointType::kRevolute);
  EXPECT_TRUE(model.dof(2).continuous);
  EXPECT_EQ(model.body(v.heel_body).name, "heel");
  EXPECT_EQ(model.body(v.upper_body).name, "upper_body");
  for (int i = 0; i < 21; ++i) {
    EXPECT_GT(model.dof(i).max_speed, 0.0) << model.dof(i).name;
    EXPECT_GT(model.dof(i).work_range, 0.0) << model.dof(i).name;
  }
  EXPECT_NO_THROW(model.check_configuration(model.home()));
}

TEST(PaperModel, MassAndFrames) {
  const Model model = wbm::make_paper_model();
  EXPECT_NEAR(model.total_mass(), 54.0, 0.5);
  for (const char* name : {"l_hand_ref", "r_hand_ref", "head_camera", "heel", "upper_body"})
    EXPECT_GE(model.find_frame(name), 0) << name;
}

// A misspelt frame or dof name gets the closest names in its error (case ignored; failing
// those, the shortest names that contain it), and the list of all names; a name like no
// other gets only the list.
TEST(PaperModel, UnknownNamesSuggestTheClosest) {
  const wbm::Model model = wbm::make_paper_model();
  auto message = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const wbm::ModelError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string typo = message([&] { model.frame_index("l_hnd_ref"); });
  EXPECT_NE(typo.find("has no frame named 'l_hnd_ref' (did you mean 'l_hand_ref'?); frames are: heel_x"),
            std::string::npos)
      << typo;
  const std::string upper = message([&] { model.frame_index("R_HAND"); });
  EXPECT_NE(upper.find("(did you mean 'r_hand'?)"), std::string::npos) << upper;
  const std::string part = message([&] { model.frame_index("hand"); });
  EXPECT_NE(part.find("(did you mean 'l_hand', 'r_hand' or 'l_hand_ref'?)"), std::string::npos) << part;
  // A name typed with an ending the model's lacks (the URDF's link is "l_hand", the user wrote
  // "l_hand_link"): beyond the edit distance, found as a part of what was typed.
  const std::string suffixed = message([&] { model.frame_index("l_hand_link"); });
  EXPECT_NE(suffixed.find("has no frame named 'l_hand_link' (did you mean 'l_hand'?)"), std::string::npos) << suffixed;
  const std::string dof = message([&] { model.dof_index("l_elbo"); });
  EXPECT_NE(dof.find("has no dof named 'l_elbo' (did you mean 'l_elbow'?); dofs are: heel_x heel_y heel_yaw"),
            std::string::npos)
      << dof;
  const std::string none = message([&] { model.frame_index("xyz"); });
  EXPECT_EQ(none.find("did you mean"), std::string::npos) << none;
  EXPECT_NE(none.find("; frames are:"), std::string::npos) << none;
}

// Past 40 names the list says how many it left out and where they all are (a user's frame
// past the 40th was neither suggested nor shown).
TEST(UrdfImport, ALongListOfNamesSaysHowManyItLeavesOut) {
  const Model g1 = wbm_test::shipped_model("g1_29dof").load();
  ASSERT_EQ(g1.num_frames(), 48);
  try {
    g1.frame_index("no_such_frame");
    ADD_FAILURE() << "no error";
  } catch (const wbm::ModelError& e) {
    EXPECT_NE(std::string(e.what()).find(" ... (8 more of 48; `wbm model info` lists them all)"), std::string::npos)
        << e.what();
  }
}

// Standing straight at zero joint values, the shipped robots' lowest link origin lies as far
// above the ground as their soles below it: G1's collision spheres 3.5 cm below the ankle roll
// links, H1's and Atlas's foot boxes 6.2 and 7.4 cm; NAO's force-sensor boxes 2.5 mm below its
// sole links, Romeo's sole links themselves (before, every one of them had its lowest link
// origin on the ground, the soles below it).
// MuJoCo's capsules (URDFs converted from MJCF use them for feet), which urdfdom drops with a
// message: the soles count them too. G1's foot spheres written as capsules lying along x give
// the same height; standing upright, 1 cm of axis more below (0.792 m before, 0.757 from the
// ankle's origin when they were dropped); a visual capsule lower still changes nothing.
TEST(UrdfImport, CapsulesUnderTheFeetCountForTheSoles) {
  const wbm_test::ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const std::string xml = wbm_test::read_file(g1.path);
  const auto with_capsules = [&](const std::string& rpy, bool visual_marker = false) {
    std::string edited = xml;
    // A visual capsule 10 cm below each foot (a marker, as EngineAI PM v2's sphere): the
    // collision capsules decide, the visual ones count only for a link without collisions.
    for (const std::string link : {"left_ankle_roll_link", "right_ankle_roll_link"}) {
      const std::string tag = "<link name=\"" + link + "\">";
      const std::size_t at = edited.find(tag);
      EXPECT_NE(at, std::string::npos) << link;
      if (visual_marker && at != std::string::npos)
        edited.insert(at + tag.size(), "<visual><origin xyz=\"0 0 -0.1\"/><geometry><capsule radius=\"0.01\" "
                                       "length=\"0.02\"/></geometry></visual>");
    }
    int replaced = 0;
    for (std::size_t at = edited.find("<collision>"); at != std::string::npos; at = edited.find("<collision>", at + 1)) {
      const std::size_t end = edited.find("</collision>", at);
      const std::size_t sphere = edited.find("<sphere radius=\"0.005\"/>", at);
      if (sphere == std::string::npos || sphere > end) continue;
      edited.replace(sphere, 25, "<capsule radius=\"0.005\" length=\"0.02\"/>");
      const std::size_t origin_rpy = edited.find("rpy=\"0 0 0\"", at);
      if (origin_rpy < sphere) edited.replace(origin_rpy, 11, "rpy=\"" + rpy + "\"");
      ++replaced;
    }
    EXPECT_GE(replaced, 8);  // four under each foot
    const Model m = wbm::parse_urdf(edited, g1.options, "g1_capsules.urdf");
    return m.dof(m.virtual_dofs().ub_z).upper;
  };
  const Model original = g1.load();
  const double height = original.dof(original.virtual_dofs().ub_z).upper;
  EXPECT_NEAR(with_capsules("0 1.5707963267948966 0"), height, 1e-12);
  EXPECT_NEAR(with_capsules("0 0 0"), height + 0.01, 1e-12);
  EXPECT_NEAR(with_capsules("0 0 0", true), height + 0.01, 1e-12);
}

TEST(UrdfImport, TheShippedRobotsStandOnTheirSoles) {
  for (const auto& [id, above] : {std::pair{"g1_29dof", 0.035}, std::pair{"h1", 0.062}, std::pair{"atlas", 0.0741},
                                  std::pair{"nao", 0.0025}, std::pair{"romeo_small", 0.0}}) {
    const Model model = wbm_test::shipped_model(id).load();
    Eigen::VectorXd q = Eigen::VectorXd::Zero(model.num_dofs());
    q[model.virtual_dofs().ub_z] = model.dof(model.virtual_dofs().ub_z).upper;
    Data data(model);
    wbm::forward_kinematics(model, data, q);
    double lowest = std::numeric_limits<double>::infinity();  // of the robot's frames, not the virtual chain's
    for (int f = model.virtual_dofs().upper_body; f < model.num_frames(); ++f)
      lowest = std::min(lowest, wbm::frame_position(model, data, f).z());
    EXPECT_NEAR(lowest, above, 5e-4) << id;
  }
}

// Links welded by fixed joints become one body: masses add, the centre of mass is their
// mass-weighted mean, and each link's inertia, turned into the body's frame (its joint's and its
// inertial's rotations), is shifted to that centre by the parallel-axis theorem. Checked by hand:
// "base" (1 kg, diag(1, 2, 3)) with "cap" (1 kg, diag(4, 5, 6)) welded 1 m above it and turned
// by yaw pi/2 (so diag(5, 4, 6) in the base's frame): 2 kg at (0, 0, 0.5), each 0.5 m off it
// (m d^2 = 0.25 about x and y, none about z), diag(6.5, 6.5, 9). The arm's inertial is turned by
// roll pi/2, which moves its off-diagonal ixy = 0.1 to the x-z entries.
TEST(UrdfImport, WeldedLinksInertialsAreMergedAboutTheirCommonCentre) {
  const std::string xml = R"(<robot name="inertials">
  <link name="base"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="3"/></inertial></link>
  <link name="cap"><inertial><mass value="1"/><inertia ixx="4" ixy="0" ixz="0" iyy="5" iyz="0" izz="6"/></inertial></link>
  <link name="arm"><inertial><origin xyz="0.1 0 0" rpy="1.5707963267948966 0 0"/><mass value="2"/>
    <inertia ixx="1" ixy="0.1" ixz="0" iyy="2" iyz="0" izz="3"/></inertial></link>
  <joint name="weld" type="fixed"><parent link="base"/><child link="cap"/>
    <origin xyz="0 0 1" rpy="0 0 1.5707963267948966"/></joint>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0.2 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>)";
  const Model model = wbm::parse_urdf(xml, {}, "inertials.urdf");
  const wbm::Inertial& base = model.body(model.virtual_dofs().upper_body).inertial;
  ASSERT_EQ(model.body(model.virtual_dofs().upper_body).name, "base");
  EXPECT_NEAR(base.mass, 2.0, 1e-15);
  EXPECT_LT((base.com - Vector3(0, 0, 0.5)).norm(), 1e-15);
  EXPECT_LT((base.inertia - Vector3(6.5, 6.5, 9.0).asDiagonal().toDenseMatrix()).cwiseAbs().maxCoeff(), 1e-12)
      << base.inertia;
  const wbm::Inertial& arm = model.body(model.num_bodies() - 1).inertial;
  ASSERT_EQ(model.body(model.num_bodies() - 1).name, "arm");
  EXPECT_NEAR(arm.mass, 2.0, 1e-15);
  EXPECT_LT((arm.com - Vector3(0.1, 0, 0)).norm(), 1e-15);
  wbm::Matrix3 expected;
  expected << 1.0, 0.0, 0.1, 0.0, 3.0, 0.0, 0.1, 0.0, 2.0;
  EXPECT_LT((arm.inertia - expected).cwiseAbs().maxCoeff(), 1e-12) << arm.inertia;
}

// default_limits (--default-limits) fills in what a joint's <limit> leaves out: a revolute
// joint without a position range gets [-pi, pi] rad, a prismatic one [-1, 1] m; without a
// speed limit 2 rad/s and 0.5 m/s (a continuous joint without <limit> too). A negative effort
// limit means none (0), with or without the option.
TEST(UrdfImport, DefaultLimitsFillWhatTheFileLeavesOut) {
  const std::string xml = R"(<robot name="defaults">
  <link name="base"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="a"/><link name="b"/><link name="c"/><link name="d"/>
  <joint name="turn" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit effort="1" velocity="0"/></joint>
  <joint name="slide" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0" effort="1" velocity="0"/></joint>
  <joint name="spin" type="continuous"><parent link="b"/><child link="c"/><axis xyz="0 1 0"/></joint>
  <joint name="no_effort" type="revolute"><parent link="c"/><child link="d"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="-1" velocity="3"/></joint>
</robot>)";
  wbm::UrdfImportOptions options;
  options.default_limits = true;
  const Model model = wbm::parse_urdf(xml, options, "defaults.urdf");
  const wbm::Dof& turn = model.dof(model.dof_index("turn"));
  EXPECT_EQ(turn.lower, -M_PI);
  EXPECT_EQ(turn.upper, M_PI);
  EXPECT_EQ(turn.max_speed, 2.0);
  const wbm::Dof& slide = model.dof(model.dof_index("slide"));
  EXPECT_EQ(slide.lower, -1.0);
  EXPECT_EQ(slide.upper, 1.0);
  EXPECT_EQ(slide.max_speed, 0.5);
  const wbm::Dof& spin = model.dof(model.dof_index("spin"));
  EXPECT_TRUE(spin.continuous);
  EXPECT_EQ(spin.max_speed, 2.0);
  const wbm::Dof& no_effort = model.dof(model.dof_index("no_effort"));
  EXPECT_EQ(no_effort.max_effort, 0.0);
  EXPECT_EQ(no_effort.max_speed, 3.0);
  EXPECT_EQ(no_effort.upper, 1.0);
  const std::string one_joint = R"(<robot name="no_effort">
  <link name="base"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="d"/>
  <joint name="no_effort" type="revolute"><parent link="base"/><child link="d"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="-1" velocity="3"/></joint>
</robot>)";  // without the option: a joint that needs none
  const Model plain = wbm::parse_urdf(one_joint, {}, "no_effort.urdf");
  EXPECT_EQ(plain.dof(plain.dof_index("no_effort")).max_effort, 0.0);
}

// A locked leg is welded at its joints' zero values, a mimic joint in it at its offset (what
// the mimic formula gives for a master at 0): its links lie where the free model puts them at
// zero joint values, and the root stands as high above the ground as the foot lies below it.
TEST(UrdfImport, ALockedLegIsWeldedWithItsMimicJointsAtTheirOffsets) {
  const std::string xml = R"(<robot name="mimic_leg">
  <link name="pelvis"><inertial><mass value="5"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="thigh"/><link name="shin"/><link name="foot"/>
  <joint name="hip" type="revolute"><parent link="pelvis"/><child link="thigh"/><origin xyz="0 0 -0.1"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="knee" type="revolute"><parent link="thigh"/><child link="shin"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/><mimic joint="hip" multiplier="2" offset="0.5"/></joint>
  <joint name="ankle" type="fixed"><parent link="shin"/><child link="foot"/><origin xyz="0 0 -0.4"/></joint>
</robot>)";
  wbm::UrdfImportOptions legs;
  legs.legs = {"thigh"};
  const Model locked = wbm::parse_urdf(xml, legs, "mimic_leg.urdf");
  const Model free = wbm::parse_urdf(xml, {}, "mimic_leg.urdf");
  EXPECT_NEAR(locked.dof(locked.virtual_dofs().ub_z).upper, 0.1 + 0.4 * std::cos(0.5), 1e-12);
  const auto foot_from_pelvis = [](const Model& model) {
    Data data(model);
    wbm::forward_kinematics(model, data, wbm::upright_base_configuration(model, Eigen::VectorXd::Zero(model.num_dofs())));
    return Vector3(wbm::frame_position(model, data, model.frame_index("foot")) -
                   wbm::frame_position(model, data, model.frame_index("pelvis")));
  };
  const Vector3 expected(-0.4 * std::sin(0.5), 0.0, -0.1 - 0.4 * std::cos(0.5));
  EXPECT_LT((foot_from_pelvis(locked) - expected).norm(), 1e-12) << foot_from_pelvis(locked).transpose();
  EXPECT_LT((foot_from_pelvis(free) - expected).norm(), 1e-12) << foot_from_pelvis(free).transpose();
}

// Frames added to an imported model (a hand point at the end of H1's forearm, where the URDF
// has no link): where the parent frame puts them on random configurations, with a Jacobian
// that matches central differences of their pose, drawn from their parent, and exported and
// imported again with the same pose.
TEST(UrdfImport, AddedFramesSitOnTheirParentFrames) {
  const ShippedModel& h1 = wbm_test::shipped_model("h1");
  wbm::UrdfImportOptions options = h1.options;
  const Vector3 xyz(0.3, 0.01, -0.02), rpy(0.1, -0.4, 0.7);
  options.added_frames = {wbm::AddedFrame{"left_hand_point", "left_elbow_link", xyz, rpy},
                          wbm::AddedFrame{"on_the_point", "left_hand_point", Vector3(0.05, 0, 0), Vector3::Zero()},
                          wbm::AddedFrame{"camera_tip", "d435_rgb_module_link", Vector3(0.01, 0, 0), Vector3::Zero()}};
  const Model model = wbm::load_urdf(h1.path, options);
  const Model plain = h1.load();
  ASSERT_EQ(model.num_frames(), plain.num_frames() + 3);
  const int point = model.frame_index("left_hand_point"), elbow = model.frame_index("left_elbow_link");
  EXPECT_EQ(model.frame(point).parent, elbow);
  EXPECT_EQ(model.frame(model.frame_index("on_the_point")).parent, point);
  const Transform X_LP{wbm::rotation_from_rpy(rpy.x(), rpy.y(), rpy.z()), xyz};
  std::mt19937_64 rng(71);
  Data data(model);
  Eigen::MatrixXd J(6, model.num_dofs()), J_fd(6, model.num_dofs());
  for (int c = 0; c < 50; ++c) {
    const Eigen::VectorXd q = wbm_test::random_configuration(model, rng);
    wbm::forward_kinematics(model, data, q);
    const Transform expected = wbm::frame_pose(model, data, elbow) * X_LP;
    const Transform actual = wbm::frame_pose(model, data, point);
    ASSERT_LT((actual.p - expected.p).norm(), 1e-12) << c;
    ASSERT_LT((actual.R - expected.R).norm(), 1e-12) << c;
    const Vector3 on = (wbm::frame_pose(model, data, model.frame_index("on_the_point")).p);
    ASSERT_LT((on - actual * Vector3(0.05, 0, 0)).norm(), 1e-12) << c;
    wbm::frame_jacobian(model, data, point, J);
    Data moved(model);
    constexpr double h = 1e-6;
    for (int i = 0; i < model.num_dofs(); ++i) {
      Eigen::VectorXd plus = q, minus = q;
      plus[i] += h;
      minus[i] -= h;
      wbm::forward_kinematics(model, moved, plus);
      const Transform a = wbm::frame_pose(model, moved, point);
      wbm::forward_kinematics(model, moved, minus);
      const Transform b = wbm::frame_pose(model, moved, point);
      J_fd.col(i).head<3>() = (a.p - b.p) / (2 * h);
      const Eigen::Matrix3d dR = (a.R - b.R) / (2 * h) * actual.R.transpose();
      J_fd.col(i).tail<3>() = Vector3(dR(2, 1), dR(0, 2), dR(1, 0));
    }
    ASSERT_LT((J - J_fd).cwiseAbs().maxCoeff(), 1e-6) << c << "\n" << J << "\n" << J_fd;
  }
  // The export writes it as a fixed link: imported again, the same pose.
  wbm::UrdfImportOptions again = h1.options;
  again.root_height = model.dof(model.virtual_dofs().ub_z).upper;
  const Model back = wbm::parse_urdf(wbm::export_urdf(model), again, "h1_added.urdf");
  Data back_data(back);
  const Eigen::VectorXd q = wbm_test::random_configuration(model, rng);
  wbm::forward_kinematics(model, data, q);
  wbm::forward_kinematics(back, back_data, q);
  EXPECT_LT((wbm::frame_pose(back, back_data, back.frame_index("left_hand_point")).p - wbm::frame_pose(model, data, point).p)
                .norm(),
            1e-9);
}

TEST(UrdfImport, AddedFramesThatDoNotFitAreErrors) {
  const ShippedModel& h1 = wbm_test::shipped_model("h1");
  const auto message = [&](const wbm::AddedFrame& frame, wbm::LegMode legs = wbm::LegMode::kLock) {
    wbm::UrdfImportOptions options = h1.options;
    options.leg_mode = legs;
    options.added_frames = {frame};
    try {
      wbm::load_urdf(h1.path, options);
    } catch (const wbm::ParseError& e) {
      return std::string(e.what());
    }
    return std::string("(loaded)");
  };
  const std::string prefix = h1.path + ": added frame ";
  EXPECT_EQ(message({"torso_link", "left_elbow_link", Vector3::Zero(), Vector3::Zero()}),
            prefix + "'torso_link' (added_frames, --add-frame): the model already has a frame of that name");
  EXPECT_EQ(message({"p", "left_elbow", Vector3::Zero(), Vector3::Zero()}).rfind(
                prefix + "'p' (added_frames, --add-frame): no frame named 'left_elbow' (did you mean 'left_elbow_link'", 0),
            0u);
  EXPECT_NE(message({"p", "left_ankle_link", Vector3::Zero(), Vector3::Zero()}, wbm::LegMode::kDrop)
                .find("no frame named 'left_ankle_link' (a link of a dropped leg)"),
            std::string::npos);
  EXPECT_EQ(message({"p", "left_ankle_link", Vector3::Zero(), Vector3::Zero()}), "(loaded)");  // a locked leg's link
  EXPECT_EQ(message({"p", "left_elbow_link", Vector3(0, std::nan(""), 0), Vector3::Zero()}),
            prefix + "'p' (added_frames, --add-frame): its position and orientation must be finite (position within 1e6 m)");
  // The command-line form.
  const wbm::AddedFrame parsed = wbm::parse_added_frame("tip:left_elbow_link:0.3,0,-0.02:0,1.5,0");
  EXPECT_EQ(parsed.name, "tip");
  EXPECT_EQ(parsed.parent, "left_elbow_link");
  EXPECT_EQ(parsed.xyz, Vector3(0.3, 0, -0.02));
  EXPECT_EQ(parsed.rpy, Vector3(0, 1.5, 0));
  EXPECT_EQ(wbm::parse_added_frame("tip:left_elbow_link:0.3,0,0").rpy, Vector3::Zero());
  for (const char* bad : {"tip", "tip:link", "tip:link:1,2", "tip:link:1,2,3,4", "tip:link:1,2,x", ":link:1,2,3",
                          "tip::1,2,3", "tip:link:1,2,3:0,0", "tip:link:1,2,3:0,0,0:9", "tip:link:1,2,nan",
                          "tip:link:1,2,3m", "tip:link:1,2,3:0,0,0.5rad"}) {
    try {
      wbm::parse_added_frame(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const wbm::ConfigError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(std::string("--add-frame '") + bad +
                                                "': expected NAME:PARENT:X,Y,Z or NAME:PARENT:X,Y,Z:ROLL,PITCH,YAW",
                                            0),
                0u)
          << e.what();
    }
  }
}

TEST(PaperModel, GraspAxesForwardAndHandsBelowShouldersAtZeroArms) {
  const Model model = wbm::make_paper_model();
  Data data(model);
  wbm::forward_kinematics(model, data, zero_arm_configuration(model));
  for (const char* side : {"l_", "r_"}) {
    const std::string s = side;
    const Transform hand = wbm::frame_pose(model, data, model.frame_index(s + "hand_ref"));
    const Transform shoulder = wbm::frame_pose(model, data, model.frame_index(s + "shoulder_1"));
    EXPECT_TRUE(hand.R.col(2).isApprox(Vector3::UnitX(), 1e-12)) << s << " grasp axis " << hand.R.col(2).transpose();
    EXPECT_LT(hand.p.z(), shoulder.p.z() - 0.3) << s;
    EXPECT_NEAR(hand.p.x(), shoulder.p.x(), 1e-12) << s;
    EXPECT_NEAR(hand.p.y(), shoulder.p.y(), 1e-12) << s;
  }
  const Transform l = wbm::frame_pose(model, data, model.frame_index("l_hand_ref"));
  const Transform r = wbm::frame_pose(model, data, model.frame_index("r_hand_ref"));
  EXPECT_GT(l.p.y(), 0.1);
  EXPECT_LT(r.p.y(), -0.1);
  const Transform cam = wbm::frame_pose(model, data, model.frame_index("head_camera"));
  EXPECT_TRUE(cam.R.col(2).isApprox(Vector3::UnitX(), 1e-12)) << "view axis " << cam.R.col(2).transpose();
  EXPECT_GT(cam.p.z(), l.p.z());
}

/// Mirror image (y -> -y) of a configuration: left and right arms swap, rotations about x
/// and z change sign, rotations about y and translations in x and z keep it.
Eigen::VectorXd mirror(const Model& model, const Eigen::VectorXd& q) {
  Eigen::VectorXd m(q.size());
  for (int i = 0; i < model.num_dofs(); ++i) {
    std::string name = model.dof(i).name;
    if (name.rfind("l_", 0) == 0) name[0] = 'r';
    else if (name.rfind("r_", 0) == 0) name[0] = 'l';
    const int j = model.dof_index(name);
    static const std::set<std::string> kOdd = {"heel_y", "heel_yaw", "upper_body_y", "upper_body_roll",
                                               "upper_body_yaw", "shoulder_roll", "shoulder_yaw", "hand_rot",
                                               "head_pan"};
    const std::string base = (name.rfind("l_", 0) == 0 || name.rfind("r_", 0) == 0) ? name.substr(2) : name;
    m[i] = kOdd.count(base) ? -q[j] : q[j];
  }
  return m;
}

TEST(PaperModel, LeftRightMirrorSymmetry) {
  const Model model = wbm::make_paper_model();
  const Eigen::Matrix3d M = Eigen::Vector3d(1, -1, 1).asDiagonal();
  Data data(model), mirrored(model);
  std::mt19937_64 rng(7);
  for (int c = 0; c < 200; ++c) {
    const Eigen::VectorXd q = wbm_test::random_configuration(model, rng);
    const Eigen::VectorXd qm = mirror(model, q);
    ASSERT_NO_THROW(model.check_configuration(qm)) << "mirrored limits are not symmetric";
    wbm::forward_kinematics(model, data, q);
    wbm::forward_kinematics(model, mirrored, qm);
    for (int f = 0; f < model.num_frames(); ++f) {
      std::string name = model.frame(f).name;
      if (name.rfind("l_", 0) == 0) name[0] = 'r';
      else if (name.rfind("r_", 0) == 0) name[0] = 'l';
      const Transform X = wbm::frame_pose(model, data, f);
      const Transform Y = wbm::frame_pose(model, mirrored, model.frame_index(name));
      EXPECT_LT((M * X.p - Y.p).cwiseAbs().maxCoeff(), 1e-12) << model.frame(f).name << " vs " << name;
      EXPECT_LT((M * X.R * M - Y.R).cwiseAbs().maxCoeff(), 1e-12) << model.frame(f).name << " vs " << name;
    }
    const Vector3 c1 = wbm::center_of_mass(model, data), c2 = wbm::center_of_mass(model, mirrored);
    EXPECT_LT((M * c1 - c2).cwiseAbs().maxCoeff(), 1e-12);
  }
}

// ---------------------------------------------------------------------------------------
// Re-rooting: G1 imported with the torso as the upper body.

/// Frames that stand for URDF links (not the virtual heel/upper-body bodies).
std::vector<std::string> link_frames(const Model& model) {
  std::vector<std::string> names;
  for (const wbm::Frame& f : model.frames())
    if (f.body >= model.virtual_dofs().upper_body) names.push_back(f.name);
  return names;
}

TEST(ReRooting, G1TorsoRootGivesTheSameRelativePoses) {
  const ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const Model pelvis = g1.load();
  const Model torso = wbm_test::import_variant("g1_29dof_torso_root").load();
  EXPECT_EQ(torso.body(torso.virtual_dofs().upper_body).name, "torso_link");
  EXPECT_NEAR(torso.total_mass(), pelvis.total_mass(), 1e-9);
  ASSERT_EQ(torso.num_dofs(), pelvis.num_dofs());

  std::vector<std::pair<int, int>> common;  // frame index in pelvis model, in torso model
  for (const std::string& name : link_frames(pelvis)) {
    const int t = torso.find_frame(name);
    if (t >= 0) common.emplace_back(pelvis.frame_index(name), t);
  }
  // Every URDF link is a frame of both models.
  EXPECT_EQ(common.size(), link_frames(pelvis).size());
  EXPECT_GE(common.size(), 40u);

  Data dp(pelvis), dt(torso);
  std::mt19937_64 rng(11);
  int failures = 0;
  for (int c = 0; c < 100; ++c) {
    const Eigen::VectorXd qp = wbm_test::random_configuration(pelvis, rng);
    Eigen::VectorXd qt = wbm_test::random_configuration(torso, rng);  // virtual dofs differ
    for (int i = 0; i < pelvis.num_dofs(); ++i)
      if (pelvis.dof(i).role == wbm::DofRole::kJoint) qt[torso.dof_index(pelvis.dof(i).name)] = qp[i];
    wbm::forward_kinematics(pelvis, dp, qp);
    wbm::forward_kinematics(torso, dt, qt);
    for (const auto& [a_p, a_t] : common) {
      const Transform Ap = wbm::frame_pose(pelvis, dp, a_p).inverse();
      const Transform At = wbm::frame_pose(torso, dt, a_t).inverse();
      for (const auto& [b_p, b_t] : common) {
        const double d = wbm_test::transform_distance(Ap * wbm::frame_pose(pelvis, dp, b_p),
                                                      At * wbm::frame_pose(torso, dt, b_t));
        if (!(d <= 1e-9) && ++failures <= kMaxReportedFailures)
          ADD_FAILURE() << "pose of " << pelvis.frame(b_p).name << " relative to " << pelvis.frame(a_p).name
                        << " differs by " << d << "\n  q = " << wbm_test::describe_configuration(pelvis, qp);
      }
    }
  }
  EXPECT_EQ(failures, 0);
}

// root_rpy turns the root link in the upper-body frame. The same model, written in the
// URDF: a link welded to the root with the inverse turn, made the root. Every frame's world
// pose, the home pose, the root height and the mass must agree, for a robot facing
// backward (iCub's root_link), one lying on its side (y up) and random turns.
TEST(UrdfImport, RootRpyTurnsTheRootAsAWeldedTurnedRootLinkWould) {
  const ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const std::string original = wbm_test::read_file(g1.path);
  std::vector<Vector3> turns = {{0.0, 0.0, M_PI}, {0.2, -0.3, 1.0}, {M_PI / 2, 0.0, 0.0}, {0.0, -M_PI / 2, 0.3}};
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  for (int k = 0; k < 4; ++k) turns.emplace_back(angle(rng), angle(rng) / 2, angle(rng));
  for (const Vector3& rpy : turns) {
    wbm::UrdfImportOptions turned_options = g1.options;
    turned_options.root_rpy = rpy;
    // The root height from the legs where they still hang below the turned root (it then
    // differs from the unturned one's for a tilt); given where they point elsewhere.
    if (std::abs(rpy.x()) > 0.5 || std::abs(rpy.y()) > 0.5) turned_options.root_height = 0.8;
    const Model turned = wbm::parse_urdf(original, turned_options, "g1.urdf");
    const Vector3 inverse = wbm::rpy_from_rotation(wbm::rotation_from_rpy(rpy.x(), rpy.y(), rpy.z()).transpose());
    std::ostringstream weld;
    weld.precision(17);
    weld << "  <link name=\"turned_root\"/>\n  <joint name=\"turned_root_joint\" type=\"fixed\">\n"
         << "    <parent link=\"pelvis\"/>\n    <child link=\"turned_root\"/>\n    <origin xyz=\"0 0 0\" rpy=\""
         << inverse.x() << " " << inverse.y() << " " << inverse.z() << "\"/>\n  </joint>\n</robot>";
    std::string welded_text = original;
    welded_text.replace(welded_text.rfind("</robot>"), 8, weld.str());
    wbm::UrdfImportOptions welded_options = turned_options;
    welded_options.root_rpy.setZero();
    welded_options.root = "turned_root";
    const Model welded = wbm::parse_urdf(welded_text, welded_options, "g1_welded.urdf");

    ASSERT_EQ(turned.num_dofs(), welded.num_dofs());
    EXPECT_NEAR(turned.total_mass(), welded.total_mass(), 1e-12);
    for (int i = 0; i < turned.num_dofs(); ++i) {
      ASSERT_EQ(turned.dof(i).name, welded.dof(i).name);
      if (turned.dof(i).continuous) continue;
      EXPECT_NEAR(turned.dof(i).lower, welded.dof(i).lower, 1e-12) << turned.dof(i).name;  // root height
      EXPECT_NEAR(turned.dof(i).upper, welded.dof(i).upper, 1e-12) << turned.dof(i).name;
    }
    EXPECT_LT((turned.home() - welded.home()).cwiseAbs().maxCoeff(), 1e-12);
    Data dt(turned), dw(welded);
    std::mt19937_64 qrng(17);
    for (int c = 0; c < 20; ++c) {
      const Eigen::VectorXd q = c == 0 ? turned.home() : wbm_test::random_configuration(turned, qrng);
      wbm::forward_kinematics(turned, dt, q);
      wbm::forward_kinematics(welded, dw, q);
      int compared = 0;
      for (int f = 0; f < turned.num_frames(); ++f) {
        const int g = welded.find_frame(turned.frame(f).name);
        if (g < 0) continue;
        ++compared;
        const double d = wbm_test::transform_distance(wbm::frame_pose(turned, dt, f), wbm::frame_pose(welded, dw, g));
        ASSERT_LT(d, 1e-9) << "frame " << turned.frame(f).name << " with root_rpy " << rpy.transpose()
                           << "\n  q = " << wbm_test::describe_configuration(turned, q);
      }
      EXPECT_GE(compared, 40);
      EXPECT_LT((wbm::center_of_mass(turned, dt) - wbm::center_of_mass(welded, dw)).norm(), 1e-9);
    }
  }
  // G1's root link follows REP 103 (x forward): at home its hands are ahead of the pelvis
  // (world +x); turned by pi about z they are behind it, i.e. the robot faces -x.
  wbm::UrdfImportOptions backward = g1.options;
  backward.root_rpy = Vector3(0.0, 0.0, M_PI);
  const Model plain = g1.load(), turned = wbm::parse_urdf(original, backward, "g1.urdf");
  auto hand_ahead_of_pelvis = [&](const Model& model) {
    Data data(model);
    wbm::forward_kinematics(model, data, model.home());
    return wbm::frame_pose(model, data, model.frame_index(g1.left_hand)).p.x() -
           wbm::frame_pose(model, data, model.frame_index("pelvis")).p.x();
  };
  EXPECT_GT(hand_ahead_of_pelvis(plain), 0.05);
  EXPECT_LT(hand_ahead_of_pelvis(turned), -0.05);
}

// Finite angles within [-2 pi, 2 pi] only; a root link lying on its side without root_rpy
// gets a hint when its legs are not below it.
// Without legs or a given height, a massless root link cut off below the root (a base_link
// on the floor, as Pepper's 0.33 m below its Tibia) is put on the ground: the root stands at
// its height above it. A world link at the root (models/dual_arm's) puts the root on the
// ground (height 0: the URDF's world frame is wbm's; 1 m before, which drew the pedestal
// floating and put every world-frame target 1 m off the ROS tools' numbers); a world link
// above the root leaves the default 1 m, as does a root other than the default given by
// name (the default root named is the default); legs and a given height decide before.
TEST(UrdfImport, ACutOffRootLinkBelowTheRootIsOnTheGround) {
  const std::string xml = wbm_test::read_file(wbm_test::source_path("models/dual_arm/dual_arm.urdf"));
  const std::string at_root = R"(<child link="base"/>
    <origin xyz="0 0 0" rpy="0 0 0"/>)";
  ASSERT_NE(xml.find(at_root), std::string::npos);
  const auto with_base_at = [&](const std::string& xyz) {
    std::string edited = xml;
    return edited.replace(edited.find(at_root), at_root.size(),
                          "<child link=\"base\"/>\n    <origin xyz=\"" + xyz + "\" rpy=\"0 0 0\"/>");
  };
  const auto height = [](const std::string& text, const wbm::UrdfImportOptions& options) {
    const Model model = wbm::parse_urdf(text, options, "dual_arm_edited.urdf");
    Data data(model);
    wbm::forward_kinematics(model, data, wbm::upright_base_configuration(model, model.home()));
    return std::make_pair(wbm::frame_position(model, data, model.frame_index("base")).z(),
                          wbm::frame_position(model, data, model.frame_index("world")).z());
  };
  const wbm::UrdfImportOptions plain;
  const auto [raised_root, raised_world] = height(with_base_at("0 0 0.75"), plain);
  EXPECT_NEAR(raised_root, 0.75, 1e-12);
  EXPECT_NEAR(raised_world, 0.0, 1e-12);  // the world link on the ground
  EXPECT_NEAR(height(with_base_at("0.2 0 0.75"), plain).first, 0.75, 1e-12);  // only the height counts
  // A massless link at the root's origin that does not name the ground is REP 120's
  // base_link at a humanoid's pelvis (NAO's, Romeo's without legs given): 1 m, not 0 (0 stood
  // NAO's soles 0.4 m below the ground for a session).
  std::string base_link = xml;
  for (std::size_t at = base_link.find("\"world\""); at != std::string::npos; at = base_link.find("\"world\"", at))
    base_link.replace(at, 7, "\"base_link\"");
  const auto root_height = [](const std::string& text) {
    const Model m = wbm::parse_urdf(text, {}, "dual_arm_renamed.urdf");
    return m.dof(m.virtual_dofs().ub_z).upper;
  };
  EXPECT_EQ(root_height(base_link), 1.0);
  // Cut off below the root (Pepper's base_link, 0.33 m below its Tibia; here 2 cm): on the
  // ground, however little below.
  std::string low_base_link = base_link;
  low_base_link.replace(low_base_link.find(at_root), at_root.size(),
                        "<child link=\"base\"/>\n    <origin xyz=\"0 0 0.02\" rpy=\"0 0 0\"/>");
  EXPECT_NEAR(root_height(low_base_link), 0.02, 1e-12);
  // A root link with mass is a body, even with a single fixed joint: it stays the root.
  std::string heavy_world = xml;
  const std::string world_link = "<link name=\"world\"/>";
  ASSERT_NE(heavy_world.find(world_link), std::string::npos);
  heavy_world.replace(heavy_world.find(world_link), world_link.size(),
                      "<link name=\"world\"><inertial><mass value=\"50\"/><inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" "
                      "iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial></link>");
  const Model heavy = wbm::parse_urdf(heavy_world, {}, "dual_arm_heavy_world.urdf");
  EXPECT_EQ(heavy.body(heavy.virtual_dofs().upper_body).name, "world");
  std::string footprint = xml;
  for (std::size_t at = footprint.find("\"world\""); at != std::string::npos; at = footprint.find("\"world\"", at))
    footprint.replace(at, 7, "\"base_footprint\"");
  EXPECT_EQ(root_height(footprint), 0.0);  // REP 120: on the ground
  for (const char* id : {"nao", "romeo_small"}) {
    wbm::UrdfImportOptions no_legs;
    const Model m = wbm::load_urdf(wbm_test::shipped_model(id).path, no_legs);
    EXPECT_EQ(m.dof(m.virtual_dofs().ub_z).upper, 1.0) << id;
  }
  // A world link carrying two bases (ABB's dual IRB120): the root itself names the ground.
  std::string two_bases = xml;
  const std::string world_joint = "<joint name=\"world_to_base\"";
  ASSERT_NE(two_bases.find(world_joint), std::string::npos);
  two_bases.insert(two_bases.find(world_joint),
                   "<link name=\"second_pedestal\"/><joint name=\"world_to_second\" type=\"fixed\"><parent "
                   "link=\"world\"/><child link=\"second_pedestal\"/><origin xyz=\"0 1 0\"/></joint>\n");
  const Model two = wbm::parse_urdf(two_bases, {}, "two_bases.urdf");
  EXPECT_EQ(two.body(two.virtual_dofs().upper_body).name, "world");
  EXPECT_EQ(two.dof(two.virtual_dofs().ub_z).upper, 0.0);
  // Something hanging a little below the world link (RB-Y1's grippers at zero joint values,
  // 0.19 m below its pedestal's top; the robot reaches further up): still on the ground.
  std::string hanging = xml;
  hanging.insert(hanging.find(world_joint),
                 "<link name=\"cable\"/><joint name=\"base_to_cable\" type=\"fixed\"><parent link=\"base\"/><child "
                 "link=\"cable\"/><origin xyz=\"0 0 -0.2\"/></joint>\n");
  EXPECT_EQ(root_height(hanging), 0.0);
  // A humanoid fixed to the world at its pelvis (a simulator's setup), no legs given: its legs
  // would stand below that "ground", so the default 1 m (0 stood G1's ankles 0.76 m deep).
  std::string g1 = wbm_test::read_file(wbm_test::shipped_model("g1_29dof").path);
  const std::string pelvis = "<link name=\"pelvis\">";
  ASSERT_NE(g1.find(pelvis), std::string::npos);
  g1.insert(g1.find(pelvis), "<link name=\"world\"/><joint name=\"world_to_pelvis\" type=\"fixed\"><parent "
                             "link=\"world\"/><child link=\"pelvis\"/></joint>\n");
  const Model fixed_g1 = wbm::parse_urdf(g1, {}, "g1_world.urdf");
  EXPECT_EQ(fixed_g1.dof(fixed_g1.virtual_dofs().ub_z).upper, 1.0);
  EXPECT_EQ(root_height(with_base_at("0 0 -0.0005")), 0.0);  // within a millimetre: on the ground
  const auto [ground_root, ground_world] = height(xml, plain);  // at the root: on the ground
  EXPECT_EQ(ground_root, 0.0);
  EXPECT_EQ(ground_world, 0.0);
  EXPECT_EQ(height(with_base_at("0 0 -1e-7"), plain).first, 0.0);  // within a micrometre: the same
  const Model on_ground = wbm::parse_urdf(xml, plain, "dual_arm.urdf");
  const wbm::Dof& z = on_ground.dof(on_ground.virtual_dofs().ub_z);
  EXPECT_EQ(z.lower, -0.2);  // a range still, the 0.2 m a 1 m root would crouch
  EXPECT_EQ(z.upper, 0.0);
  EXPECT_NEAR(height(with_base_at("0 0 -0.3"), plain).first, 1.0, 1e-12);     // above the root: 1 m
  wbm::UrdfImportOptions given = plain;
  given.root_height = 0.9;
  EXPECT_NEAR(height(with_base_at("0 0 0.75"), given).first, 0.9, 1e-12);
  // The default root named (`--root base`): the same robot, the same height (1 m before); a
  // root elsewhere given by name keeps the default 1 m.
  wbm::UrdfImportOptions named = plain;
  named.root = "base";
  EXPECT_NEAR(height(with_base_at("0 0 0.75"), named).first, 0.75, 1e-12);
  EXPECT_EQ(height(xml, named).first, 0.0);
  named.root = "torso";
  const Model torso_root = wbm::parse_urdf(with_base_at("0 0 0.75"), named, "dual_arm_edited.urdf");
  EXPECT_EQ(torso_root.dof(torso_root.virtual_dofs().ub_z).upper, 1.0);
  // A floating joint from the world link (a free-standing robot's export) cuts the tree there:
  // 1 m (the lookup of the unvisited link threw std::out_of_range, "map::at", once).
  std::string floating = with_base_at("0 0 0.75");
  const std::string fixed = R"(name="world_to_base" type="fixed")";
  ASSERT_NE(floating.find(fixed), std::string::npos);
  floating.replace(floating.find(fixed), fixed.size(), R"(name="world_to_base" type="floating")");
  const Model free_standing = wbm::parse_urdf(floating, plain, "dual_arm_floating.urdf");
  EXPECT_NEAR(free_standing.dof(free_standing.virtual_dofs().ub_z).upper, 1.0, 1e-12);
}

/// G1 with the pelvis's origin moved `dz` down (its children's joints and its inertia raised
/// by as much): the same robot, its root link's origin at the feet as in some CAD exports.
std::string g1_with_root_lowered(double dz) {
  std::string xml = wbm_test::read_file(wbm_test::shipped_model("g1_29dof").path);
  const auto raise = [&](std::size_t from, std::size_t to) {  // the first <origin xyz> in [from, to)
    const std::size_t at = xml.find("<origin xyz=\"", from);
    EXPECT_LT(at, to);
    const std::size_t start = at + 13, end = xml.find('"', start);
    std::istringstream in(xml.substr(start, end - start));
    double x, y, z;
    in >> x >> y >> z;
    std::ostringstream out;
    out.precision(17);
    out << x << " " << y << " " << z + dz;
    xml.replace(start, end - start, out.str());
  };
  const std::size_t pelvis = xml.find("<link name=\"pelvis\">");
  raise(pelvis, xml.find("</link>", pelvis));  // its inertial's origin
  int joints = 0;
  for (std::size_t at = xml.find("<joint "); at != std::string::npos; at = xml.find("<joint ", at + 1)) {
    const std::size_t end = xml.find("</joint>", at);
    if (xml.substr(at, end - at).find("<parent link=\"pelvis\"/>") == std::string::npos) continue;
    ++joints;
    if (xml.substr(at, end - at).find("<origin") == std::string::npos)
      xml.insert(xml.find("</joint>", at), "<origin xyz=\"0 0 0\"/>");
    raise(at, xml.find("</joint>", at));
  }
  EXPECT_EQ(joints, 5);  // the hips, the waist, the contour and the IMU
  return xml;
}

// A root link whose origin lies at the feet (Surena V's CAD export; Berkeley Humanoid Lite's,
// which has a link welded higher up): the legs reach less than a tenth of their length
// below it, which was an error. The virtual dofs now end at the hips (upper_body_pivot): the
// robot stands where it did with its origin up in the pelvis, crouches by 20 % of the hips'
// height and leans about them.
TEST(UrdfImport, ARootLinkAtTheFeetPivotsAtTheHips) {
  const wbm_test::ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const Model original = g1.load();
  constexpr double kDz = 0.79;  // the pelvis's origin 0.792 m up: lowered to 2 mm above the soles
  const Model lowered = wbm::parse_urdf(g1_with_root_lowered(kDz), g1.options, "g1_lowered.urdf");
  const double hips = kDz - 0.1027;  // the hip pitch joints' origin, 0.1027 m below the pelvis's
  EXPECT_NEAR(wbm::upper_body_pivot_above_root(lowered), hips, 1e-12);
  EXPECT_EQ(wbm::upper_body_pivot_above_root(original), 0.0);
  const wbm::Dof& z = lowered.dof(lowered.virtual_dofs().ub_z);
  const double original_height = original.dof(original.virtual_dofs().ub_z).upper;
  EXPECT_NEAR(z.upper, original_height - 0.1027, 1e-12);  // the hips' height above the soles
  EXPECT_NEAR(z.lower, 0.8 * z.upper, 1e-12);
  // Standing straight, every frame where it was, for random joint values.
  ASSERT_EQ(lowered.num_dofs(), original.num_dofs());
  std::mt19937_64 rng(4242);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::VectorXd q = wbm::upright_base_configuration(original, wbm_test::random_configuration(original, rng));
    Eigen::VectorXd q_lowered = q;
    q_lowered[lowered.virtual_dofs().ub_z] = z.upper;
    Data a(original), b(lowered);
    wbm::forward_kinematics(original, a, q);
    wbm::forward_kinematics(lowered, b, q_lowered);
    for (const wbm::Frame& f : original.frames()) {
      if (f.name == "pelvis" || f.name.rfind("upper_body", 0) == 0) continue;  // moved on purpose; pivots
      const int g = lowered.find_frame(f.name);
      ASSERT_GE(g, 0) << f.name;
      EXPECT_LT((wbm::frame_position(original, a, original.frame_index(f.name)) - wbm::frame_position(lowered, b, g)).norm(),
                1e-12)
          << f.name << " at trial " << trial;
    }
    EXPECT_NEAR(wbm::frame_position(lowered, b, lowered.frame_index("pelvis")).z(),
                wbm::frame_position(original, a, original.frame_index("pelvis")).z() - kDz, 1e-12);
  }
  // Leaning by the upper-body pitch turns the pelvis about the hips, not the soles.
  Eigen::VectorXd q = wbm::upright_base_configuration(lowered, lowered.home());
  Data data(lowered);
  wbm::forward_kinematics(lowered, data, q);
  const Eigen::Vector3d hip_before = wbm::frame_position(lowered, data, lowered.frame_index("left_hip_pitch_link"));
  q[lowered.virtual_dofs().ub_pitch] = 0.3;
  wbm::forward_kinematics(lowered, data, q);
  const Eigen::Vector3d hip_after = wbm::frame_position(lowered, data, lowered.frame_index("left_hip_pitch_link"));
  EXPECT_LT((hip_after - hip_before).norm(), 1e-12);  // the hips lie on the pivot's axis (y)
  // The root link's origin 8 mm below the soles: a negative root height, which the export's
  // comment writes and the import takes back with the pivot (it refused any height <= 0).
  const Model below = wbm::parse_urdf(g1_with_root_lowered(0.8), g1.options, "g1_below.urdf");
  const double below_pivot = wbm::upper_body_pivot_above_root(below);
  const double below_height = below.dof(below.virtual_dofs().ub_z).upper - below_pivot;
  EXPECT_NEAR(below_height, -0.008, 1e-3);
  const std::string exported = wbm::export_urdf(below);
  EXPECT_NE(exported.find("--upper-body-pivot "), std::string::npos);
  wbm::UrdfImportOptions back_options;
  back_options.root = "pelvis";
  back_options.root_height = below_height;
  back_options.upper_body_pivot = below_pivot;
  const Model back = wbm::parse_urdf(exported, back_options, "g1_below_export.urdf");
  EXPECT_EQ(back.dof(back.virtual_dofs().ub_z).upper, below.dof(below.virtual_dofs().ub_z).upper);
  // A pivot given far above the legs (5 m: a crouch range of metres) is refused.
  wbm::UrdfImportOptions high = g1.options;
  high.upper_body_pivot = 5.0;
  try {
    wbm::load_urdf(g1.path, high);
    ADD_FAILURE() << "a pivot 5 m above the pelvis accepted";
  } catch (const wbm::ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("more than twice the legs' length"), std::string::npos) << e.what();
  }
  // Given, the same model; a pivot of 0 is the root at its origin again, which the legs refuse.
  wbm::UrdfImportOptions given = g1.options;
  given.upper_body_pivot = hips;
  const Model with_pivot = wbm::parse_urdf(g1_with_root_lowered(kDz), given, "g1_lowered.urdf");
  EXPECT_EQ(wbm::upper_body_pivot_above_root(with_pivot), wbm::upper_body_pivot_above_root(lowered));
  given.upper_body_pivot = 0.0;
  EXPECT_THROW(wbm::parse_urdf(g1_with_root_lowered(kDz), given, "g1_lowered.urdf"), wbm::ParseError);
  // tests/data/root_at_feet.urdf: the hips 0.55 m above the root link's origin, the feet level
  // with it (refused before, with the IMU link welded 0.68 m up named as a root).
  wbm::UrdfImportOptions legs;
  legs.legs = {"thigh_l", "thigh_r"};
  const Model at_feet = wbm::load_urdf(wbm_test::source_path("tests/data/root_at_feet.urdf"), legs);
  EXPECT_NEAR(wbm::upper_body_pivot_above_root(at_feet), 0.55, 1e-12);
  EXPECT_NEAR(at_feet.dof(at_feet.virtual_dofs().ub_z).upper, 0.55, 1e-12);
  Data feet_data(at_feet);
  wbm::forward_kinematics(at_feet, feet_data, wbm::upright_base_configuration(at_feet, at_feet.home()));
  EXPECT_NEAR(wbm::frame_position(at_feet, feet_data, at_feet.frame_index("base")).z(), 0.0, 1e-12);
  EXPECT_NEAR(wbm::frame_position(at_feet, feet_data, at_feet.frame_index("imu")).z(), 0.68, 1e-12);
  for (const double bad : {-0.1, std::numeric_limits<double>::infinity()}) {
    given.upper_body_pivot = bad;
    try {
      wbm::parse_urdf(g1_with_root_lowered(kDz), given, "g1_lowered.urdf");
      ADD_FAILURE() << bad;
    } catch (const wbm::ParseError& e) {
      EXPECT_NE(std::string(e.what()).find("g1_lowered.urdf: the upper body's pivot above the root link "
                                           "(upper_body_pivot, --upper-body-pivot) must be finite and >= 0 m"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(UrdfImport, RootRpyOutOfRangeIsAnError) {
  const ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  for (const Vector3& rpy : {Vector3(0.0, 0.0, std::nan("")), Vector3(7.0, 0.0, 0.0), Vector3(0.0, -1e300, 0.0)}) {
    wbm::UrdfImportOptions options = g1.options;
    options.root_rpy = rpy;
    try {
      wbm::load_urdf(g1.path, options);
      ADD_FAILURE() << rpy.transpose() << " was accepted";
    } catch (const wbm::ParseError& e) {
      EXPECT_NE(std::string(e.what()).find("root_rpy, --root-rpy) must be finite and within [-2 pi, 2 pi]"),
                std::string::npos)
          << e.what();
    }
  }
  wbm::UrdfImportOptions upside_down = g1.options;
  upside_down.root_rpy = Vector3(M_PI, 0.0, 0.0);
  try {
    wbm::load_urdf(g1.path, upside_down);
    ADD_FAILURE() << "legs above the root were accepted";
  } catch (const wbm::ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("is not below the root link's origin, less than a tenth of the legs' length"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("If the root link's z axis is not up, give its orientation (root_rpy, --root-rpy)"),
              std::string::npos)
        << e.what();
  }
}

TEST(ReRooting, RootHeightComesFromTheLegsAlsoWhenTheyHangBelowReversedJoints) {
  const ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const Model pelvis = g1.load();
  const Model torso = wbm_test::import_variant("g1_29dof_torso_root").load();
  // Expected: the soles below the root origin at zero joint values. G1's sole is no link: its
  // ankle roll links carry four collision spheres of radius 5 mm, 3 cm below their origin.
  Data data(pelvis);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(pelvis.num_dofs());
  q[pelvis.virtual_dofs().ub_z] = pelvis.dof(pelvis.virtual_dofs().ub_z).upper;
  wbm::forward_kinematics(pelvis, data, q);
  auto lowest_leg_link = [&](const std::string& root) {
    const Transform X_RW = wbm::frame_pose(pelvis, data, pelvis.frame_index(root)).inverse();
    double lowest = std::numeric_limits<double>::infinity();
    for (const wbm::Frame& f : pelvis.frames())
      for (const char* part : {"_hip_", "_knee_", "_ankle_"})
        if (f.name.find(part) != std::string::npos)
          lowest = std::min(lowest, (X_RW * wbm::frame_pose(pelvis, data, pelvis.frame_index(f.name))).p.z());
    return lowest;
  };
  constexpr double kSoleBelowAnkle = 0.03 + 0.005;
  EXPECT_NEAR(pelvis.dof(pelvis.virtual_dofs().ub_z).upper, kSoleBelowAnkle - lowest_leg_link("pelvis"), 1e-9);
  EXPECT_NEAR(torso.dof(torso.virtual_dofs().ub_z).upper, kSoleBelowAnkle - lowest_leg_link("torso_link"), 1e-9);
}

// The root height from the legs reaches down to the lowest point of their primitives
// (collision spheres, boxes, cylinders, or visual ones on a link without collisions, turned by
// their origins and by the links' poses at zero joint values), not only to the lowest link origin: a foot's sole lies below
// its ankle (G1 3.5 cm, H1 6.2 cm, Atlas 7.4 cm; the robots stood that deep in the ground).
// Meshes are not read; a link without primitives counts by its origin as before.
TEST(UrdfImport, TheRootHeightFromTheLegsReachesTheirSoles) {
  const auto height = [](const std::string& foot_geometry) {
    const std::string xml = R"(<robot name="biped">
  <link name="pelvis"><inertial><mass value="5"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <link name="l_thigh"/>
  <joint name="l_hip" type="revolute"><parent link="pelvis"/><child link="l_thigh"/><origin xyz="0 0.1 -0.1" rpy="0 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="5"/></joint>
  <link name="l_foot">)" + foot_geometry + R"(</link>
  <joint name="l_knee" type="revolute"><parent link="l_thigh"/><child link="l_foot"/><origin xyz="0 0 -0.5" rpy="0 0.3 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="5"/></joint>
  <link name="arm"/>
  <joint name="shoulder" type="revolute"><parent link="pelvis"/><child link="arm"/><origin xyz="0 0.2 0.3" rpy="0 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="5"/></joint>
</robot>)";
    wbm::UrdfImportOptions options;
    options.legs = {"l_thigh"};
    const Model model = wbm::parse_urdf(xml, options, "biped.urdf");
    return model.dof(model.virtual_dofs().ub_z).upper;
  };
  const double ankle = 0.6;  // the foot link's origin below the pelvis
  EXPECT_NEAR(height(""), ankle, 1e-12);
  const auto element = [](const char* kind, const std::string& xyz, const std::string& rpy, const std::string& shape) {
    return std::string("<") + kind + "><origin xyz=\"" + xyz + "\" rpy=\"" + rpy + "\"/><geometry>" + shape +
           "</geometry></" + kind + ">";
  };
  // The foot link is pitched by 0.3 rad (the knee's origin): its point (x, y, z) lies
  // -x sin(0.3) + z cos(0.3) above its origin.
  const double s = std::sin(0.3), c = std::cos(0.3);
  EXPECT_NEAR(height(element("collision", "0 0 -0.03", "0 0 0", R"(<sphere radius="0.005"/>)")),
              ankle + 0.03 * c + 0.005, 1e-12);
  // A box 0.2 x 0.1 x 0.02 centred 4 cm below the ankle: its lowest corner.
  EXPECT_NEAR(height(element("collision", "0 0 -0.04", "0 0 0", R"(<box size="0.2 0.1 0.02"/>)")),
              ankle + 0.04 * c + 0.5 * (0.2 * s + 0.02 * c), 1e-12);
  // A visual cylinder lying along the foot's x axis (rpy 0 pi/2 0 turns its z onto x), radius
  // 0.03, length 0.2: its axis pitched by 0.3 rad, the lowest point of the rim at one end.
  EXPECT_NEAR(height(element("visual", "0 0 -0.02", "0 1.5707963267948966 0", R"(<cylinder radius="0.03" length="0.2"/>)")),
              ankle + 0.02 * c + 0.5 * 0.2 * s + 0.03 * c, 1e-9);
  // Visuals count only without collisions: a marker sphere around the sole point does not.
  EXPECT_NEAR(height(element("collision", "0 0 -0.01", "0 0 0", R"(<box size="0.2 0.1 0.02"/>)") +
                     element("visual", "0 0 0", "0 0 0", R"(<sphere radius="0.1"/>)")),
              ankle + 0.01 * c + 0.5 * (0.2 * s + 0.02 * c), 1e-12);
  // The lowest of several; a mesh (not read) and a primitive above the origin change nothing.
  EXPECT_NEAR(height(element("collision", "0 0 0.05", "0 0 0", R"(<sphere radius="0.01"/>)") +
                     element("visual", "0 0 -0.5", "0 0 0", R"(<mesh filename="foot.stl"/>)")),
              ankle, 1e-12);
  EXPECT_NEAR(height(element("collision", "0 0 -0.01", "0 0 0", R"(<sphere radius="0.01"/>)") +
                     element("collision", "0 0 -0.03", "0 0 0", R"(<sphere radius="0.01"/>)")),
              ankle + 0.03 * c + 0.01, 1e-12);
}

// ---------------------------------------------------------------------------------------
// URDF export round trip.

/// Every frame of `original` exists in `back` (same name) and has the same pose, to 1e-9,
/// on `cases` random configurations (the same q: the dofs are in the same order).
void expect_same_frame_poses(const Model& original, const Model& back, unsigned seed, int cases) {
  std::vector<std::pair<int, int>> frames;
  for (int f = 0; f < original.num_frames(); ++f) {
    const int g = back.find_frame(original.frame(f).name);
    EXPECT_GE(g, 0) << "frame " << original.frame(f).name << " lost in the round trip";
    if (g >= 0) frames.emplace_back(f, g);
  }
  Data da(original), db(back);
  std::mt19937_64 rng(seed);
  for (int c = 0; c < cases; ++c) {
    const Eigen::VectorXd q = wbm_test::random_configuration(original, rng);
    wbm::forward_kinematics(original, da, q);
    wbm::forward_kinematics(back, db, q);
    for (const auto& [f, g] : frames)
      ASSERT_LT(wbm_test::transform_distance(wbm::frame_pose(original, da, f), wbm::frame_pose(back, db, g)), 1e-9)
          << "frame " << original.frame(f).name << "\n  q = " << wbm_test::describe_configuration(original, q);
  }
}

TEST(Export, PaperModelRoundTrip) {
  const Model original = wbm::make_paper_model();
  const std::string xml = wbm::export_urdf(original);
  wbm::UrdfImportOptions options;
  options.root = "upper_body";
  options.root_height = 0.6;
  const Model back = wbm::parse_urdf(xml, options, "paper_export.urdf");

  ASSERT_EQ(back.num_dofs(), original.num_dofs());
  for (int i = 0; i < original.num_dofs(); ++i) {
    const wbm::Dof &a = original.dof(i), &b = back.dof(i);
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.type, b.type) << a.name;
    EXPECT_EQ(a.role, b.role) << a.name;
    EXPECT_EQ(a.continuous, b.continuous) << a.name;
    EXPECT_EQ(a.lower, b.lower) << a.name;
    EXPECT_EQ(a.upper, b.upper) << a.name;
    EXPECT_EQ(a.max_speed, b.max_speed) << a.name;
    EXPECT_DOUBLE_EQ(a.work_range, b.work_range) << a.name;
  }
  EXPECT_NEAR(back.total_mass(), original.total_mass(), 1e-9);

  expect_same_frame_poses(original, back, 3, 200);
  Data da(original), db(back);
  // The heel mass is welded at the home pose: the centre of mass agrees there.
  wbm::forward_kinematics(original, da, original.home());
  wbm::forward_kinematics(back, db, original.home());
  EXPECT_LT((wbm::center_of_mass(original, da) - wbm::center_of_mass(back, db)).cwiseAbs().maxCoeff(), 1e-9);
}

// The upper body's shift ranges are import options (longer feet need the upper body further
// forward for balance): they set the two dofs' ranges and home, nothing else, and the export's
// comment names them so that the file can be imported the same way.
TEST(Export, UpperBodyRangesAreImportOptionsAndTheExportNamesThem) {
  const wbm_test::ShippedModel g1 = wbm_test::shipped_model("g1_29dof");
  wbm::UrdfImportOptions options = g1.options;
  options.upper_body_x_range = {-0.05, 0.3};
  options.upper_body_y_range = {-0.1, 0.12};
  const Model plain = g1.load(), shifted = wbm::load_urdf(g1.path, options);
  const wbm::VirtualDofs& v = shifted.virtual_dofs();
  ASSERT_EQ(shifted.num_dofs(), plain.num_dofs());
  for (int i = 0; i < shifted.num_dofs(); ++i) {
    const wbm::Dof &a = shifted.dof(i), &b = plain.dof(i);
    if (i == v.ub_x || i == v.ub_y) continue;
    EXPECT_EQ(a.lower, b.lower) << a.name;
    EXPECT_EQ(a.upper, b.upper) << a.name;
    EXPECT_EQ(shifted.home()[i], plain.home()[i]) << a.name;
  }
  EXPECT_EQ(plain.dof(v.ub_x).lower, -0.02);
  EXPECT_EQ(plain.dof(v.ub_x).upper, 0.14);
  EXPECT_EQ(shifted.dof(v.ub_x).lower, -0.05);
  EXPECT_EQ(shifted.dof(v.ub_x).upper, 0.3);
  EXPECT_EQ(shifted.dof(v.ub_y).lower, -0.1);
  EXPECT_EQ(shifted.dof(v.ub_y).upper, 0.12);
  EXPECT_DOUBLE_EQ(shifted.home()[v.ub_x], 0.125);  // home in the middle of the range
  EXPECT_DOUBLE_EQ(shifted.home()[v.ub_y], 0.01);
  // The export of the default ranges names none; of others, both, as options and as flags.
  EXPECT_EQ(wbm::export_urdf(plain).find("upper_body_"), std::string::npos);
  const std::string xml = wbm::export_urdf(shifted);
  EXPECT_NE(xml.find(", upper_body_x_range -0.05 0.3, upper_body_y_range -0.1 0.12"), std::string::npos) << xml.substr(0, 400);
  EXPECT_NE(xml.find(" --upper-body-x-range -0.05,0.3 --upper-body-y-range -0.1,0.12"), std::string::npos)
      << xml.substr(0, 400);
  wbm::UrdfImportOptions again;
  again.root = shifted.body(v.upper_body).name;
  again.root_height = shifted.dof(v.ub_z).upper;
  again.upper_body_x_range = options.upper_body_x_range;
  again.upper_body_y_range = options.upper_body_y_range;
  const Model back = wbm::parse_urdf(xml, again, "g1_shifted_export.urdf");
  for (const int i : {v.ub_x, v.ub_y}) {
    EXPECT_EQ(back.dof(i).lower, shifted.dof(i).lower);
    EXPECT_EQ(back.dof(i).upper, shifted.dof(i).upper);
  }
}

/// The import options that the export's comment names as command-line flags ("(--root R
/// --root-height H ...). -->"), read as a user of the file would type them.
wbm::UrdfImportOptions options_named_by_export(const std::string& xml) {
  wbm::UrdfImportOptions options;
  const std::size_t open = xml.find("(--root "), close = xml.find("). -->", open);
  if (open == std::string::npos || close == std::string::npos) {
    ADD_FAILURE() << "no import flags in the export's comment: " << xml.substr(0, 300);
    return options;
  }
  const auto numbers = [](const std::string& text) {
    std::vector<double> v;
    std::istringstream in(text);
    for (std::string item; std::getline(in, item, ',');) v.push_back(std::stod(item));
    return v;
  };
  std::istringstream flags(xml.substr(open + 1, close - open - 1));
  for (std::string flag, value; flags >> flag >> value;) {
    if (flag == "--root") {
      options.root = value;
      continue;
    }
    const std::vector<double> v = numbers(value);
    if (flag == "--root-height" && v.size() == 1) options.root_height = v[0];
    else if (flag == "--upper-body-pivot" && v.size() == 1) options.upper_body_pivot = v[0];
    else if (flag == "--upper-body-x-range" && v.size() == 2) options.upper_body_x_range = {v[0], v[1]};
    else if (flag == "--upper-body-y-range" && v.size() == 2) options.upper_body_y_range = {v[0], v[1]};
    else if (flag == "--root-rpy" && v.size() == 3) options.root_rpy = Vector3(v[0], v[1], v[2]);
    else ADD_FAILURE() << "unexpected flag " << flag << " " << value;
  }
  return options;
}

class ExportRoundTrip : public testing::TestWithParam<ShippedModel> {};

TEST_P(ExportRoundTrip, SameFramePosesAfterExportAndImport) {
  // Every URDF model survives export + import with the same frame poses, the file imported
  // with the flags its comment names.
  const ShippedModel& entry = GetParam();
  const Model original = entry.load();
  const std::string xml = wbm::export_urdf(original);
  const wbm::UrdfImportOptions options = options_named_by_export(xml);
  EXPECT_EQ(options.root, original.body(original.virtual_dofs().upper_body).name);
  // The root link origin's height, and the pivot above it where the origin lies at the feet.
  const double pivot = wbm::upper_body_pivot_above_root(original);
  EXPECT_EQ(options.root_height, original.dof(original.virtual_dofs().ub_z).upper - pivot);
  if (pivot > 0.0)
    EXPECT_EQ(options.upper_body_pivot, pivot);
  else
    EXPECT_TRUE(std::isnan(options.upper_body_pivot)) << options.upper_body_pivot;
  // A root turned by root_rpy, by however little: the import needs it again.
  const wbm::Matrix3& R_UR = original.body(original.virtual_dofs().upper_body).X_PJ.R;
  EXPECT_EQ(!options.root_rpy.isZero(0.0), !R_UR.isIdentity(0.0)) << options.root_rpy.transpose();
  const Model back = wbm::parse_urdf(xml, options, entry.id + "_export.urdf");
  ASSERT_EQ(back.num_dofs(), original.num_dofs());
  // The same dofs in the same order, with the same limits: a q of the model is a q of the
  // exported file.
  for (int i = 0; i < original.num_dofs(); ++i) {
    const wbm::Dof &a = original.dof(i), &b = back.dof(i);
    ASSERT_EQ(b.name, a.name) << "dof " << i << " of the file exported and imported again";
    EXPECT_EQ(b.max_effort, a.max_effort) << a.name;
    EXPECT_EQ(b.lower, a.lower) << a.name;
    EXPECT_EQ(b.upper, a.upper) << a.name;
    EXPECT_EQ(b.max_speed, a.max_speed) << a.name;
  }
  // Every body below the root keeps its inertial (the root's gains the heel's mass).
  for (int i = original.virtual_dofs().upper_body + 1; i < original.num_bodies(); ++i) {
    const wbm::Body& a = original.body(i);
    const wbm::Body& b = back.body(back.frame(back.frame_index(a.name)).body);
    EXPECT_EQ(b.name, a.name);
    EXPECT_NEAR(b.inertial.mass, a.inertial.mass, 1e-12 * (1.0 + a.inertial.mass)) << a.name;
    EXPECT_LT((b.inertial.com - a.inertial.com).norm(), 1e-12) << a.name;
    EXPECT_LT((b.inertial.inertia - a.inertial.inertia).cwiseAbs().maxCoeff(), 1e-12) << a.name << "\n"
                                                                                     << b.inertial.inertia;
  }
  // The source's joint names: mimic joints' (Romeo's and NAO's fingers) and fixed joints'.
  int named = 0;
  for (const wbm::Body& body : original.bodies())
    if (!body.joint_name.empty() && body.name != original.body(original.virtual_dofs().upper_body).name) {
      EXPECT_EQ(back.body(back.frame(back.frame_index(body.name)).body).joint_name, body.joint_name) << "body " << body.name;
      ++named;
    }
  for (const wbm::Frame& f : original.frames())
    if (!f.joint_name.empty() && !original.is_body_frame(original.frame_index(f.name)) &&
        f.body >= original.virtual_dofs().upper_body) {
      EXPECT_EQ(back.frame(back.frame_index(f.name)).joint_name, f.joint_name) << "frame " << f.name;
      ++named;
    }
  EXPECT_GE(named, original.num_dofs() - 9);
  EXPECT_NEAR(back.total_mass(), original.total_mass(), 1e-9);
  expect_same_frame_poses(original, back, 5, 20);
  // The links hang from the same links (Frame::parent; the body's origin where not given).
  auto hangs_from = [](const Model& model, const wbm::Frame& f) {
    if (f.parent >= 0) return model.frame(f.parent).name;
    const int body = f.name == model.body(f.body).name ? model.body(f.body).parent : f.body;
    return model.body(body).name;
  };
  const int root = original.virtual_dofs().upper_body;
  int compared = 0;
  for (const wbm::Frame& f : original.frames()) {
    if (f.body < root || f.name == original.body(root).name) continue;
    EXPECT_EQ(hangs_from(back, back.frame(back.frame_index(f.name))), hangs_from(original, f)) << f.name;
    ++compared;
  }
  EXPECT_GT(compared, 5);
}

INSTANTIATE_TEST_SUITE_P(Urdfs, ExportRoundTrip, testing::ValuesIn(wbm_test::shipped_urdf_models()), wbm_test::ModelIdName());
INSTANTIATE_TEST_SUITE_P(ImportVariants, ExportRoundTrip, testing::ValuesIn(wbm_test::import_variants()),
                         wbm_test::ModelIdName());

/// A model with a body welded to its parent (no dof): legal in a ModelBuilder model.
/// `arm_multiplier`: the arm's coupling to its dof (URDF can express only 1 there).
/// The nine virtual bodies (the last the root "trunk", 10 kg) and "arm" (1 kg) on the trunk,
/// driven by the dof "shoulder" (y axis) times `arm_multiplier`. Returns the arm's body.
int add_trunk_and_arm(wbm::ModelBuilder& builder, double arm_multiplier = 1.0, double arm_offset = 0.0) {
  wbm::Inertial trunk;
  trunk.mass = 10.0;
  const int ub = wbm::add_virtual_base(builder, 1.0, "trunk", wbm::Inertial{}, trunk);
  wbm::Body arm;
  arm.name = "arm";
  arm.parent = ub;
  arm.X_PJ.p = {0.0, 0.2, 0.3};
  arm.axis = Vector3::UnitY();
  wbm::Dof dof;
  dof.name = "shoulder";
  dof.lower = -1.0;
  dof.upper = 1.0;
  dof.max_speed = 2.0;
  arm.dof = builder.add_dof(dof);
  arm.multiplier = arm_multiplier;
  arm.offset = arm_offset;
  arm.inertial.mass = 1.0;
  return builder.add_body(arm);
}

Model welded_model(double arm_multiplier = 1.0, double arm_offset = 0.0) {
  wbm::ModelBuilder builder("welded");
  const int arm_body = add_trunk_and_arm(builder, arm_multiplier, arm_offset);
  wbm::Body hand;
  hand.name = "hand";
  hand.parent = arm_body;
  hand.X_PJ.p = {0.0, 0.0, -0.4};
  hand.X_PJ.R = wbm::rotation_from_rpy(0.1, 0.2, 0.3);
  hand.dof = -1;
  hand.inertial.mass = 0.5;
  hand.inertial.com = {0.05, 0.02, -0.03};  // off its origin: a column for it would not be zero
  builder.add_body(hand);
  return builder.build();
}

// Values a ModelBuilder rejects because poses, Jacobians, W or the centre of mass computed
// from them would overflow or be NaN (the URDF importer reports them with their line).
TEST(ModelBuilder, RejectsValuesThatWouldOverflow) {
  // Names are move-assigned from std::string here: GCC 12's -Wrestrict misreads the inlined
  // copy of a literal into a std::function's lambda (a false positive).
  struct Change {
    std::function<void(wbm::Dof&, wbm::Body&, wbm::Frame&)> apply;
    std::string expected;
  };
  const double big = 1e308, nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Change> changes = {
      {[&](wbm::Dof& d, wbm::Body&, wbm::Frame&) { d.lower = -big, d.upper = big; },
       "dof 'j': work range must be finite, got inf (limits [-1e+308, 1e+308]; make a joint without limits "
       "continuous)"},
      {[&](wbm::Dof& d, wbm::Body& b, wbm::Frame&) {
         d.lower = -2e6;
         b.joint_type = d.type = wbm::JointType::kPrismatic;
       },
       "dof 'j': prismatic limits [-2e+06, 1] m reach beyond 1e+06 m"},
      {[&](wbm::Dof&, wbm::Body& b, wbm::Frame&) { b.X_PJ.p.x() = -big; },
       "body 'link': joint offset (-1e+308, 0, 0.5) m reaches beyond 1e+06 m"},
      {[&](wbm::Dof&, wbm::Body& b, wbm::Frame&) { b.inertial.mass = big; },
       "body 'link': mass must be in [0, 1e+06] kg, got 1e+308"},
      {[&](wbm::Dof&, wbm::Body& b, wbm::Frame&) { b.inertial.mass = nan; },
       "body 'link': mass must be in [0, 1e+06] kg, got nan"},
      {[&](wbm::Dof&, wbm::Body& b, wbm::Frame&) { b.inertial.com.z() = 2e6; },
       "body 'link': centre of mass (0, 0, 2e+06) m reaches beyond 1e+06 m"},
      {[&](wbm::Dof&, wbm::Body&, wbm::Frame& f) { f.X_BF.p.y() = nan; },
       "frame 'tip': offset is not finite or reaches beyond 1e+06 m"},
      {[&](wbm::Dof&, wbm::Body&, wbm::Frame& f) { f.X_BF.p.y() = 2e6; },
       "frame 'tip': offset is not finite or reaches beyond 1e+06 m"},
      {[&](wbm::Dof& d, wbm::Body&, wbm::Frame&) { d.max_effort = -1.0; },
       "dof 'j': effort limit must be finite and >= 0 (0: not given), got -1"},
      {[&](wbm::Dof& d, wbm::Body&, wbm::Frame&) { d.max_effort = nan; },
       "dof 'j': effort limit must be finite and >= 0 (0: not given), got nan"},
      {[&](wbm::Dof& d, wbm::Body&, wbm::Frame&) { d.max_speed = 0.0; },
       "dof 'j': speed limit must be finite and > 0, got 0"},
      // An axis or a rotation off by a thousandth is a typo, not rounding (the URDF import
      // normalises the axes it reads, within 1 %).
      {[&](wbm::Dof&, wbm::Body& b, wbm::Frame&) { b.axis = Vector3(0.0, 0.0, 1.001); },
       "body 'link': joint axis (0, 0, 1.001) is not a unit vector (norm 1.001)"},
      {[&](wbm::Dof&, wbm::Body& b, wbm::Frame&) { b.X_PJ.R *= 1.001; },
       "body 'link': joint offset rotation is not orthonormal"},
      // Joint names kept for the export must name one joint each (a URDF cannot hold two).
      {[&](wbm::Dof&, wbm::Body&, wbm::Frame& f) { f.joint_name = std::string("j"); },
       "joint name 'j' is given to frame 'tip' and to dof 'j'"},
      {[&](wbm::Dof&, wbm::Body& b, wbm::Frame& f) { b.joint_name = f.joint_name = std::string("k"); },
       "joint name 'k' is given to frame 'tip' and to body 'link'"},
      // Limits, axes, couplings, offsets and inertials that are no numbers or no joint.
      {[&](wbm::Dof& d, wbm::Body& b, wbm::Frame&) {
         d.continuous = true;
         b.joint_type = d.type = wbm::JointType::kPrismatic;
       },
       "dof 'j': only revolute joints can be continuous"},
      {[&](wbm::Dof& d, wbm::Body&, wbm::Frame&) { d.upper = std::numeric_limits<double>::infinity(); },
       "dof 'j': position limits must be finite (or the joint continuous)"},
      {[&](wbm::Dof& d, wbm::Body&, wbm::Frame&) { d.lower = 0.5, d.upper = 0.2; },
       "dof 'j': lower limit 0.5 is above upper limit 0.2"},
      {[&](wbm::Dof& d, wbm::Body&, wbm::Frame&) { d.lower = d.upper = 0.3; },
       "dof 'j': zero motion range (lower == upper); lock the joint instead"},
      {[&](wbm::Dof&, wbm::Body& b, wbm::Frame&) { b.axis = Vector3::Zero(); }, "body 'link': joint axis is zero"},
      {[&](wbm::Dof&, wbm::Body& b, wbm::Frame&) { b.multiplier = nan; },
       "body 'link': mimic multiplier and offset must be finite"},
      {[&](wbm::Dof&, wbm::Body& b, wbm::Frame&) { b.X_PJ.R(0, 1) = nan; }, "body 'link': joint offset is not finite"},
      {[&](wbm::Dof&, wbm::Body& b, wbm::Frame&) { b.inertial.com.x() = nan; },
       "body 'link': centre of mass and inertia must be finite"},
      {[&](wbm::Dof&, wbm::Body&, wbm::Frame& f) { f.parent = 1; },  // its own index
       "frame 'tip': parent frame index 1 is not -1 or the index of another frame"},
      {[&](wbm::Dof&, wbm::Body&, wbm::Frame& f) { f.name = std::string("link"); }, "duplicate frame 'link'"},
  };
  // One dof driving one body with a frame; `change` edits them before the build.
  auto one_joint_model = [](const std::function<void(wbm::Dof&, wbm::Body&, wbm::Frame&)>& change) {
    wbm::ModelBuilder builder("one_joint");
    wbm::Dof dof;
    dof.name = "j";
    dof.lower = -1.0;
    dof.upper = 1.0;
    dof.max_speed = 1.0;
    wbm::Body body;
    body.name = "link";
    body.X_PJ.p = {0.0, 0.0, 0.5};
    body.inertial.mass = 1.0;
    wbm::Frame frame;
    frame.name = "tip";
    frame.X_BF.p = {0.0, 0.0, 0.3};
    change(dof, body, frame);
    body.dof = builder.add_dof(dof);
    frame.body = builder.add_body(body);
    builder.add_frame(frame);
    return builder.build();
  };
  EXPECT_NO_THROW(one_joint_model([](wbm::Dof&, wbm::Body&, wbm::Frame&) {}));  // valid without a change
  EXPECT_NO_THROW(one_joint_model([](wbm::Dof& d, wbm::Body& b, wbm::Frame& f) {
    d.max_effort = 30.0;
    b.joint_name = std::string("j");  // its dof's own joint
    f.joint_name = std::string("tip_mount");
  }));
  for (const Change& change : changes) {
    try {
      one_joint_model(change.apply);
      ADD_FAILURE() << "accepted; wanted: " << change.expected;
    } catch (const wbm::ModelError& e) {
      EXPECT_NE(std::string(e.what()).find(change.expected), std::string::npos) << "got: " << e.what();
    }
  }
  // A dof no body follows.
  wbm::ModelBuilder idle("idle_dof");
  add_trunk_and_arm(idle);
  wbm::Dof spare;
  spare.name = "spare";
  spare.lower = -1.0;
  spare.upper = 1.0;
  spare.max_speed = 1.0;
  idle.add_dof(spare);
  try {
    idle.build();
    ADD_FAILURE() << "a dof that drives no body was accepted";
  } catch (const wbm::ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("dof 'spare' drives no body"), std::string::npos) << e.what();
  }
}

// Names and indices a ModelBuilder refuses: two dofs or bodies of one name, a body whose
// dof or a frame whose body does not exist, a body hung from itself; an axis within the
// tolerance is normalised. A configuration is checked for its size, numbers and limits
// (within 1e-9 of a limit counts as at it); the virtual base for its height and pivot.
TEST(ModelBuilder, RefusesNamesAndIndicesThatNameNothingOrTwoThings) {
  auto dof_named = [](const char* name) {
    wbm::Dof dof;
    dof.name = name;
    dof.lower = -1.0;
    dof.upper = 1.0;
    dof.max_speed = 1.0;
    return dof;
  };
  auto body_named = [](const char* name, int parent, int dof) {
    wbm::Body body;
    body.name = name;
    body.parent = parent;
    body.dof = dof;
    return body;
  };
  auto expect_error = [](const std::function<void()>& build, const std::string& expected) {
    EXPECT_TRUE(wbm_test::throws_with<wbm::ModelError>(build, expected));
  };
  expect_error([&] {
    wbm::ModelBuilder b("two_dofs");
    b.add_body(body_named("a", -1, b.add_dof(dof_named("j"))));
    b.add_body(body_named("b", 0, b.add_dof(dof_named("j"))));
    b.build();
  }, "duplicate dof 'j'");
  expect_error([&] {
    wbm::ModelBuilder b("two_bodies");
    b.add_body(body_named("a", -1, b.add_dof(dof_named("j"))));
    b.add_body(body_named("a", 0, b.add_dof(dof_named("k"))));
    b.build();
  }, "duplicate body 'a'");
  expect_error([&] {
    wbm::ModelBuilder b("dof_out_of_range");
    b.add_body(body_named("a", -1, b.add_dof(dof_named("j"))));
    b.add_body(body_named("b", 0, 1));
    b.build();
  }, "body 'b': dof index out of range");
  expect_error([&] {
    wbm::ModelBuilder b("frame_out_of_range");
    b.add_body(body_named("a", -1, b.add_dof(dof_named("j"))));
    wbm::Frame frame;
    frame.name = "tip";
    frame.body = 1;
    b.add_frame(frame);
    b.build();
  }, "frame 'tip': body index out of range");
  expect_error([&] {
    wbm::ModelBuilder b("own_parent");
    b.add_body(body_named("a", 0, b.add_dof(dof_named("j"))));
  }, "body 'a': parent index 0 is not an earlier body");
  wbm::ModelBuilder b("near_unit_axis");
  wbm::Body body = body_named("a", -1, b.add_dof(dof_named("j")));
  body.axis = Vector3(0.0, 0.0, 1.0 + 5e-6);
  b.add_body(body);
  const Model model = b.build();
  EXPECT_EQ(model.body(0).axis, Vector3::UnitZ());

  // The configuration check.
  Eigen::VectorXd q = Eigen::VectorXd::Constant(1, 1.0 + 1e-10);  // within 1e-9 of the limit
  EXPECT_NO_THROW(model.check_configuration(q));
  expect_error([&] { model.check_configuration(Eigen::VectorXd::Constant(1, 1.0 + 1e-6)); },
               "configuration value 1 of dof 'j' is outside [-1, 1]");
  expect_error([&] { model.check_configuration(Eigen::VectorXd::Constant(1, std::nan(""))); },
               "configuration value of dof 'j' is not finite");
  expect_error([&] { model.check_configuration(Eigen::VectorXd::Zero(2)); },
               "configuration has 2 values, model 'near_unit_axis' has 1 dofs");

  // The virtual base's height and pivot.
  for (const double height : {-0.1, std::nan(""), std::numeric_limits<double>::infinity()}) {
    wbm::ModelBuilder base("base");
    EXPECT_THROW(wbm::add_virtual_base(base, height, "trunk", wbm::Inertial{}, wbm::Inertial{}), wbm::ModelError)
        << height;
  }
  for (const double pivot : {-0.1, std::nan("")}) {
    wbm::ModelBuilder base("base");
    EXPECT_THROW(wbm::add_virtual_base(base, wbm::default_virtual_dofs(1.0), "trunk", wbm::Inertial{}, wbm::Inertial{},
                                       Eigen::Matrix3d::Identity(), pivot),
                 wbm::ModelError)
        << pivot;
  }
}

// The virtual base as given: the heel's inertial on the heel body, the pivot above the root
// link (and read back), a turned root link whose yaw dof still turns about the vertical, and
// the upright configuration within ranges that exclude zero.
TEST(ModelBuilder, TheVirtualBaseIsBuiltAsGiven) {
  std::array<wbm::Dof, 9> dofs = wbm::default_virtual_dofs(1.0);
  dofs[3].lower = 0.02;  // upper_body_x in [0.02, 0.14]: upright is 0.02, not 0
  wbm::Inertial heel;
  heel.mass = 2.0;
  const wbm::Matrix3 R_UR = wbm::rotation_from_rpy(0.3, -0.2, 0.5);
  wbm::ModelBuilder builder("base");
  const int upper = wbm::add_virtual_base(builder, dofs, "trunk", heel, wbm::Inertial{}, R_UR, 0.25);
  const Model model = builder.build();
  const wbm::VirtualDofs& v = model.virtual_dofs();
  EXPECT_EQ(model.body(v.heel_body).inertial.mass, 2.0);
  EXPECT_EQ(model.total_mass(), 2.0);
  EXPECT_EQ(wbm::upper_body_pivot_above_root(model), 0.25);
  const Eigen::VectorXd upright = wbm::upright_base_configuration(model, model.home());
  EXPECT_EQ(upright[v.ub_x], 0.02);
  EXPECT_EQ(upright[v.ub_z], 1.0);
  Data data(model);
  Eigen::VectorXd q = upright;
  q[v.ub_x] = 0.05;
  wbm::forward_kinematics(model, data, q);
  const Transform pivot = data.X_WB[upper];  // yaw 0: the root link's own turn
  EXPECT_LT((pivot.R - R_UR).norm(), 1e-12);
  q[v.ub_yaw] = 0.4;
  wbm::forward_kinematics(model, data, q);
  const wbm::Matrix3 Rz = Eigen::AngleAxisd(0.4, Vector3::UnitZ()).toRotationMatrix();
  EXPECT_LT((data.X_WB[upper].R - Rz * R_UR).norm(), 1e-12);
  // The root link's origin 0.25 m below the pivot along the upper body's z (vertical here),
  // which the yaw leaves where it is.
  EXPECT_LT((data.X_WB[upper].p - pivot.p).norm(), 1e-12);
  EXPECT_NEAR(pivot.p.z(), 1.0 - 0.25, 1e-12);
}

// Frame::parent: a frame hangs from a frame of its body, a body's own frame from one of the
// parent body (so that the link between them is rigid, or spans the body's joint).
TEST(ModelBuilder, FrameParentsHangFromTheirBodyOrTheParentBody) {
  // Bodies: the nine virtual ones (the last is the root "trunk"), "arm" (a dof). Frames: one per
  // body, then trunk_point on the trunk, tip and tip2 on the arm.
  static constexpr int kNone = -1, kArm = 9, kTrunkPoint = 10, kTip = 11, kTip2 = 12;
  auto model_with = [](int tip_parent, int arm_parent, int tip2_parent) {
    wbm::ModelBuilder builder("parents");
    const int arm_body = add_trunk_and_arm(builder);
    const int ub = builder.num_bodies() - 2;
    EXPECT_EQ(builder.num_frames() - 1, kArm);
    EXPECT_EQ(builder.add_frame({"trunk_point", ub, Transform{wbm::Matrix3::Identity(), {0.0, 0.2, 0.2}}}), kTrunkPoint);
    EXPECT_EQ(builder.add_frame({"tip", arm_body, Transform{wbm::Matrix3::Identity(), {0.0, 0.0, -0.3}}}), kTip);
    EXPECT_EQ(builder.add_frame({"tip2", arm_body, Transform{wbm::Matrix3::Identity(), {0.0, 0.0, -0.4}}}), kTip2);
    builder.set_frame_parent(kTip, tip_parent);
    builder.set_frame_parent(kArm, arm_parent);
    builder.set_frame_parent(kTip2, tip2_parent);
    return builder.build();
  };
  // Valid: the arm from trunk_point, tip from the arm's frame, tip2 from tip; or none given.
  const Model ok = model_with(kArm, kTrunkPoint, kTip);
  EXPECT_EQ(ok.frame(ok.frame_index("tip2")).parent, ok.frame_index("tip"));
  EXPECT_EQ(ok.frame(ok.frame_index("arm")).parent, ok.frame_index("trunk_point"));
  EXPECT_TRUE(ok.is_body_frame(kArm));
  EXPECT_FALSE(ok.is_body_frame(kTip));
  EXPECT_FALSE(ok.is_body_frame(kTrunkPoint));
  EXPECT_NO_THROW(model_with(kNone, kNone, kNone));
  const std::vector<std::tuple<int, int, int, std::string>> bad = {
      {kTrunkPoint, kNone, kNone,
       "frame 'tip': parent frame 'trunk_point' is on body 'trunk', expected a frame on 'arm' (the frame's body)"},
      {kNone, kTip, kNone,
       "frame 'arm': parent frame 'tip' is on body 'arm', expected a frame on 'trunk' (the parent of the frame's body)"},
      {kNone, kNone, kTip2, "frame 'tip2': parent frame index 12 is not -1 or the index of another frame"},
      {kNone, kNone, 99, "frame 'tip2': parent frame index 99 is not -1 or the index of another frame"},
      {-5, kNone, kNone, "frame 'tip': parent frame index -5 is not -1 or the index of another frame"},
  };
  for (const auto& [tip, arm, tip2, expected] : bad) {
    try {
      model_with(tip, arm, tip2);
      ADD_FAILURE() << "accepted; wanted: " << expected;
    } catch (const wbm::ModelError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << "got: " << e.what();
    }
  }
  wbm::ModelBuilder builder("no_frames");
  EXPECT_THROW(builder.set_frame_parent(0, -1), wbm::ModelError);
}

/// The centre of mass's Jacobian by central differences (step 1e-6), a column per dof.
Eigen::Matrix3Xd com_jacobian_by_differences(const Model& model, const Eigen::VectorXd& q) {
  Data plus(model), minus(model);
  Eigen::Matrix3Xd J(3, model.num_dofs());
  const double h = 1e-6;
  for (int d = 0; d < model.num_dofs(); ++d) {
    Eigen::VectorXd qp = q, qm = q;
    qp[d] += h;
    qm[d] -= h;
    forward_kinematics(model, plus, qp);
    forward_kinematics(model, minus, qm);
    J.col(d) = (center_of_mass(model, plus) - center_of_mass(model, minus)) / (2 * h);
  }
  return J;
}

// Jacobians of a model with a welded body: its bodies without a dof write no column (a
// finite sentinel column on each side of J stays untouched; += on NaN would hide a write)
// and the centre-of-mass Jacobian matches central differences.
TEST(Kinematics, WeldedBodiesHaveNoJacobianColumn) {
  const Model model = welded_model();
  const int nq = model.num_dofs();
  std::mt19937_64 rng(53);
  Data data(model);
  Eigen::MatrixXd padded(3, nq + 2);
  for (int c = 0; c < 20; ++c) {
    const Eigen::VectorXd q = wbm_test::random_configuration(model, rng);
    forward_kinematics(model, data, q);
    center_of_mass(model, data);
    const double sentinel = 12345.0;
    padded.setConstant(sentinel);
    com_jacobian(model, data, padded.middleCols(1, nq));
    ASSERT_TRUE((padded.col(0).array() == sentinel).all() && (padded.col(nq + 1).array() == sentinel).all()) << c;
    const Eigen::Matrix3Xd fd = com_jacobian_by_differences(model, q);
    for (int d = 0; d < nq; ++d) ASSERT_LT((padded.col(1 + d) - fd.col(d)).norm(), 1e-6) << "dof " << d << " case " << c;
    padded.setConstant(sentinel);
    point_jacobian(model, data, model.num_bodies() - 1, data.X_WB.back().p, padded.middleCols(1, nq));
    ASSERT_TRUE((padded.col(0).array() == sentinel).all() && (padded.col(nq + 1).array() == sentinel).all()) << c;
  }
}

// The centre of mass sums every body, the first one and those of every root: a ModelBuilder
// model may have several roots (a body whose parent is -1: the world), and here the first
// body, itself a root, has mass (in the shipped models the first bodies are the massless
// virtual heel's). Both functions agree with the mass-weighted mean computed here, and the
// Jacobian of the centre of mass matches central differences.
TEST(Kinematics, TheCentreOfMassSumsEveryBodyOfEveryRoot) {
  wbm::ModelBuilder builder("two_roots");
  auto add_dof = [&](const std::string& name, wbm::JointType type) {
    wbm::Dof dof;
    dof.name = name;
    dof.type = type;
    dof.lower = -1.0;
    dof.upper = 1.0;
    dof.max_speed = 1.0;
    return builder.add_dof(dof);
  };
  wbm::Body slider;  // a root on a prismatic x joint, 2 kg off its origin
  slider.name = "slider";
  slider.joint_type = wbm::JointType::kPrismatic;
  slider.axis = Vector3::UnitX();
  slider.dof = add_dof("slide", wbm::JointType::kPrismatic);
  slider.inertial.mass = 2.0;
  slider.inertial.com = {0.1, 0.2, 0.0};
  builder.add_body(slider);
  wbm::Body turntable;  // a second root, 3 kg, turning about z one metre away
  turntable.name = "turntable";
  turntable.X_PJ.p = {1.0, 0.0, 0.0};
  turntable.dof = add_dof("turn", wbm::JointType::kRevolute);
  turntable.inertial.mass = 3.0;
  turntable.inertial.com = {0.3, 0.0, 0.1};
  const int table = builder.add_body(turntable);
  wbm::Body arm;  // 1 kg on the turntable, pitching about y
  arm.name = "arm";
  arm.parent = table;
  arm.X_PJ.p = {0.0, 0.2, 0.5};
  arm.axis = Vector3::UnitY();
  arm.dof = add_dof("pitch", wbm::JointType::kRevolute);
  arm.inertial.mass = 1.0;
  arm.inertial.com = {0.0, 0.0, -0.4};
  builder.add_body(arm);
  const Model model = builder.build();
  ASSERT_EQ(model.total_mass(), 6.0);

  std::mt19937_64 rng(38);
  Data data(model);
  Eigen::MatrixXd J(3, model.num_dofs());
  for (int c = 0; c < 20; ++c) {
    const Eigen::VectorXd q = wbm_test::random_configuration(model, rng);
    forward_kinematics(model, data, q);
    Vector3 sum = Vector3::Zero();
    for (int b = 0; b < model.num_bodies(); ++b)
      sum += model.bodies()[b].inertial.mass * (data.X_WB[b] * model.bodies()[b].inertial.com);
    const Vector3 expected = sum / 6.0;
    ASSERT_LT((center_of_mass(model, data) - expected).norm(), 1e-12) << "case " << c;
    ASSERT_LT((center_of_mass_position(model, data) - expected).norm(), 1e-12) << "case " << c;
    com_jacobian(model, data, J);
    const Eigen::Matrix3Xd fd = com_jacobian_by_differences(model, q);
    for (int d = 0; d < model.num_dofs(); ++d) ASSERT_LT((J.col(d) - fd.col(d)).norm(), 1e-7) << "dof " << d << " case " << c;
  }
}

TEST(Export, ModelWithWeldedBody) {
  // Bodies without a dof (welded to their parent) are legal in a ModelBuilder model.
  const Model original = welded_model();
  std::string xml;
  ASSERT_NO_THROW(xml = wbm::export_urdf(original));
  wbm::UrdfImportOptions options;
  options.root = "trunk";
  options.root_height = 1.0;
  const Model back = wbm::parse_urdf(xml, options, "welded_export.urdf");
  EXPECT_EQ(back.num_dofs(), original.num_dofs());
  EXPECT_NEAR(back.total_mass(), original.total_mass(), 1e-12);
  Data da(original), db(back);
  wbm::forward_kinematics(original, da, original.home());
  wbm::forward_kinematics(back, db, original.home());
  EXPECT_LT(wbm_test::transform_distance(wbm::frame_pose(original, da, original.frame_index("hand")),
                                         wbm::frame_pose(back, db, back.frame_index("hand"))),
            1e-12);
}

// A joint below a welded link whose fixed joint the file lists before a sibling joint (a neck
// on a head mount, listed before the arms, as in Unitree's G1 with a 2-dof head): the import
// numbers the neck's dof first. The export once wrote every welded link after all joints, so
// the exported file numbered the arm first: a model's q meant other joints in the file.
TEST(Export, JointBelowAWeldedLinkKeepsItsDofNumber) {
  const std::string xml =
      "<?xml version=\"1.0\"?>\n<robot name=\"r\">\n"
      "<link name=\"torso\"><inertial><mass value=\"5\"/>"
      "<inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/></inertial></link>\n"
      "<link name=\"head_mount\"/><link name=\"neck\"/><link name=\"head\"/><link name=\"arm\"/>\n"
      "<joint name=\"mount_joint\" type=\"fixed\"><parent link=\"torso\"/><child link=\"head_mount\"/>"
      "<origin xyz=\"0 0 0.4\" rpy=\"0 0.2 0\"/></joint>\n"
      "<joint name=\"neck_pitch\" type=\"revolute\"><parent link=\"head_mount\"/><child link=\"neck\"/>"
      "<origin xyz=\"0 0 0.05\"/><axis xyz=\"0 1 0\"/><limit lower=\"-0.5\" upper=\"0.5\" effort=\"1\" velocity=\"1\"/></joint>\n"
      "<joint name=\"neck_yaw\" type=\"revolute\"><parent link=\"neck\"/><child link=\"head\"/>"
      "<origin xyz=\"0 0 0.08\"/><axis xyz=\"0 0 1\"/><limit lower=\"-2\" upper=\"2\" effort=\"1\" velocity=\"1\"/></joint>\n"
      "<joint name=\"shoulder\" type=\"revolute\"><parent link=\"torso\"/><child link=\"arm\"/>"
      "<origin xyz=\"0 0.2 0.3\"/><axis xyz=\"0 1 0\"/><limit lower=\"-2\" upper=\"2\" effort=\"1\" velocity=\"1\"/></joint>\n"
      "</robot>\n";
  wbm::UrdfImportOptions options;
  options.root_height = 1.0;
  const Model original = wbm::parse_urdf(xml, options, "welded_mount.urdf");
  const int first = original.virtual_dofs().ub_yaw + 1;
  ASSERT_EQ(original.num_dofs(), first + 3);
  ASSERT_EQ(original.dof(first).name, "neck_pitch");
  ASSERT_EQ(original.dof(first + 2).name, "shoulder");
  options.root = "torso";
  const Model back = wbm::parse_urdf(wbm::export_urdf(original), options, "welded_mount_export.urdf");
  ASSERT_EQ(back.num_dofs(), original.num_dofs());
  for (int i = 0; i < original.num_dofs(); ++i) EXPECT_EQ(back.dof(i).name, original.dof(i).name) << "dof " << i;
  expect_same_frame_poses(original, back, 9, 50);

  // Two welded links between the torso and the neck (a mount and a bracket on it): the
  // mount, too, is written before the neck's joint, or the import numbers the neck last.
  std::string two = xml;
  const std::string neck_parent = "<parent link=\"head_mount\"/><child link=\"neck\"/>";
  two.replace(two.find(neck_parent), neck_parent.size(), "<parent link=\"bracket\"/><child link=\"neck\"/>");
  two.replace(two.find("<joint name=\"neck_pitch\""), 0,
              "<link name=\"bracket\"/><joint name=\"bracket_joint\" type=\"fixed\"><parent link=\"head_mount\"/>"
              "<child link=\"bracket\"/><origin xyz=\"0.02 0 0.03\" rpy=\"0.1 0 0\"/></joint>\n");
  options.root.clear();
  const Model bracketed = wbm::parse_urdf(two, options, "welded_bracket.urdf");
  ASSERT_EQ(bracketed.dof(first).name, "neck_pitch");
  options.root = "torso";
  const Model bracketed_back = wbm::parse_urdf(wbm::export_urdf(bracketed), options, "welded_bracket_export.urdf");
  ASSERT_EQ(bracketed_back.num_dofs(), bracketed.num_dofs());
  for (int i = 0; i < bracketed.num_dofs(); ++i)
    EXPECT_EQ(bracketed_back.dof(i).name, bracketed.dof(i).name) << "dof " << i << " with the bracket";
  expect_same_frame_poses(bracketed, bracketed_back, 10, 20);
}

// A dof that drives its only body with a multiplier or an offset has no URDF joint to be:
// an error that names it, not a file whose joint means another angle.
TEST(Export, DofWithoutAnUnscaledBodyIsAnError) {
  for (const auto& [multiplier, offset] : {std::pair{2.0, 0.0}, std::pair{1.0, 0.25}}) {
    try {
      wbm::export_urdf(welded_model(multiplier, offset));
      ADD_FAILURE() << "exported with multiplier " << multiplier << ", offset " << offset;
    } catch (const wbm::ModelError& e) {
      EXPECT_NE(std::string(e.what()).find("dof 'shoulder' drives no body with multiplier 1 and offset 0"),
                std::string::npos)
          << e.what();
    }
  }
}

// "Did you mean": at most three of the equally close names, in their order; names the typed
// one contains count only if they make at least half of it.
TEST(ClosestNames, AtMostThreeAndNoShortParts) {
  using wbm::internal::did_you_mean;
  EXPECT_EQ(did_you_mean("a0x", {"a1x", "a2x", "zzz", "a3x", "a4x"}), " (did you mean 'a1x', 'a2x' or 'a3x'?)");
  EXPECT_EQ(did_you_mean("a0x", {"a1x", "a2x"}), " (did you mean 'a1x' or 'a2x'?)");
  EXPECT_EQ(did_you_mean("left_hand_link", {"left_hand", "nk", "k"}), " (did you mean 'left_hand'?)");
  EXPECT_EQ(did_you_mean("left_hand_link", {"nk"}), "");
  EXPECT_EQ(did_you_mean("left_hand_link", {"hand_link"}), " (did you mean 'hand_link'?)");
}

// A joint axis written with few digits (norm within 1 % of one) is normalised, as KDL and
// urdfdom users expect: the same poses as the exact axis. Farther from unit length it is an
// error naming the line (the catalogue in test_urdf_errors.cpp has norm 2).
std::string one_joint_urdf(const std::string& axis) {
  return "<?xml version=\"1.0\"?>\n<robot name=\"r\">\n"
         "<link name=\"base\"><inertial><mass value=\"1\"/>"
         "<inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/></inertial></link>\n"
         "<link name=\"l1\"/><link name=\"l2\"/>\n"
         "<joint name=\"j1\" type=\"revolute\"><parent link=\"base\"/><child link=\"l1\"/>\n"
         "<axis xyz=\"" + axis + "\"/><limit lower=\"-2\" upper=\"2\" effort=\"1\" velocity=\"1\"/></joint>\n"
         "<joint name=\"j2\" type=\"fixed\"><parent link=\"l1\"/><child link=\"l2\"/>"
         "<origin xyz=\"0.1 0.2 0.3\"/></joint>\n</robot>\n";
}

// The export names the joints the model did not keep a name for (an added frame's) after
// their link, "tip_joint"; where the source has a joint of that name, with an underscore
// more. Two joints of one name: the file did not import again.
TEST(Export, GeneratedJointNamesDoNotClashWithTheSources) {
  std::string xml = one_joint_urdf("0 0 1");
  const std::string j2 = "<joint name=\"j2\"";
  xml.replace(xml.find(j2), j2.size(), "<joint name=\"tip_joint\"");
  wbm::UrdfImportOptions options;
  options.root_height = 1.0;
  options.added_frames.push_back({"tip", "l2", Vector3(0.0, 0.0, 0.1), Vector3::Zero()});
  const Model original = wbm::parse_urdf(xml, options, "tip.urdf");
  ASSERT_EQ(original.frame(original.frame_index("l2")).joint_name, "tip_joint");
  const std::string exported = wbm::export_urdf(original);
  EXPECT_NE(exported.find("<joint name=\"tip_joint_\" type=\"fixed\">"), std::string::npos) << exported;
  Model back = original;
  ASSERT_NO_THROW(back = wbm::parse_urdf(exported, options_named_by_export(exported), "tip_export.urdf")) << exported;
  expect_same_frame_poses(original, back, 11, 10);
}

TEST(UrdfImport, RoundedJointAxesAreNormalised) {
  const double r = std::sqrt(0.5);
  std::ostringstream exact;
  exact.precision(17);
  exact << r << " 0 " << r;
  const Model reference = wbm::parse_urdf(one_joint_urdf(exact.str()), {}, "exact.urdf");
  Data dr(reference);
  for (const std::string axis : {"0.707 0 0.707", "7.07e-1 0.0 0.707", "0.71 0 0.71"}) {
    const Model model = wbm::parse_urdf(one_joint_urdf(axis), {}, "rounded.urdf");
    Data d(model);
    for (const double angle : {-1.9, -0.3, 0.8, 2.0}) {
      Eigen::VectorXd q = model.home();
      q[model.dof_index("j1")] = angle;
      wbm::forward_kinematics(model, d, q);
      wbm::forward_kinematics(reference, dr, q);
      EXPECT_LT(wbm_test::transform_distance(wbm::frame_pose(model, d, model.frame_index("l2")),
                                             wbm::frame_pose(reference, dr, reference.frame_index("l2"))),
                1e-12)
          << axis << " at " << angle;
    }
  }
  for (const std::string axis : {"0 0 1.02", "0.7 0 0.7"}) {
    try {
      wbm::parse_urdf(one_joint_urdf(axis), {}, "typo.urdf");
      ADD_FAILURE() << axis << " was accepted";
    } catch (const wbm::ParseError& e) {
      EXPECT_NE(std::string(e.what()).find("typo.urdf:6: joint 'j1': joint axis has norm"), std::string::npos)
          << e.what();
    }
  }
}

// sdformat writes +-1e16 for "no limit" (and URDFs converted from SDF carry it), others 1e10
// or the largest float. Kept as limits, such a joint took all of W (its work range 2e16 rad)
// and the other joints of its arm hardly moved; it is a continuous joint.
TEST(UrdfImport, RevoluteJointsWithUnlimitedSpellingsAreContinuous) {
  const std::string original = wbm_test::read_file(wbm_test::source_path("models/dual_arm/dual_arm.urdf"));
  const std::string limits = "<limit lower=\"-2\" upper=\"2\" effort=\"50\" velocity=\"2\"/>";
  const std::size_t joint = original.find("<joint name=\"left_joint1\" type=\"revolute\">");
  const std::size_t at = original.find(limits, joint);
  ASSERT_NE(joint, std::string::npos);
  ASSERT_NE(at, std::string::npos);
  auto with_limits = [&](const std::string& lower, const std::string& upper) {
    std::string xml = original;
    xml.replace(at, limits.size(),
                "<limit lower=\"" + lower + "\" upper=\"" + upper + "\" effort=\"50\" velocity=\"2\"/>");
    return xml;
  };
  std::string continuous = original;
  continuous.replace(joint, std::string("<joint name=\"left_joint1\" type=\"revolute\">").size(),
                     "<joint name=\"left_joint1\" type=\"continuous\">");
  const Model reference = wbm::parse_urdf(continuous, {}, "continuous.urdf");
  const int i = reference.dof_index("left_joint1");
  ASSERT_TRUE(reference.dof(i).continuous);
  for (const auto& [lower, upper] : std::vector<std::pair<std::string, std::string>>{
           {"-1e16", "1e16"}, {"-1e+16", "1e+16"}, {"-3.4028235e+38", "3.4028235e+38"}, {"-1e6", "1e6"}}) {
    const Model model = wbm::parse_urdf(with_limits(lower, upper), {}, "unlimited.urdf");
    ASSERT_EQ(model.num_dofs(), reference.num_dofs());
    for (int d = 0; d < model.num_dofs(); ++d) {
      EXPECT_EQ(model.dof(d).continuous, reference.dof(d).continuous) << lower << ", dof " << d;
      EXPECT_EQ(model.dof(d).work_range, reference.dof(d).work_range) << lower << ", dof " << d;
      EXPECT_EQ(model.dof(d).lower, reference.dof(d).lower) << lower << ", dof " << d;
      EXPECT_EQ(model.dof(d).upper, reference.dof(d).upper) << lower << ", dof " << d;
    }
  }
  // Just inside the threshold the limits are limits: a multi-turn joint keeps them.
  const Model limited = wbm::parse_urdf(with_limits("-999999", "999999"), {}, "limited.urdf");
  EXPECT_FALSE(limited.dof(i).continuous);
  EXPECT_EQ(limited.dof(i).upper, 999999.0);
}

// ---------------------------------------------------------------------------------------
// Roll-pitch-yaw conversion, used by the exporter for every joint origin.

TEST(Transform, RpyRoundTripIncludingGimbalLock) {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  std::vector<wbm::Matrix3> rotations;
  for (int i = 0; i < 1000; ++i) {
    const double roll = angle(rng), pitch = angle(rng) / 2, yaw = angle(rng);  // drawn in this order
    rotations.push_back(wbm::rotation_from_rpy(roll, pitch, yaw));
  }
  for (double pitch : {M_PI / 2, -M_PI / 2, M_PI / 2 - 1e-9, -M_PI / 2 + 1e-12})
    for (int i = 0; i < 50; ++i) {
      const double roll = angle(rng), yaw = angle(rng);
      rotations.push_back(wbm::rotation_from_rpy(roll, pitch, yaw));
    }
  for (const wbm::Matrix3& R : rotations) {
    const Vector3 rpy = wbm::rpy_from_rotation(R);
    const wbm::Matrix3 back = wbm::rotation_from_rpy(rpy.x(), rpy.y(), rpy.z());
    ASSERT_LT((back - R).cwiseAbs().maxCoeff(), 1e-12) << "R =\n" << R << "\nrpy = " << rpy.transpose();
  }
}

}  // namespace
