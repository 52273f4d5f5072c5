// Cross-check against Orocos KDL: for every shipped URDF, KDL's tree (built by kdl_parser
// from the same file) gives the same link poses and Jacobians relative to the root link.
//
// Our model puts 9 virtual dofs before the root link, so poses are compared relative to
// the root link: X_W,root^-1 * X_W,F (ours) vs X_B,root^-1 * X_B,F (KDL, B = tree base).
// Locked leg joints are at 0 in our model; mimic joints have multiplier * q_master + offset.
// KDL ignores <mimic>: it gets those values in its joint array, and its mimic columns are
// added (times the multiplier) into the master's column.
//
// Second suite: the whole tree, virtual dofs included, as wbm::export_urdf writes it with
// virtual_dofs = true (the tree bench_wbm gives KDL). There every dof of ours is a KDL
// joint, KDL's base is our world frame, and poses and all Jacobian columns are compared in
// world coordinates, for the paper model and every shipped URDF.
#include <cmath>
#include <functional>
#include <iostream>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>
#include <kdl/tree.hpp>
#include <kdl/treefksolverpos_recursive.hpp>
#include <kdl/treejnttojacsolver.hpp>
#include <urdf_parser/urdf_parser.h>

#include "console_capture.hpp"
#include "kdl_parse.hpp"
#include "shipped_models.hpp"
#include "test_util.hpp"
#include "wbm/kinematics.hpp"
#include "wbm/paper_model.hpp"
#include "wbm/urdf_import.hpp"

