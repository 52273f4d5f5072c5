#include "shipped_models.hpp"

#include <stdexcept>

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
  list.push_back(dual_arm);
  return list;
}

}  // namespace

wbm::Model ShippedModel::load() const {
  if (path.empty()) return wbm::make_paper_model();
  return wbm::load_urdf(path, options);
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
