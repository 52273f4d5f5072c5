// The wbm command-line tool: runs it through the shell and parses its JSON output.
#include <sys/wait.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"

#include "shipped_models.hpp"
#include "wbm/kinematics.hpp"
#include "wbm/paper_model.hpp"

#ifndef WBM_CLI_PATH
#error "WBM_CLI_PATH must name the wbm command-line tool"
#endif

namespace {

using nlohmann::json;

using wbm_test::CliRun;
using wbm_test::read_file;

/// Runs `wbm ARGS`.
CliRun wbm_cli(const std::string& args) {
  return wbm_test::run_command(std::string("'") + WBM_CLI_PATH + "' " + args, "wbm_cli_test");
}

json parse(const CliRun& r) {
  EXPECT_EQ(r.status, 0) << r.err;
  try {
    return json::parse(r.out);
  } catch (const json::exception& e) {
    ADD_FAILURE() << "not JSON (" << e.what() << "):\n" << r.out.substr(0, 2000);
    return json();
  }
}

TEST(Cli, ModelInfoText) {
  const CliRun r = wbm_cli("model info");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("model paper_asimo_like: 21 dofs"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("l_hand_ref"), std::string::npos);
  // A welded link names its body and the link it hangs from.
  const CliRun g1 = wbm_cli("model info '" + wbm_test::shipped_model("g1_29dof").path + "'");
  EXPECT_NE(g1.out.find("\n  left_rubber_hand (left_wrist_yaw_link, from left_wrist_yaw_link)\n"), std::string::npos)
      << g1.out;
  EXPECT_NE(g1.out.find("\n  d435_link (torso_link, from torso_link)\n"), std::string::npos) << g1.out;
}

// A placeholder <limit velocity> (ergoCub's URDFs declare 1e9 rad/s on every joint) would
// leave the speed limits without effect: `model info` says so; realistic speeds get no note.
TEST(Cli, ModelInfoNotesImplausibleSpeedLimits) {
  const std::string file = testing::TempDir() + "wbm_cli_fast_" + std::to_string(getpid()) + ".urdf";
  std::ofstream(file) << "<?xml version=\"1.0\"?>\n<robot name=\"fast\">\n"
                         "<link name=\"base\"><inertial><mass value=\"1\"/>"
                         "<inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/></inertial></link>\n"
                         "<link name=\"a\"/><link name=\"b\"/><link name=\"c\"/>\n"
                         "<joint name=\"slow\" type=\"revolute\"><parent link=\"base\"/><child link=\"a\"/><axis xyz=\"0 0 1\"/>"
                         "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"30\"/></joint>\n"
                         "<joint name=\"round\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><axis xyz=\"0 1 0\"/>"
                         "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"100\"/></joint>\n"
                         "<joint name=\"fast\" type=\"revolute\"><parent link=\"b\"/><child link=\"c\"/><axis xyz=\"1 0 0\"/>"
                         "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1e9\"/></joint>\n</robot>\n";
  const CliRun r = wbm_cli("model info '" + file + "' --root-height 1");
  const CliRun as_json = wbm_cli("model info '" + file + "' --root-height 1 --json");
  std::remove(file.c_str());
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("note: 2 dofs with a speed limit of 100 rad/s or m/s or more (the largest: 'fast', 1e+09)"),
            std::string::npos)
      << r.out;
  const json notes = parse(as_json)["notes"];  // the same notes for scripts
  ASSERT_EQ(notes.size(), 1u) << as_json.out;
  EXPECT_EQ(notes[0].get<std::string>().rfind("2 dofs with a speed limit of 100 rad/s or m/s or more", 0), 0u) << notes;
  const CliRun paper = wbm_cli("model info");
  EXPECT_EQ(paper.out.find("note:"), std::string::npos) << paper.out;
  const CliRun g1 = wbm_cli("model info '" + wbm_test::shipped_model("g1_29dof").path + "'");
  EXPECT_EQ(g1.status, 0) << g1.err;
  EXPECT_EQ(g1.out.find("note:"), std::string::npos) << g1.out;
}

// Legs that point forward, backward or sideways at zero joint values get a note naming
// --root-rpy (a root link turned by pi/2 that the import's own check lets pass, e.g. with the
// root height given); no shipped humanoid's legs do.
TEST(Cli, ModelInfoNotesLegsThatDoNotPointDown) {
  for (const wbm_test::ShippedModel& m : wbm_test::shipped_urdf_models()) {
    if (m.options.legs.empty()) continue;
    std::string legs;
    for (const std::string& leg : m.options.legs) legs += (legs.empty() ? "" : ",") + leg;
    std::string flags = " --legs " + legs;
    if (!m.options.root.empty()) flags += " --root " + m.options.root;
    if (m.options.default_limits) flags += " --default-limits";
    const CliRun r = wbm_cli("model info '" + m.path + "'" + flags);
    EXPECT_EQ(r.status, 0) << m.id << ": " << r.err;
    EXPECT_EQ(r.out.find("note: the legs"), std::string::npos) << m.id << ": " << r.out;
  }
  const wbm_test::ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const std::string g1_info = "model info '" + g1.path + "' --legs left_hip_pitch_link,right_hip_pitch_link --root-height 0.8";
  for (const auto& [rpy, expected] :
       {std::pair{"0,1.5707963,0", "note: the legs point backward rather than down at zero joint values (from their "
                                   "first link to their farthest, on average -0.65 m forward, 0.00 m left, 0.00 m up"},
        std::pair{"0,-1.5707963,0", "note: the legs point forward rather than down"},
        std::pair{"1.5707963,0,0", "note: the legs point to the left rather than down"},
        std::pair{"-1.5707963,0,0", "note: the legs point to the right rather than down"}}) {
    const CliRun r = wbm_cli(g1_info + " --root-rpy " + rpy);
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find(expected), std::string::npos) << rpy << ": " << r.out;
    EXPECT_NE(r.out.find("give its orientation with --root-rpy"), std::string::npos) << r.out;
    const json notes = parse(wbm_cli(g1_info + " --root-rpy " + rpy + " --json"))["notes"];
    ASSERT_EQ(notes.size(), 1u) << notes;
    EXPECT_EQ(notes[0].get<std::string>(), r.out.substr(r.out.find("note: the legs") + 6,
                                                         r.out.find('\n', r.out.find("note: the legs")) -
                                                             r.out.find("note: the legs") - 6));
  }
  EXPECT_EQ(parse(wbm_cli(g1_info + " --json"))["notes"], json::array());
  // Tilted by less than 45 degrees (0.7 rad) the legs still point down; dropped legs say nothing.
  EXPECT_EQ(wbm_cli(g1_info + " --root-rpy 0,0.7,0").out.find("note: the legs"), std::string::npos);
  // By more (1 rad: 1.56 times as far backward as down), they point backward.
  EXPECT_NE(wbm_cli(g1_info + " --root-rpy 0,1,0").out.find("note: the legs point backward"), std::string::npos);
  EXPECT_EQ(wbm_cli(g1_info + " --root-rpy 0,1.5707963,0 --drop-legs").out.find("note: the legs"), std::string::npos);
}