namespace {

using wbm::Data;
using wbm::Model;
using wbm::Transform;
using wbm_test::ShippedModel;

constexpr int kConfigurations = 200;
constexpr double kTolerance = 1e-9;
constexpr int kMaxReportedFailures = 8;

Transform to_transform(const KDL::Frame& F) {
  Transform X;
  for (int r = 0; r < 3; ++r) {
    X.p[r] = F.p(r);
    for (int c = 0; c < 3; ++c) X.R(r, c) = F.M(r, c);
  }
  return X;
}

/// Mimic relations of the URDF (KDL's tree does not keep them).
struct Mimic {
  std::string master;
  double multiplier = 1.0, offset = 0.0;
};

std::map<std::string, Mimic> read_mimics(const urdf::ModelInterfaceSharedPtr& urdf, const std::string& source) {
  std::map<std::string, Mimic> mimics;
  if (!urdf) throw std::runtime_error("urdfdom cannot parse " + source);
  for (const auto& [name, joint] : urdf->joints_)
    if (joint->mimic) mimics[name] = {joint->mimic->joint_name, joint->mimic->multiplier, joint->mimic->offset};
  return mimics;
}

/// One movable KDL joint: its column in KDL's arrays and where it goes in ours.
struct KdlJoint {
  std::string name;
  unsigned q_nr = 0;
};

/// Compares poses and Jacobians of `model` with KDL's `tree` on random configurations.
/// whole_tree = false: the tree is the URDF from the root link down; poses are compared
/// relative to the root link and virtual-dof columns are skipped. true: the tree has every
/// dof of ours and its base is our world frame; everything is compared in world coordinates.
void compare_with_kdl(const std::string& id, const Model& model, const KDL::Tree& tree,
                      const std::map<std::string, Mimic>& mimics, bool whole_tree, int dropped_segments = 0) {
  const unsigned nj = tree.getNrOfJoints();
  std::vector<KdlJoint> joints;
  for (const auto& [segment_name, element] : tree.getSegments()) {
    const KDL::Segment& segment = GetTreeElementSegment(element);
    if (segment.getJoint().getType() != KDL::Joint::None)
      joints.push_back({segment.getJoint().getName(), GetTreeElementQNr(element)});
  }
  ASSERT_EQ(joints.size(), nj);

  // Frames to compare: our frames that are URDF links (KDL segments), on real bodies.
  const wbm::VirtualDofs& v = model.virtual_dofs();
  const std::string root = whole_tree ? GetTreeElementSegment(tree.getRootSegment()->second).getName()
                                      : model.body(v.upper_body).name;
  ASSERT_TRUE(tree.getSegments().count(root)) << "root link " << root << " is not a KDL segment";
  std::vector<int> frames;
  for (int f = 0; f < model.num_frames(); ++f)
    if ((whole_tree || model.frame(f).body >= v.upper_body) && tree.getSegments().count(model.frame(f).name))
      frames.push_back(f);
  // Every URDF link except a cut-off world link (or the exported world link) and the links
  // of dropped legs is a frame of ours.
  EXPECT_GE(frames.size() + 1 + dropped_segments, tree.getSegments().size()) << "frames missing in our model";
  const int root_frame = whole_tree ? -1 : model.frame_index(root);
  auto compared = [&](int dof) { return whole_tree || model.dof(dof).role == wbm::DofRole::kJoint; };

  // The joint value KDL gets for a URDF joint, given our configuration q.
  std::function<double(const std::string&, const Eigen::VectorXd&)> joint_value =
      [&](const std::string& joint, const Eigen::VectorXd& q) -> double {
    const auto m = mimics.find(joint);
    if (m != mimics.end()) return m->second.multiplier * joint_value(m->second.master, q) + m->second.offset;
    const int dof = model.find_dof(joint);
    return dof >= 0 ? q[dof] : 0.0;  // locked leg joint: 0
  };
  // The dof a KDL column adds into, and with which factor (-1: a locked joint).
  std::vector<std::pair<int, double>> column_target(nj, {-1, 0.0});
  int mapped = 0;
  for (const KdlJoint& j : joints) {
    std::string name = j.name;
    double factor = 1.0;
    while (mimics.count(name)) {
      factor *= mimics.at(name).multiplier;
      name = mimics.at(name).master;
    }
    const int dof = model.find_dof(name);
    if (dof >= 0) {
      column_target[j.q_nr] = {dof, factor};
      ++mapped;
    }
  }
  // Every dof of ours (every non-virtual one unless whole_tree) is a KDL joint.
  int expected_dofs = 0;
  for (int i = 0; i < model.num_dofs(); ++i) expected_dofs += compared(i);
  std::vector<bool> dof_seen(model.num_dofs(), false);
  for (const auto& [dof, factor] : column_target)
    if (dof >= 0) dof_seen[dof] = true;
  for (int i = 0; i < model.num_dofs(); ++i)
    if (compared(i)) {
      EXPECT_TRUE(dof_seen[i]) << "dof " << model.dof(i).name << " not in KDL";
    }
  EXPECT_GE(mapped, expected_dofs);

  KDL::TreeFkSolverPos_recursive kdl_fk(tree);
  KDL::TreeJntToJacSolver kdl_jac(tree);
  KDL::JntArray kq(nj);
  KDL::Jacobian kJ(nj), kJ_root(nj);
  Data data(model);
  Eigen::MatrixXd J(6, model.num_dofs());
  std::mt19937_64 rng(2024);
  int failures = 0;
  double worst_pose = 0.0, worst_jacobian = 0.0;

  for (int c = 0; c < kConfigurations && failures < kMaxReportedFailures; ++c) {
    const Eigen::VectorXd q = wbm_test::random_configuration(model, rng);
    for (const KdlJoint& j : joints) kq(j.q_nr) = joint_value(j.name, q);
    wbm::forward_kinematics(model, data, q);
    const Transform X_W_root = whole_tree ? Transform() : wbm::frame_pose(model, data, root_frame);
    KDL::Frame kdl_root;
    ASSERT_GE(kdl_fk.JntToCart(kq, kdl_root, root), 0);
    const Transform X_B_root = to_transform(kdl_root);
    // The root link's own motion in KDL's tree: zero unless the model was re-rooted at a
    // link below KDL's root (UrdfImportOptions::root), whose joints then move that link.
    ASSERT_GE(kdl_jac.JntToJac(kq, kJ_root, root), 0) << root;

    for (const int f : frames) {
      const std::string& name = model.frame(f).name;
      // Poses relative to the root link.
      KDL::Frame kdl_pose;
      ASSERT_GE(kdl_fk.JntToCart(kq, kdl_pose, name), 0) << name;
      const Transform ours = X_W_root.inverse() * wbm::frame_pose(model, data, f);
      const Transform theirs = X_B_root.inverse() * to_transform(kdl_pose);
      const double pose_error = wbm_test::transform_distance(ours, theirs);
      worst_pose = std::max(worst_pose, pose_error);
      if (!(pose_error <= kTolerance) && ++failures <= kMaxReportedFailures)
        ADD_FAILURE() << id << ", configuration #" << c << ", frame " << name << ": pose differs from KDL by "
                      << pose_error << "\n  ours:\n" << ours.R << "\n  " << ours.p.transpose() << "\n  KDL:\n"
                      << theirs.R << "\n  " << theirs.p.transpose()
                      << "\n  q = " << wbm_test::describe_configuration(model, q);

      // Jacobians in root-link coordinates, reference point at the frame origin, of the
      // motion relative to the root link: KDL's column minus the root link's motion (its
      // twist moved to the frame origin: v_R + w_R x (p_F - p_R)).
      ASSERT_GE(kdl_jac.JntToJac(kq, kJ, name), 0) << name;
      wbm::frame_jacobian(model, data, f, J);
      const Eigen::Vector3d p_RF_B = to_transform(kdl_pose).p - X_B_root.p;
      Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(6, model.num_dofs());
      for (unsigned k = 0; k < nj; ++k) {
        const auto [dof, factor] = column_target[k];
        if (dof < 0) continue;
        const Eigen::Vector3d w_root = kJ_root.data.col(k).tail<3>();
        Eigen::Matrix<double, 6, 1> relative = kJ.data.col(k);
        relative.head<3>() -= kJ_root.data.col(k).head<3>() + w_root.cross(p_RF_B);
        relative.tail<3>() -= w_root;
        expected.col(dof) += factor * relative;
      }
      const Eigen::Matrix3d R_root_B = X_B_root.R.transpose();
      expected.topRows(3) = R_root_B * expected.topRows(3);
      expected.bottomRows(3) = R_root_B * expected.bottomRows(3);
      const Eigen::Matrix3d R_root_W = X_W_root.R.transpose();
      Eigen::MatrixXd actual(6, model.num_dofs());
      actual.topRows(3) = R_root_W * J.topRows(3);
      actual.bottomRows(3) = R_root_W * J.bottomRows(3);
      for (int i = 0; i < model.num_dofs(); ++i) {
        if (!compared(i)) continue;  // virtual dofs of a URDF tree: no KDL counterpart
        const double err = (actual.col(i) - expected.col(i)).cwiseAbs().maxCoeff();
        worst_jacobian = std::max(worst_jacobian, err);
        if (!(err <= kTolerance) && ++failures <= kMaxReportedFailures)
          ADD_FAILURE() << id << ", configuration #" << c << ", frame " << name << ", column " << i << " ("
                        << model.dof(i).name << "): ours " << wbm_test::describe_vector(actual.col(i)) << " vs KDL "
                        << wbm_test::describe_vector(expected.col(i)) << ", error " << err
                        << "\n  q = " << wbm_test::describe_configuration(model, q);
      }
    }
  }
  EXPECT_EQ(failures, 0);
  testing::Test::RecordProperty("frames", static_cast<int>(frames.size()));
  std::cout << "  " << id << ": " << frames.size() << " frames x " << kConfigurations
            << " configurations, largest pose difference " << worst_pose << ", largest Jacobian difference "
            << worst_jacobian << "\n";
}

class KdlComparison : public testing::TestWithParam<ShippedModel> {};

TEST_P(KdlComparison, PosesAndJacobiansMatchKdl) {
  const ShippedModel& entry = GetParam();
  const Model model = entry.load();
  KDL::Tree tree;
  // The URDF with the frames the model adds (--add-frame), as fixed links: none on the shipped models.
  const std::string xml = wbm_test::urdf_text_with_added_frames(entry.path, entry.options.added_frames);
  const wbm_test::KdlParse parsed = wbm_test::kdl_tree_from_string(xml, tree);
  if (!parsed.ok)
    GTEST_SKIP() << "kdl_parser could not parse " << entry.path << " (no KDL reference for model " << entry.id
                 << "): " << parsed.summary();
  if (parsed.messages > 0) std::cout << "  " << entry.id << ": " << parsed.summary() << "\n";
  int dropped = 0;  // links of legs removed (LegMode::kDrop): the leg link's subtree in KDL's tree
  if (entry.options.leg_mode == wbm::LegMode::kDrop) {
    std::function<int(const KDL::SegmentMap::const_iterator&)> subtree_size = [&](const auto& segment) {
      int size = 1;
      for (const auto& child : GetTreeElementChildren(segment->second)) size += subtree_size(child);
      return size;
    };
    for (const std::string& leg : entry.options.legs) {
      const auto segment = tree.getSegments().find(leg);
      if (segment != tree.getSegments().end()) dropped += subtree_size(segment);
    }
  }
  compare_with_kdl(entry.id, model, tree, read_mimics(wbm_test::urdf_model_from_string(xml), entry.path), false, dropped);
}

// Frame::parent draws the robot: every frame hangs from the frame of the link next to it in
// the URDF. Checked against urdfdom's joints (an undirected tree: re-rooting reverses
// joints): the edges between our frames are exactly the URDF joints between links we keep. A
// reversed joint's body (named after the joint) stands between its two links: it is merged
// into the frame it hangs from, which leaves the URDF's edge.
TEST_P(KdlComparison, FrameParentsAreTheUrdfJoints) {
  const ShippedModel& entry = GetParam();
  const Model model = entry.load();
  const urdf::ModelInterfaceSharedPtr urdf =
      wbm_test::urdf_model_from_string(wbm_test::urdf_text_with_added_frames(entry.path, entry.options.added_frames));
  ASSERT_TRUE(urdf) << entry.path;
  const int first = model.virtual_dofs().upper_body;  // frames before it are the virtual chain's
  auto is_link = [&](int f) { return urdf->links_.count(model.frame(f).name) > 0; };
  // A frame that is a URDF link, following reversed joints' bodies up to their parents.
  std::function<int(int)> link_of = [&](int f) {
    if (is_link(f)) return f;
    EXPECT_GE(model.frame(f).parent, 0) << entry.id << ": frame " << model.frame(f).name
                                        << " is neither a URDF link nor hangs from one";
    return model.frame(f).parent >= 0 ? link_of(model.frame(f).parent) : f;
  };
  std::set<std::pair<std::string, std::string>> ours, expected;
  auto edge = [](const std::string& a, const std::string& b) { return a < b ? std::pair(a, b) : std::pair(b, a); };
  for (int f = 0; f < model.num_frames(); ++f) {
    const wbm::Frame& frame = model.frame(f);
    if (frame.body < first) {
      EXPECT_EQ(frame.parent, -1) << entry.id << ": virtual frame " << frame.name;
      continue;
    }
    if (frame.parent < 0) {
      EXPECT_EQ(frame.name, model.body(first).name) << entry.id << ": only the root link hangs from nothing";
      continue;
    }
    const int a = link_of(f), b = link_of(frame.parent);
    if (a != b) ours.insert(edge(model.frame(a).name, model.frame(b).name));
  }
  auto kept = [&](const std::string& link) {
    const int f = model.find_frame(link);
    return f >= 0 && model.frame(f).body >= first;
  };
  for (const auto& [name, joint] : urdf->joints_)
    if (kept(joint->parent_link_name) && kept(joint->child_link_name))
      expected.insert(edge(joint->parent_link_name, joint->child_link_name));
  EXPECT_EQ(ours, expected) << entry.id;
  EXPECT_GE(expected.size(), 5u) << entry.id;  // not vacuous
}

/// The whole tree as exported with the virtual dofs, parsed by kdl_parser.
void compare_whole_tree_with_kdl(const std::string& id, const Model& model) {
  wbm::UrdfExportOptions options;
  options.virtual_dofs = true;
  const std::string xml = wbm::export_urdf(model, options);
  KDL::Tree tree;
  const wbm_test::KdlParse parsed = wbm_test::kdl_tree_from_string(xml, tree);
  ASSERT_TRUE(parsed.ok) << id << ": kdl_parser rejects the whole-tree export; " << parsed.summary();
  EXPECT_EQ(parsed.messages, 0) << id << ": the whole-tree export: " << parsed.summary();
  // The root is "world", or "world_" where the model has a frame of that name
  // (models/dual_arm keeps its URDF's world link as a frame on its base).
  const std::string world = model.find_frame("world") >= 0 ? "world_" : "world";
  EXPECT_EQ(GetTreeElementSegment(tree.getRootSegment()->second).getName(), world);
  int mimic_joints = 0;
  for (int b = 0; b < model.num_bodies(); ++b) mimic_joints += model.body(b).dof >= 0;
  mimic_joints -= model.num_dofs();  // bodies that share a dof with an earlier body
  EXPECT_EQ(tree.getNrOfJoints(), static_cast<unsigned>(model.num_dofs() + mimic_joints)) << id;
  compare_with_kdl(id + " (whole tree)", model, tree, read_mimics(urdf::parseURDF(xml), id + " export"), true);
}

class KdlWholeTree : public testing::TestWithParam<ShippedModel> {};

TEST_P(KdlWholeTree, ExportWithVirtualDofsMatchesKdl) {
  const ShippedModel& entry = GetParam();
  compare_whole_tree_with_kdl(entry.id, entry.load());
}

TEST(KdlWholeTreePaper, ExportWithVirtualDofsMatchesKdl) { compare_whole_tree_with_kdl("paper", wbm::make_paper_model()); }

INSTANTIATE_TEST_SUITE_P(ShippedUrdfs, KdlComparison, testing::ValuesIn(wbm_test::shipped_urdf_models()), wbm_test::ModelIdName());
// Re-rooted (KDL keeps the URDF's root: Jacobians compared relative to our root link) and
// with dropped legs (KDL has their links).
INSTANTIATE_TEST_SUITE_P(ImportVariants, KdlComparison, testing::ValuesIn(wbm_test::import_variants()), wbm_test::ModelIdName());
INSTANTIATE_TEST_SUITE_P(ShippedUrdfs, KdlWholeTree, testing::ValuesIn(wbm_test::shipped_urdf_models()), wbm_test::ModelIdName());

}  // namespace

