#include "shipped_models.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "wbm/errors.hpp"
#include "wbm/paper_model.hpp"

namespace wbm_test {
namespace {

ShippedModel urdf(std::string id, const std::string& relative, std::vector<std::string> legs,
                  std::string left_hand, std::string right_hand, std::string head,
                  bool default_limits = false, bool has_mimic = false) {
  ShippedModel m;
  m.id = std::move(id);
  m.path = source_path("models/third_party/" + relative);
  m.options.legs = std::move(legs);
  m.options.default_limits = default_limits;
  m.left_hand = std::move(left_hand);
  m.right_hand = std::move(right_hand);
  m.head = std::move(head);
  m.has_mimic = has_mimic;
  return m;
}

/// The list is built before any test runs (when gtest expands the parameterised suites): a
/// bad variable ends the process with the script's flag, the variable, what was expected
/// and exit status 2.
[[noreturn]] void environment_error(const std::string& message) {
  std::cerr << "error: " << message << "\n";
  std::exit(2);
}

std::vector<std::string> split_names(const char* flag, const char* variable) {
  std::vector<std::string> names;
  const char* text = std::getenv(variable);
  if (text == nullptr || *text == '\0') return names;
  std::stringstream in(text);
  for (std::string name; std::getline(in, name, ',');) {
    if (name.empty()) environment_error(std::string(flag) + " (" + variable + "): empty name in '" + text + "'");
    names.push_back(name);
  }
  return names;
}

std::string join(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ",") + name;
  return text;
}

/// The user's robot (scripts/check_model.sh): WBM_TEST_URDF=PATH, WBM_TEST_HANDS=LEFT,RIGHT
/// (frames), optional WBM_TEST_HEAD (frame), WBM_TEST_LEGS=A,B, WBM_TEST_ROOT (links),
/// WBM_TEST_ROOT_HEIGHT (m), WBM_TEST_UPPER_BODY_PIVOT (m), WBM_TEST_ROOT_RPY=R,P,Y (rad), WBM_TEST_UPPER_BODY_X_RANGE=LO,HI and
/// WBM_TEST_UPPER_BODY_Y_RANGE=LO,HI (m), WBM_TEST_DEFAULT_LIMITS=1, WBM_TEST_IGNORE_XACRO_ELEMENTS=1,
/// WBM_TEST_DROP_LEGS=1, WBM_TEST_FIXED_BASE=1, WBM_TEST_ADD_FRAME=SPEC;SPEC (--add-frame). Its id,
/// in test names, is "user".
ShippedModel model_from_environment() {
  ShippedModel m;
  m.id = "user";
  m.path = std::getenv("WBM_TEST_URDF");
  m.has_mimic.reset();  // not known: the comparison with KDL checks mimic coupling
  if (!std::ifstream(m.path)) environment_error("WBM_TEST_URDF: cannot read '" + m.path + "'");
  const std::vector<std::string> hands = split_names("--hands", "WBM_TEST_HANDS");
  if (hands.size() != 2)
    environment_error("--hands (WBM_TEST_HANDS): expected LEFT,RIGHT (two frames of " + m.path + "), got " +
                      std::to_string(hands.size()) + ": '" + join(hands) + "'");
  m.left_hand = hands[0];
  m.right_hand = hands[1];
  const std::vector<std::string> head = split_names("--head", "WBM_TEST_HEAD");
  if (head.size() > 1) environment_error("--head (WBM_TEST_HEAD): expected one frame");
  if (!head.empty()) m.head = head[0];
  m.options.legs = split_names("--legs", "WBM_TEST_LEGS");
  const std::vector<std::string> root = split_names("--root", "WBM_TEST_ROOT");
  if (root.size() > 1) environment_error("--root (WBM_TEST_ROOT): expected one link");
  if (!root.empty()) m.options.root = root[0];
  // Heights >= 0 (the import refuses 0 for a robot with legs, naming the option).
  for (const auto& [flag, variable, value] :
       {std::tuple{"--root-height", "WBM_TEST_ROOT_HEIGHT", &m.options.root_height},
        std::tuple{"--upper-body-pivot", "WBM_TEST_UPPER_BODY_PIVOT", &m.options.upper_body_pivot}})
    if (const char* text = std::getenv(variable); text != nullptr && *text != '\0') {
      char* end = nullptr;
      *value = std::strtod(text, &end);
      if (*end != '\0' || !(*value >= 0.0) || !std::isfinite(*value))
        environment_error(std::string(flag) + " (" + variable + "): expected a height >= 0 in metres, got '" + text + "'");
    }
  if (const std::vector<std::string> rpy = split_names("--root-rpy", "WBM_TEST_ROOT_RPY"); !rpy.empty()) {
    if (rpy.size() != 3) environment_error("--root-rpy (WBM_TEST_ROOT_RPY): expected ROLL,PITCH,YAW in radians");
    for (int k = 0; k < 3; ++k) {
      char* end = nullptr;
      m.options.root_rpy[k] = std::strtod(rpy[k].c_str(), &end);
      if (*end != '\0' || !std::isfinite(m.options.root_rpy[k]))
        environment_error("--root-rpy (WBM_TEST_ROOT_RPY): '" + rpy[k] + "' is not an angle in radians");
    }
  }
  // The upper body's shift ranges: LOWER,UPPER in metres (their order is load_urdf's check).
  for (const auto& [flag, variable, range] :
       {std::tuple{"--upper-body-x-range", "WBM_TEST_UPPER_BODY_X_RANGE", &m.options.upper_body_x_range},
        std::tuple{"--upper-body-y-range", "WBM_TEST_UPPER_BODY_Y_RANGE", &m.options.upper_body_y_range}}) {
    const std::vector<std::string> bounds = split_names(flag, variable);
    if (bounds.empty()) continue;
    const std::string what = std::string(flag) + " (" + variable + "): ";
    if (bounds.size() != 2) environment_error(what + "expected LOWER,UPPER in metres");
    for (int k = 0; k < 2; ++k) {
      char* end = nullptr;
      (*range)[k] = std::strtod(bounds[k].c_str(), &end);
      if (*end != '\0' || !std::isfinite((*range)[k])) environment_error(what + "'" + bounds[k] + "' is not a number of metres");
    }
  }
  if (const char* frames = std::getenv("WBM_TEST_ADD_FRAME"); frames != nullptr && *frames != '\0') {
    std::stringstream in(frames);  // several --add-frame flags, joined by ';' (check_model.sh)
    for (std::string frame; std::getline(in, frame, ';');) {
      try {
        m.options.added_frames.push_back(wbm::parse_added_frame(frame));
      } catch (const wbm::ConfigError& e) {
        environment_error(std::string(e.what()) + " (WBM_TEST_ADD_FRAME)");
      }
    }
  }
  m.options.default_limits = std::getenv("WBM_TEST_DEFAULT_LIMITS") != nullptr;
  m.options.ignore_xacro_elements = std::getenv("WBM_TEST_IGNORE_XACRO_ELEMENTS") != nullptr;
  if (std::getenv("WBM_TEST_DROP_LEGS") != nullptr) m.options.leg_mode = wbm::LegMode::kDrop;
  m.fixed_base = std::getenv("WBM_TEST_FIXED_BASE") != nullptr;
  m.min_full_rank_share = 0.1;  // not known (see the field)
  // Load it and look the frames up once here, so that a wrong file or name is one message.
  if (m.left_hand == m.right_hand) environment_error("--hands (WBM_TEST_HANDS): the two hands are the same frame");
  std::string what;  // the URDF file: its errors name the file and line
  try {
    const wbm::Model model = m.load();
    what = "--hands (WBM_TEST_HANDS): ";
    for (const std::string& hand : {m.left_hand, m.right_hand})
      if (joints_moving(model, hand).empty())
        environment_error(what + "no joint of the robot moves frame '" + hand +
                          "' (it is welded to the root link, or lies in a locked leg, --legs)");
    // Two frames of one arm (every joint that moves one also moves the other): the tests
    // need a hand on each arm; with one arm the identities and the convergence fail for
    // reasons of the choice, not of the model.
    if (on_one_arm(model, m.left_hand, m.right_hand))
      environment_error(what + "'" + m.left_hand + "' and '" + m.right_hand +
                        "' are on one arm (every joint that moves one moves the other): name a frame on each arm");
    what = "--head (WBM_TEST_HEAD): ";
    if (!m.head.empty()) {
      // On a fixed base only the robot's revolute joints can turn the view axis.
      bool turned = !m.fixed_base;
      for (const int b : model.moving_bodies(model.frame(model.frame_index(m.head)).body))
        turned = turned || (model.dof(model.body(b).dof).role == wbm::DofRole::kJoint &&
                            model.body(b).joint_type == wbm::JointType::kRevolute);
      if (!turned)
        environment_error(what + "no revolute joint of the robot turns frame '" + m.head +
                          "' (on a fixed base, --fixed-base, the virtual dofs are frozen): its view axis cannot move");
    }
  } catch (const std::exception& e) {
    environment_error(what + e.what());
  }
  return m;
}

std::vector<ShippedModel> make_list() {
  std::vector<ShippedModel> list;
  ShippedModel paper;
  paper.id = "paper";
  paper.left_hand = "l_hand_ref";
  paper.right_hand = "r_hand_ref";
  paper.head = "head_camera";
  list.push_back(paper);
  // Unitree G1: rubber hands are fixed links on the last wrist link; the head is welded
  // to the torso, d435_link is its depth camera.
  list.push_back(urdf("g1_29dof", "unitree_g1/g1_29dof.urdf", {"left_hip_pitch_link", "right_hip_pitch_link"},
                      "left_rubber_hand", "right_rubber_hand", "d435_link"));
  list.push_back(urdf("g1_23dof", "unitree_g1/g1_23dof.urdf", {"left_hip_pitch_link", "right_hip_pitch_link"},
                      "left_wrist_roll_rubber_hand", "right_wrist_roll_rubber_hand", "d435_link"));
  // Unitree H1 has no hands: the elbow links carry the forearms. Camera on the torso.
  list.push_back(urdf("h1", "unitree_h1/h1.urdf", {"left_hip_yaw_link", "right_hip_yaw_link"},
                      "left_elbow_link", "right_elbow_link", "d435_rgb_module_link"));
  list.push_back(urdf("romeo_small", "romeo/romeo_small.urdf", {"LHipYawLink", "RHipYawLink"},
                      "l_gripper", "r_gripper", "gaze"));
  // Full romeo: finger joints mimic LHand/RHand, which have no speed limit in the file.
  list.push_back(urdf("romeo", "romeo/romeo.urdf", {"LHipYawLink", "RHipYawLink"}, "l_gripper", "r_gripper",
                      "gaze", /*default_limits=*/true, /*has_mimic=*/true));
  // NAO: l_gripper is turned by the LHand joint (hand opening); fingers mimic LHand.
  list.push_back(urdf("nao", "nao/nao.urdf", {"LPelvis", "RPelvis"}, "l_gripper", "r_gripper", "gaze",
                      false, /*has_mimic=*/true));
  // Atlas v4 with the MultiSense head (no camera links in this file).
  list.push_back(urdf("atlas", "atlas/atlas_v4_with_multisense.urdf", {"l_uglut", "r_uglut"}, "l_hand", "r_hand",
                      "head"));
  // wbm's own dual-arm robot on a fixed base (root link "world", no legs, no head):
  // a prismatic torso lift and two 7-joint arms with continuous wrist joints.
  ShippedModel dual_arm;
  dual_arm.id = "dual_arm";
  dual_arm.path = source_path("models/dual_arm/dual_arm.urdf");
  dual_arm.left_hand = "left_tool";
  dual_arm.right_hand = "right_tool";
  dual_arm.fixed_base = true;
  list.push_back(dual_arm);
  if (std::getenv("WBM_TEST_URDF") != nullptr) list.push_back(model_from_environment());
  return list;
}

}  // namespace