// Arms given as legs: pointing up (the dual-arm robot's) or apart (two links straight out to
// the sides, which said "the legs point to the right ... 0.00 m forward, 0.00 m left, 0.00 m
// up") get a note that names --legs.
TEST(Cli, ModelInfoNotesLegsThatPointUpOrApart) {
  const CliRun up = wbm_cli("model info '" + wbm_test::source_path("models/dual_arm/dual_arm.urdf") +
                            "' --legs left_link1,right_link1 --root-height 1");
  EXPECT_EQ(up.status, 0) << up.err;
  EXPECT_NE(up.out.find("note: the legs point up rather than down at zero joint values (from their first link to their "
                        "farthest, on average 0.00 m forward, 0.00 m left, 1.02 m up"),
            std::string::npos)
      << up.out;
  EXPECT_NE(up.out.find("if these are not the robot's legs, --legs (robot.legs) names the first link of each leg"),
            std::string::npos)
      << up.out;
  const std::string file = testing::TempDir() + "wbm_cli_apart_" + std::to_string(getpid()) + ".urdf";
  std::string xml = "<?xml version=\"1.0\"?>\n<robot name=\"apart\">\n"
                    "<link name=\"base\"><inertial><mass value=\"1\"/>"
                    "<inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/></inertial></link>\n";
  for (const auto& [side, y] : {std::pair{"l", "0.4"}, std::pair{"r", "-0.4"}})
    xml += std::string("<link name=\"") + side + "_upper\"/><link name=\"" + side + "_lower\"/>\n<joint name=\"" + side +
           "_hip\" type=\"revolute\"><parent link=\"base\"/><child link=\"" + side +
           "_upper\"/><origin xyz=\"0 0 -0.1\"/><axis xyz=\"0 1 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" "
           "velocity=\"5\"/></joint>\n<joint name=\"" + side + "_knee\" type=\"revolute\"><parent link=\"" + side +
           "_upper\"/><child link=\"" + side + "_lower\"/><origin xyz=\"0 " + y +
           " 0\"/><axis xyz=\"0 1 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"5\"/></joint>\n";
  std::ofstream(file) << xml << "</robot>\n";
  const CliRun apart = wbm_cli("model info '" + file + "' --legs l_upper,r_upper --root-height 1");
  std::remove(file.c_str());
  EXPECT_EQ(apart.status, 0) << apart.err;
  EXPECT_NE(apart.out.find("note: the legs point apart rather than down at zero joint values (from their first link to "
                           "their farthest, 0.40 m long on average, their directions cancel): if these are not the "
                           "robot's legs, --legs (robot.legs) names the first link of each leg"),
            std::string::npos)
      << apart.out;
}