namespace {

// urdfdom's messages while the KDL reference reads a file (one per link with a nameless
// visual material, as in Unitree's H1_2) are counted, the first kept, and not printed;
// the tree is still built.
TEST(KdlParse, UrdfdomMessagesAreCountedNotPrinted) {
  std::string xml = "<?xml version=\"1.0\"?>\n<robot name=\"r\">\n";
  for (const char* link : {"base", "l1", "l2"})
    xml += std::string("<link name=\"") + link +
           "\"><inertial><mass value=\"1\"/><inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" iyy=\"0.1\" iyz=\"0\" "
           "izz=\"0.1\"/></inertial><visual><geometry><box size=\"0.1 0.1 0.1\"/></geometry><material/></visual></link>\n";
  for (const char* joint : {"j1", "j2"})
    xml += std::string("<joint name=\"") + joint + "\" type=\"revolute\"><parent link=\"" +
           (joint[1] == '1' ? "base" : "l1") + "\"/><child link=\"" + (joint[1] == '1' ? "l1" : "l2") +
           "\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>\n";
  xml += "</robot>\n";
  KDL::Tree tree;
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const wbm_test::KdlParse parsed = wbm_test::kdl_tree_from_string(xml, tree);
  const std::string out = testing::internal::GetCapturedStdout(), err = testing::internal::GetCapturedStderr();
  ASSERT_TRUE(parsed.ok) << parsed.summary();
  EXPECT_EQ(tree.getNrOfJoints(), 2u);
  EXPECT_GE(parsed.messages, 3) << parsed.summary();  // a message per link at least
  EXPECT_NE(parsed.first_message.find("material"), std::string::npos) << parsed.first_message;
  EXPECT_EQ(out.find("material"), std::string::npos) << out;
  EXPECT_EQ(err.find("material"), std::string::npos) << err;
  EXPECT_NE(parsed.summary().find(" messages while kdl_parser read the file (the first: '"), std::string::npos)
      << parsed.summary();
}

// The import's error when urdfdom rejects a file quotes urdfdom's first messages, not a page:
// urdfdom repeats a problem for every link that has it (a vector with tabs: one message per
// link, 40 on the G1, before the import named the line itself).
TEST(ConsoleCapture, TextKeepsTheFirstMessagesAndCountsTheRest) {
  wbm::internal::ConsoleCapture capture;
  for (int i = 1; i <= 7; ++i) CONSOLE_BRIDGE_logError("problem %d", i);
  CONSOLE_BRIDGE_logDebug("not an error");
  EXPECT_EQ(capture.messages().size(), 7u);
  EXPECT_EQ(capture.text(), "problem 1; problem 2; problem 3; problem 4; and 3 more messages");
  EXPECT_EQ(capture.text(7), "problem 1; problem 2; problem 3; problem 4; problem 5; problem 6; problem 7");
}

}  // namespace