wbm::Model ShippedModel::load() const {
  if (path.empty()) return wbm::make_paper_model();
  return wbm::load_urdf(path, options);
}

Eigen::VectorXd ShippedModel::start(const wbm::Model& model) const {
  return fixed_base ? wbm::upright_base_configuration(model, model.home()) : model.home();
}

void ShippedModel::freeze_base(const wbm::Model& model, wbm::Mask& free_dofs) const {
  if (!fixed_base) return;
  for (const int i : model.virtual_dofs().all())
    if (i >= 0) free_dofs[i] = false;
}

const std::vector<ShippedModel>& shipped_models() {
  static const std::vector<ShippedModel> list = make_list();
  return list;
}

std::vector<ShippedModel> shipped_urdf_models() {
  std::vector<ShippedModel> out;
  for (const ShippedModel& m : shipped_models())
    if (m.is_urdf()) out.push_back(m);
  return out;
}

std::vector<ShippedModel> import_variants() {
  std::vector<ShippedModel> variants;
  ShippedModel g1 = shipped_model("g1_29dof");
  g1.id = "g1_29dof_torso_root";
  g1.options.root = "torso_link";
  variants.push_back(g1);
  g1 = shipped_model("g1_29dof");
  g1.id = "g1_29dof_root_turned";  // root_rpy: the root link turned and tilted in the upper-body frame
  g1.options.root_rpy = wbm::Vector3(0.3, -0.2, 2.5);
  variants.push_back(g1);
  g1 = shipped_model("g1_29dof");
  g1.id = "g1_29dof_root_tilted";  // root_rpy of a few hundredths of a radian: a mounting correction
  g1.options.root_rpy = wbm::Vector3(0.02, -0.01, 0.03);
  variants.push_back(g1);
  g1 = shipped_model("g1_29dof");
  g1.id = "g1_29dof_pivot";  // upper_body_pivot: the root link hung below the virtual dofs' end
  g1.options.upper_body_pivot = 0.25;
  variants.push_back(g1);
  g1 = shipped_model("g1_29dof");
  g1.id = "g1_29dof_legs_dropped";
  g1.options.leg_mode = wbm::LegMode::kDrop;
  variants.push_back(g1);
  for (const std::string root : {"", "link_b", "tool"}) {
    ShippedModel m;
    m.id = "synthetic_root_" + (root.empty() ? std::string("base") : root);
    m.path = source_path("tests/data/mimic_prismatic.urdf");
    m.options.root = root;
    m.options.legs = {"leg"};
    m.options.root_height = 0.7;
    m.left_hand = m.right_hand = "tool";
    m.has_mimic = true;
    variants.push_back(m);
  }
  return variants;
}

std::set<int> joints_moving(const wbm::Model& model, const std::string& frame) {
  std::set<int> joints;
  for (const int b : model.moving_bodies(model.frame(model.frame_index(frame)).body))
    if (model.dof(model.body(b).dof).role == wbm::DofRole::kJoint) joints.insert(model.body(b).dof);
  return joints;
}

bool on_one_arm(const wbm::Model& model, const std::string& a, const std::string& b) {
  const std::set<int> ja = joints_moving(model, a), jb = joints_moving(model, b);
  return std::includes(jb.begin(), jb.end(), ja.begin(), ja.end()) ||
         std::includes(ja.begin(), ja.end(), jb.begin(), jb.end());
}

ShippedModel import_variant(const std::string& id) {
  for (const ShippedModel& m : import_variants())
    if (m.id == id) return m;
  throw std::out_of_range("no import variant with id '" + id + "'");
}

const ShippedModel& shipped_model(const std::string& id) {
  for (const ShippedModel& m : shipped_models())
    if (m.id == id) return m;
  throw std::out_of_range("no shipped model with id '" + id + "'");
}

}  // namespace wbm_test