// One leg named: the other is the robot's own dofs, which a biped's user did not mean.
TEST(Cli, ModelInfoNotesASingleLeg) {
  const std::string g1 = wbm_test::shipped_model("g1_29dof").path;
  const CliRun r = wbm_cli("model info '" + g1 + "' --legs left_hip_pitch_link");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("note: one leg given ('left_hip_pitch_link'): a robot with two legs names the first link of each"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(wbm_cli("model info '" + g1 + "' --legs left_hip_pitch_link,right_hip_pitch_link").out.find("one leg"),
            std::string::npos);
  // Degrees for the root's turn: the hint.
  const CliRun degrees = wbm_cli("model info '" + g1 + "' --root-rpy 0,0,180");
  EXPECT_NE(degrees.status, 0);
  EXPECT_NE(degrees.err.find("got 0, 0, 180 (degrees?)"), std::string::npos) << degrees.err;
}

// A URDF without masses (a kinematic description) loads; the note says what needs them.
TEST(Cli, ModelInfoNotesAModelWithoutMass) {
  std::string xml = wbm_test::read_file(wbm_test::source_path("models/dual_arm/dual_arm.urdf"));
  int removed = 0;
  for (std::size_t at; (at = xml.find("<inertial>")) != std::string::npos; ++removed)
    xml.erase(at, xml.find("</inertial>", at) + std::string("</inertial>").size() - at);
  ASSERT_GT(removed, 10);
  const std::string file = testing::TempDir() + "wbm_cli_massless_" + std::to_string(getpid()) + ".urdf";
  std::ofstream(file) << xml;
  const CliRun r = wbm_cli("model info '" + file + "'");
  const CliRun as_json = wbm_cli("model info '" + file + "' --json");
  std::remove(file.c_str());
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("note: the model has no mass (no <inertial> with a mass in the URDF): centre-of-mass tasks and "
                       "balance need the links' masses"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(parse(as_json)["notes"].size(), 1u) << as_json.out;
  // With masses: no such note.
  const CliRun dual_arm = wbm_cli("model info '" + wbm_test::source_path("models/dual_arm/dual_arm.urdf") + "'");
  EXPECT_EQ(dual_arm.out.find("has no mass"), std::string::npos) << dual_arm.out;
}

// A world link whose joint turns or shifts the robot: wbm stands the base upright above its
// origin, so its world frame is not the URDF's; the note says where the URDF's lies and the
// --root-rpy that turns the robot as the file has it (AgileX Nero's world joint, yaw pi).
TEST(Cli, ModelInfoNotesAWorldLinkThatIsNotWbmsWorld) {
  std::string xml = wbm_test::read_file(wbm_test::source_path("models/dual_arm/dual_arm.urdf"));
  const std::string at_root = R"(<child link="base"/>
    <origin xyz="0 0 0" rpy="0 0 0"/>)";
  ASSERT_NE(xml.find(at_root), std::string::npos);
  xml.replace(xml.find(at_root), at_root.size(), R"(<child link="base"/>
    <origin xyz="0 0 0" rpy="0 0 1.5707963267948966"/>)");
  const std::string file = testing::TempDir() + "wbm_cli_world_turned_" + std::to_string(getpid()) + ".urdf";
  std::ofstream(file) << xml;
  const CliRun turned = wbm_cli("model info '" + file + "'");
  const CliRun fixed = wbm_cli("model info '" + file + "' --root-rpy 0,0,1.5707963267948966");
  // With a turn of the user's own, the flag the note suggests is still the root's whole turn
  // that puts the file's world on wbm's (it replaces the user's): given, the note goes.
  const CliRun own = wbm_cli("model info '" + file + "' --root-rpy 0.2,0,0");
  const std::size_t flag = own.out.find("(--root-rpy ");
  ASSERT_NE(flag, std::string::npos) << own.out;
  const std::size_t end = own.out.find(' ', flag + 12);
  const std::string suggested = own.out.substr(flag + 12, end - flag - 12);
  EXPECT_EQ(suggested, "0,0,1.570796327") << own.out;
  const CliRun again = wbm_cli("model info '" + file + "' --root-rpy " + suggested);
  EXPECT_EQ(again.status, 0) << again.err;
  EXPECT_EQ(again.out.find("world link is not"), std::string::npos) << suggested << "\n" << again.out;
  std::remove(file.c_str());
  EXPECT_EQ(turned.status, 0) << turned.err;
  EXPECT_NE(turned.out.find("note: the URDF's world link is not wbm's world frame: with the base upright (as a fixed base "
                            "stands) it lies at (0, 0, 0) m, turned by roll, pitch, yaw 0, 0, -1.571 rad (--root-rpy "
                            "0,0,1.570796327 turns the robot as the file has it)"),
            std::string::npos)
      << turned.out;
  EXPECT_EQ(fixed.out.find("world link is not"), std::string::npos) << fixed.out;
  // models/dual_arm: the URDF's world is wbm's.
  const CliRun plain = wbm_cli("model info '" + wbm_test::source_path("models/dual_arm/dual_arm.urdf") + "'");
  EXPECT_EQ(plain.out.find("world link is not"), std::string::npos) << plain.out;
}

// The root link and its standing height (G1's from its soles: the ankle roll link's
// collision spheres 3.5 cm below it).
TEST(Cli, ModelInfoNamesTheRootLinkAndItsHeight) {
  const wbm_test::ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const wbm::Model model = g1.load();
  const double height = model.dof(model.virtual_dofs().ub_z).upper;
  const std::string info = "model info '" + g1.path + "' --legs left_hip_pitch_link,right_hip_pitch_link";
  const json j = parse(wbm_cli(info + " --json"));
  EXPECT_EQ(j["root_link"], "pelvis");
  EXPECT_EQ(j["root_height"].get<double>(), height);
  EXPECT_NEAR(height, 0.7925, 0.001);  // Unitree's own figure for the pelvis standing straight: 0.793 m
  const CliRun r = wbm_cli(info);
  EXPECT_NE(r.out.find("\nroot link 'pelvis', 0.79"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(" m above the ground standing straight (upper_body_z's upper limit"), std::string::npos) << r.out;
}

TEST(Cli, ModelInfoJson) {
  const json j = parse(wbm_cli("model info --json"));
  ASSERT_TRUE(j.is_object());
  EXPECT_EQ(j["name"], "paper_asimo_like");
  EXPECT_NEAR(j["total_mass"].get<double>(), 54.0, 1e-9);
  ASSERT_EQ(j["dofs"].size(), 21u);
  EXPECT_EQ(j["dofs"][0]["name"], "heel_x");
  EXPECT_EQ(j["dofs"][2]["type"], "continuous");
  EXPECT_TRUE(j["dofs"][2]["lower"].is_null());  // -inf is written as null
  EXPECT_EQ(j["dofs"][20]["name"], "head_tilt");
  bool hand = false;
  for (const json& f : j["frames"]) hand |= f["name"] == "l_hand_ref";
  EXPECT_TRUE(hand);
  // Frame::parent: G1's locked legs hang link from link (null where not given).
  const json g1 = parse(wbm_cli("model info --json " + wbm_test::shipped_model("g1_29dof").path +
                                " --legs left_hip_pitch_link,right_hip_pitch_link"));
  std::map<std::string, json> parent;
  for (const json& f : g1["frames"]) parent[f["name"]] = f["parent"];
  EXPECT_EQ(parent.at("left_knee_link"), "left_hip_yaw_link");
  EXPECT_EQ(parent.at("left_shoulder_pitch_link"), "torso_link");
  EXPECT_TRUE(parent.at("pelvis").is_null());
}

TEST(Cli, ModelFkWithJacobianMatchesTheLibrary) {
  const json j = parse(wbm_cli("model fk --frames l_hand_ref --jacobian --json"));
  const wbm::Model model = wbm::make_paper_model();
  wbm::Data data(model);
  wbm::forward_kinematics(model, data, model.home());
  const int f = model.frame_index("l_hand_ref");
  const wbm::Transform X = wbm::frame_pose(model, data, f);
  Eigen::MatrixXd J(6, model.num_dofs());
  wbm::frame_jacobian(model, data, f, J);

  ASSERT_TRUE(j["frames"].contains("l_hand_ref"));
  EXPECT_EQ(j["frames"].size(), 1u);
  const json& hand = j["frames"]["l_hand_ref"];
  for (int r = 0; r < 3; ++r) {
    EXPECT_NEAR(hand["position"][r].get<double>(), X.p[r], 1e-12);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(hand["rotation"][r][c].get<double>(), X.R(r, c), 1e-12);
  }
  ASSERT_EQ(hand["jacobian"].size(), 6u);
  for (int r = 0; r < 6; ++r) {
    ASSERT_EQ(hand["jacobian"][r].size(), 21u);
    for (int c = 0; c < 21; ++c) EXPECT_NEAR(hand["jacobian"][r][c].get<double>(), J(r, c), 1e-12);
  }
  ASSERT_EQ(j["q"].size(), 21u);
  EXPECT_EQ(j["center_of_mass"].size(), 3u);
}

// --fixed-base: the virtual dofs upright (as scripts' --fixed-base and robot.fixed_base),
// also where --q gives them other values; the joints keep theirs.
TEST(Cli, ModelFkWithFixedBaseStandsUpright) {
  const wbm::Model model = wbm::make_paper_model();
  Eigen::VectorXd q = model.home();
  q.setConstant(0.05);
  std::ostringstream q_text;
  for (int i = 0; i < q.size(); ++i) q_text << (i ? "," : "") << q[i];
  const json j = parse(wbm_cli("model fk --fixed-base --q " + q_text.str() + " --frames l_hand_ref --json"));
  const Eigen::VectorXd upright = wbm::upright_base_configuration(model, q);
  ASSERT_EQ(j["q"].size(), static_cast<size_t>(model.num_dofs()));
  for (int i = 0; i < model.num_dofs(); ++i) EXPECT_EQ(j["q"][i].get<double>(), upright[i]) << model.dof(i).name;
  EXPECT_EQ(j["q"][model.virtual_dofs().ub_pitch].get<double>(), 0.0);
  EXPECT_EQ(j["q"][model.virtual_dofs().ub_z].get<double>(), model.dof(model.virtual_dofs().ub_z).upper);
  EXPECT_EQ(j["q"][model.virtual_dofs().ub_yaw + 1].get<double>(), 0.05);  // a joint keeps its value
  wbm::Data data(model);
  wbm::forward_kinematics(model, data, upright);
  const wbm::Vector3 p = wbm::frame_pose(model, data, model.frame_index("l_hand_ref")).p;
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(j["frames"]["l_hand_ref"]["position"][r].get<double>(), p[r], 1e-12);
}

TEST(Cli, ModelFkWithConfiguration) {
  std::string q;
  const wbm::Model model = wbm::make_paper_model();
  for (int i = 0; i < model.num_dofs(); ++i) {
    if (i > 0) q += ',';
    q += std::to_string(model.home()[i]);
  }
  const json j = parse(wbm_cli("model fk --q " + q + " --frames l_hand_ref,r_hand_ref,head_camera --json"));
  EXPECT_EQ(j["frames"].size(), 3u);
}

TEST(Cli, ExportThenImportWithRootAndHeight) {
  const std::string file = testing::TempDir() + "wbm_cli_paper_export_" + std::to_string(getpid()) + ".urdf";
  std::remove(file.c_str());
  const CliRun exported = wbm_cli("model export -o '" + file + "'");
  EXPECT_EQ(exported.status, 0) << exported.err;
  const CliRun info = wbm_cli("model info '" + file + "' --root upper_body --root-height 0.6");
  EXPECT_EQ(info.status, 0) << info.err;
  EXPECT_NE(info.out.find("21 dofs"), std::string::npos) << info.out;
  const json original = parse(wbm_cli("model info --json"));
  const json back = parse(wbm_cli("model info '" + file + "' --root upper_body --root-height 0.6 --json"));
  ASSERT_EQ(back["dofs"].size(), original["dofs"].size());
  for (size_t i = 0; i < original["dofs"].size(); ++i) {
    EXPECT_EQ(back["dofs"][i]["name"], original["dofs"][i]["name"]);
    EXPECT_EQ(back["dofs"][i]["lower"], original["dofs"][i]["lower"]);
    EXPECT_EQ(back["dofs"][i]["upper"], original["dofs"][i]["upper"]);
    EXPECT_EQ(back["dofs"][i]["max_speed"], original["dofs"][i]["max_speed"]);
  }
  // The same hand pose at home.
  const json fk_original = parse(wbm_cli("model fk --frames l_hand_ref --json"));
  const json fk_back =
      parse(wbm_cli("model fk '" + file + "' --root upper_body --root-height 0.6 --frames l_hand_ref --json"));
  for (int r = 0; r < 3; ++r)
    EXPECT_NEAR(fk_back["frames"]["l_hand_ref"]["position"][r].get<double>(),
                fk_original["frames"]["l_hand_ref"]["position"][r].get<double>(), 1e-9);
  std::remove(file.c_str());
}

// The exported file's comment names the import flags that give the model back: with them
// `model info` of the export lists the same dofs, ranges and mass as of the original (G1
// with its legs measured for the height, turned by --root-rpy). Without the height the
// import would take 1 m for the root height, and upper_body_z's range would differ.
TEST(Cli, ExportCommentNamesTheImportFlags) {
  const std::string g1 = "'" + wbm_test::shipped_model("g1_29dof").path + "'";
  const std::string source = "--legs left_hip_pitch_link,right_hip_pitch_link --root-rpy 0.3,-0.2,2.5";
  const std::string file = testing::TempDir() + "wbm_cli_g1_export_" + std::to_string(getpid()) + ".urdf";
  const CliRun exported = wbm_cli("model export " + g1 + " " + source + " -o '" + file + "'");
  ASSERT_EQ(exported.status, 0) << exported.err;
  const std::string xml = read_file(file);
  const size_t open = xml.find(" (--root "), close = xml.find("). -->", open);
  ASSERT_NE(open, std::string::npos) << xml.substr(0, 300);
  ASSERT_NE(close, std::string::npos) << xml.substr(0, 300);
  const std::string flags = xml.substr(open + 2, close - open - 2);
  EXPECT_NE(flags.find("--root-height "), std::string::npos) << flags;
  EXPECT_NE(flags.find("--root-rpy "), std::string::npos) << flags;
  const json original = parse(wbm_cli("model info " + g1 + " " + source + " --json"));
  const json back = parse(wbm_cli("model info '" + file + "' " + flags + " --json"));
  std::remove(file.c_str());
  ASSERT_EQ(back["dofs"].size(), original["dofs"].size()) << flags;
  for (size_t i = 0; i < original["dofs"].size(); ++i)
    for (const char* field : {"name", "lower", "upper", "home"})
      EXPECT_EQ(back["dofs"][i][field], original["dofs"][i][field]) << i << " " << field << " with " << flags;
  EXPECT_NEAR(back["total_mass"].get<double>(), original["total_mass"].get<double>(), 1e-9);
}

TEST(Cli, ExportWholeTreeWithVirtualDofs) {
  // Every dof becomes a joint of the same name below a "world" link (KDL gets this tree in
  // bench/; tests/test_kdl.cpp checks it against KDL); load_urdf refuses it, by name.
  const std::string file = testing::TempDir() + "wbm_cli_paper_whole_" + std::to_string(getpid()) + ".urdf";
  std::remove(file.c_str());
  const CliRun exported = wbm_cli("model export --virtual-dofs -o '" + file + "'");
  ASSERT_EQ(exported.status, 0) << exported.err;
  std::ifstream in(file);
  const std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(xml.find("<link name=\"world\">"), std::string::npos);
  const wbm::Model model = wbm::make_paper_model();
  for (const wbm::Dof& d : model.dofs())
    EXPECT_NE(xml.find("<joint name=\"" + d.name + "\" type=\""), std::string::npos) << d.name;
  EXPECT_NE(xml.find("<joint name=\"heel_yaw\" type=\"continuous\">"), std::string::npos);
  const CliRun info = wbm_cli("model info '" + file + "' --root world");
  EXPECT_NE(info.status, 0);
  EXPECT_NE(info.err.find(":8: joint 'heel_x': the name of one of the virtual dofs wbm adds"), std::string::npos) << info.err;
  std::remove(file.c_str());
}

TEST(Cli, ShippedUrdfWithLegs) {
  const wbm_test::ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const json j = parse(wbm_cli("model info '" + g1.path + "' --legs left_hip_pitch_link,right_hip_pitch_link --json"));
  EXPECT_EQ(j["dofs"].size(), static_cast<size_t>(g1.load().num_dofs()));
  const json fk = parse(wbm_cli("model fk '" + g1.path + "' --legs left_hip_pitch_link,right_hip_pitch_link --frames " +
                                g1.left_hand + "," + g1.right_hand + " --jacobian --json"));
  EXPECT_EQ(fk["frames"].size(), 2u);
}

/// `wbm ARGS` fails: non-zero exit, `message` on stderr, nothing on stdout.
void expect_cli_error(const std::string& args, const std::string& message) {
  const CliRun r = wbm_cli(args);
  EXPECT_NE(r.status, 0) << args;
  EXPECT_NE(r.err.find(message), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

// --add-frame (repeatable): frames fixed to a frame of the URDF, as the library adds them.
TEST(Cli, ModelFkWithAddedFrames) {
  const wbm_test::ShippedModel& h1 = wbm_test::shipped_model("h1");
  const std::string file = "model fk '" + h1.path + "' --legs left_hip_yaw_link,right_hip_yaw_link";
  const json j = parse(wbm_cli(file + " --add-frame tip:left_elbow_link:0.3,0,0 --add-frame "
                                      "cam:d435_rgb_module_link:0,0,0:0,0,1.5 --frames tip,cam,left_elbow_link --json"));
  wbm::UrdfImportOptions options = h1.options;
  options.added_frames = {wbm::AddedFrame{"tip", "left_elbow_link", wbm::Vector3(0.3, 0, 0), wbm::Vector3::Zero()}};
  const wbm::Model model = wbm::load_urdf(h1.path, options);
  wbm::Data data(model);
  wbm::forward_kinematics(model, data, model.home());
  const wbm::Vector3 p = wbm::frame_position(model, data, model.frame_index("tip"));
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(j["frames"]["tip"]["position"][r].get<double>(), p[r], 1e-12) << j;
  EXPECT_TRUE(j["frames"].contains("cam")) << j;
  expect_cli_error(file + " --add-frame tip:left_elbow_link:0.3,0", "--add-frame 'tip:left_elbow_link:0.3,0': expected "
                                                                     "NAME:PARENT:X,Y,Z or NAME:PARENT:X,Y,Z:ROLL,PITCH,YAW");
  expect_cli_error(file + " --add-frame tip:no_link:0,0,0",
                   "added frame 'tip' (added_frames, --add-frame): no frame named 'no_link'");
  expect_cli_error("model fk --add-frame tip:l_hand_ref:0,0,0",
                   "--add-frame: an option of the URDF import; the built-in paper model takes none (give a URDF file)");
}

// Every URDF import option without a URDF file is an error, not silently ignored (`model
// info --legs nope_link` printed the paper model and exited 0: a forgotten file name looked
// like a working command).
TEST(Cli, UrdfOptionsWithoutAUrdfFail) {
  expect_cli_error("model info --legs nope_link",
                   "--legs: an option of the URDF import; the built-in paper model takes none (give a URDF file)");
  expect_cli_error("model export --root torso --drop-legs --default-limits",
                   "--root, --drop-legs, --default-limits: options of the URDF import; the built-in paper model takes "
                   "none (give a URDF file)");
  expect_cli_error("model fk --root-rpy 0,0,1 --json", "--root-rpy: an option of the URDF import");
  // The subcommands' own options stay allowed on the built-in model.
  EXPECT_TRUE(parse(wbm_cli("model fk --fixed-base --frames l_hand_ref --json"))["frames"].contains("l_hand_ref"));
}

TEST(Cli, UnknownFrameFails) {
  expect_cli_error("model fk --frames no_such_frame --json", "no frame named 'no_such_frame'");
}

TEST(Cli, WrongConfigurationSizeFails) {
  expect_cli_error("model fk --q 1,2,3 --json", "--q has 3 values; the model has 21 dofs");
  expect_cli_error("model fk --q 0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0 --json", "--q has 22 values; the model has 21 dofs");
}

// Several scenario files: a name the model lacks in the second file stops the run before
// the first one is simulated or anything is written (exit 1, the file and line named).
TEST(Cli, RunChecksEveryScenarioBeforeRunningAny) {
  const std::string dir = testing::TempDir() + "wbm_cli_run_check_" + std::to_string(getpid());
  const std::string good = dir + "_good.yaml", bad = dir + "_bad.yaml", out = dir + "_out";
  std::ofstream(good) << "name: good\nduration: 0.1\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n";
  std::ofstream(bad) << "name: bad\nduration: 0.1\ntasks:\n  - {name: a, type: position, frame: no_such_frame}\n";
  const CliRun r = wbm_cli("run '" + good + "' '" + bad + "' --out '" + out + "'");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.err.find("_bad.yaml:4: tasks[0]: model 'paper_asimo_like' has no frame named 'no_such_frame'"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.out.find("scenario good"), std::string::npos) << r.out;
  EXPECT_NE(access(out.c_str(), F_OK), 0) << out << " was created";
  std::remove(good.c_str());
  std::remove(bad.c_str());
}

// Two scenarios of one name would write into the same directory, the second over the first:
// refused before either runs.
TEST(Cli, RunRefusesTwoScenariosOfOneName) {
  const std::string dir = testing::TempDir() + "wbm_cli_same_name_" + std::to_string(getpid());
  const std::string first = dir + "_1.yaml", second = dir + "_2.yaml", out = dir + "_out";
  for (const std::string& file : {first, second})
    std::ofstream(file) << "# a comment\nname: same\nduration: 0.1\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n";
  const CliRun r = wbm_cli("run '" + first + "' '" + second + "' --out '" + out + "'");
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("_2.yaml:2: name: 'same' is also the name of the scenario in " + first + "; both would write to " +
                       out + "/same"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.out.find("scenario same"), std::string::npos) << r.out;
  EXPECT_NE(access(out.c_str(), F_OK), 0) << out << " was created";
  std::remove(first.c_str());
  std::remove(second.c_str());
}

TEST(Cli, NonFiniteConfigurationFails) {
  expect_cli_error("model fk --q nan,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0 --json", "--q: 'nan' is not a finite number");
  expect_cli_error("model fk --q 1e400,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0 --json",
                   "--q: '1e400' is beyond the range of a double");
  expect_cli_error("model fk --q 1x,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0 --json", "--q: '1x' is not a number");
  expect_cli_error("model fk --q 1,,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0 --json", "--q: '' is not a number");
  expect_cli_error("model info '" + wbm_test::shipped_model("g1_29dof").path + "' --root-height nan",
                   "--root-height: expected a finite height >= 0 m, got nan");
  expect_cli_error("model info '" + wbm_test::shipped_model("g1_29dof").path + "' --upper-body-pivot nan",
                   "--upper-body-pivot: expected a finite height >= 0 m, got nan");
}

// --upper-body-x-range / -y-range set the upper body's shift ranges (for balance over long
// feet); the export names them and its file imports with them; a bad range names the option.
TEST(Cli, UpperBodyRangesAreUrdfOptions) {
  const wbm_test::ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const std::string file = "'" + g1.path + "' --legs left_hip_pitch_link,right_hip_pitch_link";
  const std::string ranges = " --upper-body-x-range -0.05,0.3 --upper-body-y-range -0.1,0.12";
  const json info = parse(wbm_cli("model info " + file + ranges + " --json"));
  std::map<std::string, json> dofs;
  for (const json& d : info["dofs"]) dofs[d["name"].get<std::string>()] = d;
  EXPECT_EQ(dofs["upper_body_x"]["lower"].get<double>(), -0.05);
  EXPECT_EQ(dofs["upper_body_x"]["upper"].get<double>(), 0.3);
  EXPECT_EQ(dofs["upper_body_y"]["lower"].get<double>(), -0.1);
  EXPECT_EQ(dofs["upper_body_y"]["upper"].get<double>(), 0.12);
  const std::string exported = testing::TempDir() + "wbm_cli_ranges_export.urdf";
  const CliRun out = wbm_cli("model export " + file + ranges + " -o '" + exported + "'");
  ASSERT_EQ(out.status, 0) << out.err;
  std::ifstream in(exported);
  const std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t flags = xml.find("(--root pelvis");
  ASSERT_NE(flags, std::string::npos) << xml.substr(0, 400);
  const std::string import_flags = xml.substr(flags + 1, xml.find(')', flags) - flags - 1);
  EXPECT_NE(import_flags.find(ranges.substr(1)), std::string::npos) << import_flags;
  const json back = parse(wbm_cli("model info '" + exported + "' " + import_flags + " --json"));
  EXPECT_EQ(back["dofs"], info["dofs"]);
  std::remove(exported.c_str());
  expect_cli_error("model info " + file + " --upper-body-x-range 0.3,0",
                   "(upper_body_x_range, --upper-body-x-range) must be finite with lower < upper [m], got 0.3, 0");
  expect_cli_error("model info " + file + " --upper-body-y-range 0.3", "--upper-body-y-range");
}

// --root-rpy turns the root link: G1 turned by pi about z has its left hand on the world's
// right (y < 0) at home; out of range is an error naming the option.
TEST(Cli, RootRpyTurnsTheRobot) {
  const wbm_test::ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  const std::string args = "model fk '" + g1.path + "' --legs left_hip_pitch_link,right_hip_pitch_link --frames " +
                           g1.left_hand + " --json";
  const json plain = parse(wbm_cli(args));
  const json turned = parse(wbm_cli(args + " --root-rpy 0,0,3.141592653589793"));
  EXPECT_GT(plain["frames"][g1.left_hand]["position"][1].get<double>(), 0.05);
  EXPECT_LT(turned["frames"][g1.left_hand]["position"][1].get<double>(), -0.05);
  expect_cli_error(args + " --root-rpy 0,0,9", "(root_rpy, --root-rpy) must be finite and within [-2 pi, 2 pi] rad");
}

// A subnormal value is a number (std::stod would have refused it as out of range), and
// spaces after the commas are allowed.
TEST(Cli, SubnormalAndSpacedConfigurationValuesAreAccepted) {
  const CliRun r = wbm_cli("model fk --q 1e-320,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0 --frames l_hand_ref --json");
  EXPECT_EQ(r.status, 0) << r.err;
  const json spaced = parse(wbm_cli("model fk --q '0, 0, 0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0, 0.5 ' --frames head_camera --json"));
  const json plain = parse(wbm_cli("model fk --q 0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0.5 --frames head_camera --json"));
  EXPECT_EQ(spaced, plain);
}

// --out naming a file: an error before anything runs, not an abort from std::filesystem.
TEST(Cli, RunWithAnOutputThatIsAFileFails) {
  const std::string base = testing::TempDir() + "wbm_cli_out_file_" + std::to_string(getpid());
  const std::string scenario = base + ".yaml", file = base + ".txt";
  std::ofstream(scenario) << "name: x\nduration: 0.1\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n";
  std::ofstream(file) << "not a directory\n";
  for (const std::string& out : {file, file + "/sub"}) {
    const CliRun r = wbm_cli("run '" + scenario + "' --out '" + out + "'");
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.err.find("wbm: error: " + out + ": "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("is not a directory (--out)"), std::string::npos) << r.err;
    EXPECT_EQ(r.out.find("scenario x"), std::string::npos) << r.out;
  }
  std::remove(scenario.c_str());
  std::remove(file.c_str());
}

// An --out with a component longer than a file name: refused before the run (it failed only
// when writing, after the simulation, and left the directories above it behind).
TEST(Cli, RunWithAnOutputNameTooLongFails) {
  const std::string base = testing::TempDir() + "wbm_cli_long_out_" + std::to_string(getpid());
  const std::string scenario = base + ".yaml", out = base + "_dir/" + std::string(300, 'o');
  std::ofstream(scenario) << "name: x\nduration: 0.1\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n";
  const CliRun r = wbm_cli("run '" + scenario + "' --out '" + out + "' --no-report");
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("wbm: error: " + out + ": cannot be created: 'oooo"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("' is longer than a file name may be (255 bytes; --out)"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("scenario x"), std::string::npos) << r.out;
  EXPECT_NE(access((base + "_dir").c_str(), F_OK), 0) << base << "_dir was created";
  std::remove(scenario.c_str());
}

// Where a root link at the feet stands and where its upper body pivots: level with the soles
// (0 m above the ground, 0.55 m to the hips), or given 1 cm below them.
TEST(Cli, ModelInfoSaysWhereARootAtTheFeetStands) {
  const std::string info = "model info '" + wbm_test::source_path("tests/data/root_at_feet.urdf") + "' --legs thigh_l,thigh_r";
  const CliRun level = wbm_cli(info);
  EXPECT_EQ(level.status, 0) << level.err;
  EXPECT_NE(level.out.find("root link 'base', its origin 0.000 m above the ground standing straight; the upper body "
                           "pivots 0.550 m above it"),
            std::string::npos)
      << level.out;
  const CliRun below = wbm_cli(info + " --root-height -0.01 --upper-body-pivot 0.55");
  EXPECT_EQ(below.status, 0) << below.err;
  EXPECT_NE(below.out.find("its origin 0.010 m below the ground standing straight; the upper body pivots 0.550 m above "
                           "it (upper_body_pivot: chosen at the hips where the root link's origin lies at the feet, or "
                           "given; upper_body_z's upper limit 0.540 m"),
            std::string::npos)
      << below.out;
}

// An --out inside a directory the user cannot write into: refused before the run, with the
// directory named. Root writes anywhere, so as root the tool runs without the capabilities
// that let it (setpriv, util-linux: no CAP_DAC_OVERRIDE), as any other user would.
TEST(Cli, RunIntoADirectoryItCannotWriteFails) {
  const std::string base = testing::TempDir() + "wbm_cli_read_only_" + std::to_string(getpid());
  const std::string scenario = base + ".yaml", locked = base + "_dir";
  std::ofstream(scenario) << "name: x\nduration: 0.1\ntasks: [{name: a, type: position, frame: l_hand_ref}]\n";
  ASSERT_EQ(mkdir(locked.c_str(), 0555), 0) << locked;
  ASSERT_EQ(chmod(locked.c_str(), 0555), 0) << locked;  // whatever the umask
  std::string prefix;
  if (geteuid() == 0) {
    prefix = "setpriv --inh-caps=-dac_override,-dac_read_search --bounding-set=-dac_override,-dac_read_search ";
    // A container without CAP_SETPCAP cannot drop them: then nothing here can be refused.
    if (std::system((prefix + "true > /dev/null 2>&1").c_str()) != 0) {
      std::filesystem::remove_all(locked);
      std::remove(scenario.c_str());
      GTEST_SKIP() << "running as root, and setpriv (util-linux) cannot drop CAP_DAC_OVERRIDE here";
    }
  }
  const CliRun r = wbm_test::run_command(prefix + "'" + WBM_CLI_PATH + "' run '" + scenario + "' --out '" + locked +
                                             "/out' --no-report",
                                         "wbm_cli_test");
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("wbm: error: " + locked + "/out: cannot write into " + locked + " (--out)"), std::string::npos)
      << r.err;
  EXPECT_EQ(r.out.find("scenario x"), std::string::npos) << r.out;
  EXPECT_NE(access((locked + "/out").c_str(), F_OK), 0) << "created";
  std::filesystem::remove_all(locked);
  std::remove(scenario.c_str());
}

// The run's last lines say how balance and walking ended, not only the task errors: a
// centre of mass left outside the feet, or a walk still going, is what a user looks for;
// and how close the joints came to their limits.
// wbm run says the model's notes too: G1 turned by pitch pi/2 (its root height given) runs,
// lying on its back, and the run says why; the same robot as it is gets no note.
TEST(Cli, RunSaysTheModelsNotes) {
  const std::string base = testing::TempDir() + "wbm_cli_notes_" + std::to_string(getpid());
  const std::string g1 = wbm_test::shipped_model("g1_29dof").path;
  const std::string robot = "robot: {urdf: '" + g1 + "', legs: [left_hip_pitch_link, right_hip_pitch_link]";
  const std::string rest = "duration: 0.05\nfrozen: [heel_x, heel_y, heel_yaw]\n"
                           "tasks: [{name: a, type: position, frame: left_rubber_hand}]\n";
  std::ofstream(base + "_turned.yaml") << "name: turned\n" << robot << ", root_rpy: [0, 1.5707963, 0], root_height: 0.8}\n" << rest;
  std::ofstream(base + "_plain.yaml") << "name: plain\n" << robot << "}\n" << rest;
  const CliRun r = wbm_cli("run '" + base + "_turned.yaml' '" + base + "_plain.yaml' --out '" + base + "_dir' --no-report");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err.find("scenario "), std::string::npos) << r.err;  // the results on stdout
  const size_t turned = r.out.find("scenario turned"), plain = r.out.find("scenario plain");
  ASSERT_TRUE(turned != std::string::npos && plain != std::string::npos) << r.out;
  EXPECT_NE(r.out.substr(turned, plain - turned).find("  note: the legs point backward rather than down"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.substr(plain).find("note:"), std::string::npos) << r.out;
  std::filesystem::remove_all(base + "_dir");
  std::remove((base + "_turned.yaml").c_str());
  std::remove((base + "_plain.yaml").c_str());
}

TEST(Cli, RunSaysHowBalanceAndWalkingEnded) {
  const std::string base = testing::TempDir() + "wbm_cli_balance_" + std::to_string(getpid());
  const std::string inside = base + "_in.yaml", outside = base + "_out.yaml", walk = base + "_walk.yaml";
  const std::string tasks = "tasks: [{name: a, type: position, frame: l_hand_ref}]\n";
  std::ofstream(inside) << "name: in\nduration: 0.2\nfrozen: [heel_x, heel_y, heel_yaw]\nbalance: {enabled: true}\n" << tasks;
  // Feet 4 cm long: the centre of mass, 6 cm ahead of the heel, stays beyond their front edge.
  std::ofstream(outside) << "name: out\nduration: 0.2\nfrozen: [heel_x, heel_y, heel_yaw]\nbalance: {enabled: true}\n"
                         << "feet: {length: 0.04, width: 0.1}\n" << tasks;
  std::ofstream(walk) << "name: walk\nduration: 0.2\nfrozen: [heel_x, heel_y, heel_yaw]\nwalking: {enabled: true}\n" << tasks;
  // The same short feet with balance configured but off: no shift was tried.
  const std::string off = base + "_off.yaml";
  std::ofstream(off) << "name: off\nduration: 0.2\nfrozen: [heel_x, heel_y, heel_yaw]\nbalance: {enabled: false}\n"
                     << "feet: {length: 0.04, width: 0.1}\n" << tasks;
  // Feet 0.6 m long: the upper body shifts forward to its limit and stays there.
  const std::string long_feet = base + "_long.yaml";
  std::ofstream(long_feet) << "name: long\nduration: 1\nfrozen: [heel_x, heel_y, heel_yaw]\nbalance: {enabled: true}\n"
                           << "feet: {length: 0.6, width: 0.1}\n" << tasks;
  const CliRun r = wbm_cli("run '" + inside + "' '" + outside + "' '" + walk + "' '" + off + "' '" + long_feet +
                           "' --out '" + base + "_dir' --no-report");
  EXPECT_EQ(r.status, 0) << r.err;
  const size_t in = r.out.find("scenario in"), out = r.out.find("scenario out"), w = r.out.find("scenario walk");
  ASSERT_TRUE(in != std::string::npos && out != std::string::npos && w != std::string::npos) << r.out;
  const size_t o = r.out.find("scenario off");
  ASSERT_NE(o, std::string::npos) << r.out;
  EXPECT_NE(r.out.substr(o).find(" cm OUTSIDE the feet at the end (balance off)\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.substr(in, out - in).find(" cm inside the feet at the end"), std::string::npos) << r.out;
  EXPECT_NE(r.out.substr(out, w - out).find(" cm OUTSIDE the feet at the end (the upper-body shift could not"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.substr(w, o - w).find("  walking: 0 footsteps in 0 walks (steps up to 0.250 m ahead, 0.140-0.300 m wide, every 0.600 s)\n"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.substr(w, o - w).find("balance:"), std::string::npos) << r.out;
  const size_t l = r.out.find("scenario long");
  ASSERT_NE(l, std::string::npos) << r.out;
  EXPECT_NE(r.out.substr(l).find("  balance: upper_body_x held at its limit 14.0 cm in "), std::string::npos) << r.out;
  EXPECT_NE(r.out.substr(l).find("the built-in paper model's range is fixed"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.substr(0, l).find("held at its limit"), std::string::npos) << r.out;
  // And how close the joints came to their speed limits and to the bound on their rates' change.
  EXPECT_NE(r.out.substr(in, out - in).find("  joints: fastest at 0."), std::string::npos) << r.out;
  EXPECT_NE(r.out.substr(in, out - in).find(" of its bound k v_max (upper_body_"), std::string::npos) << r.out;
  for (const std::string& f : {inside, outside, walk, off, long_feet}) std::remove(f.c_str());
  std::filesystem::remove_all(base + "_dir");
}

// A bad command line exits 2 with the message as for a bad file (CLI11's own exit codes
// were 100-odd, its message without the prefix); --help still exits 0.
TEST(Cli, BadCommandLinesExitTwoWithTheMessage) {
  const std::pair<const char*, const char*> cases[] = {
      {"", "wbm: error: A subcommand is required"},
      {"model", "wbm: error: A subcommand is required"},
      {"model info --root-rpy 1", "wbm: error: --root-rpy: At least 3 required but received 1"},
      {"model fk --root-height high", "wbm: error: Could not convert: --root-height = high"},
      {"model info --no-such-flag", "wbm: error: The following argument was not expected: --no-such-flag"},
  };
  for (const auto& [arguments, message] : cases) {
    const CliRun r = wbm_cli(arguments);
    EXPECT_EQ(r.status, 2) << arguments << "\n" << r.err;
    EXPECT_NE(r.err.find(message), std::string::npos) << arguments << "\n" << r.err;
  }
  const CliRun help = wbm_cli("model fk --help");
  EXPECT_EQ(help.status, 0) << help.err;
  EXPECT_NE(help.out.find("--jacobian"), std::string::npos) << help.out;
}

}  // namespace
