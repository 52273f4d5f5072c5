// Catalogue of malformed URDF files (tests/data/malformed/): each must raise a ParseError
// whose message names the file, the line and the problem, and the CLI must exit non-zero
// with that message on stderr.
#include <algorithm>
#include <array>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <sstream>
#include <typeinfo>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cli_runner.hpp"

#include "shipped_models.hpp"
#include "test_util.hpp"
#include "wbm/errors.hpp"
#include "wbm/kinematics.hpp"
#include "wbm/urdf_import.hpp"

namespace {

struct Case {
  std::string file;  ///< in tests/data/malformed/
  std::string expected;  ///< exact substring of the message (file name and line included)
  std::string root;
  std::vector<std::string> legs;
  bool ignore_xacro_elements = false;  ///< the option (--ignore-xacro-elements)
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.file; }

const std::vector<Case>& catalogue() {
  static const std::vector<Case> cases = {
      {"malformed_xml.urdf", "malformed_xml.urdf:11: malformed XML: Error reading end tag", "", {}},
      {"wrong_root_element.urdf", "wrong_root_element.urdf:2: expected a <robot> root element, found <model>", "", {}},
      {"no_links.urdf", "no_links.urdf:2: <robot> has no <link>", "", {}},
      {"robot_without_name.urdf", "robot_without_name.urdf:2: robot: <robot> lacks the attribute 'name'", "", {}},
      {"unknown_root_link.urdf", "unknown_root_link.urdf: root link 'nope' is not defined in the URDF", "nope", {}},
      {"unknown_leg_link.urdf", "unknown_leg_link.urdf: leg link 'nope' is not defined in the URDF", "", {"leg", "nope"}},
      {"leg_is_root.urdf", "leg_is_root.urdf: leg link 'base' is the root link", "", {"base"}},
      {"legs_sideways.urdf",
       "legs_sideways.urdf:10: leg link 'shin_l', the legs' lowest at zero joint values, is 0.02 m below the root link's "
       "origin, less than a tenth of the legs' length (0.4005 m from a leg's first link to its farthest): the legs do not "
       "point down. If the root link's z axis is not up, give its orientation (root_rpy, --root-rpy)",
       "", {"thigh_l", "thigh_r"}},
      {"legs_above_root.urdf",
       "legs_above_root.urdf:26: leg link 'imu', the legs' lowest at zero joint values, is not below the root link's "
       "origin, less than a tenth of the legs' length (0 m from a leg's first link to its farthest): the legs do not "
       "point down.",
       "", {"cam", "imu"}},
      // The root link's origin at the feet, legs that do not point down from the hips (so no
      // pivot at the hips is taken): the links welded to it higher up are named as roots.
      {"root_at_feet_legs_folded.urdf",
       "root_at_feet_legs_folded.urdf:13: leg link 'foot_l', the legs' lowest at zero joint values, is not below the "
       "root link's origin, less than a tenth of the legs' length (0.538516 m from a leg's first link to its farthest): "
       "the legs do not point down. If the root link's z axis is not up, give its orientation (root_rpy, --root-rpy); if "
       "its origin lies at the feet (as in some CAD exports), choose a link at the hips or above as the root (root, "
       "--root) (links welded to it higher up: 'imu' 0.68 m above the legs' lowest) or give the upper body's pivot "
       "above it (upper_body_pivot, --upper-body-pivot); if these are not the legs, name the first link of each (legs, "
       "--legs); or give the root height (root_height, --root-height)",
       "", {"thigh_l", "thigh_r"}},
      {"nested_legs.urdf",
       "nested_legs.urdf:9: leg link 'shin_l' lies inside the leg of 'thigh_l' (legs, --legs): name the first link of "
       "each leg",
       "", {"thigh_l", "shin_l"}},
      {"missing_parent_link.urdf", "missing_parent_link.urdf:7: joint 'j1': parent link 'nowhere' is not defined", "", {}},
      {"joint_without_parent.urdf", "joint_without_parent.urdf:7: joint 'j1' has no <parent link=...>", "", {}},
      {"undefined_child_link.urdf", "undefined_child_link.urdf:13: joint 'j2': child link 'l2' is not defined", "", {}},
      {"loop_two_parents.urdf",
       "loop_two_parents.urdf:20: kinematic loop: link 'l2' is the child of joint 'j3' and of joint 'j2' (line 14)", "", {}},
      {"loop_no_root.urdf", "loop_no_root.urdf:7: kinematic loop: every link has a parent joint, there is no root link", "",
       {}},
      {"loop_detached.urdf", "loop_detached.urdf:14: kinematic loop through link 'l1' and joint 'j2'", "", {}},
      {"self_loop.urdf", "self_loop.urdf:13: joint 'j2' connects link 'l1' to itself (kinematic loop)", "", {}},
      {"disconnected_two_roots.urdf",
       "disconnected_two_roots.urdf:7: the links do not form one tree; root links: 'base' (line 3) 'island' (line 7)", "",
       {}},
      {"bad_axis_zero.urdf", "bad_axis_zero.urdf:12: joint 'j1': joint axis is zero", "", {}},
      {"axis_not_unit.urdf", "axis_not_unit.urdf:10: joint 'j1': joint axis has norm 2 (expected a unit vector, within 1 %)", "", {}},
      {"limit_without_effort.urdf",
       "limit_without_effort.urdf:11: joint 'j1': <limit> lacks effort=\"...\" (the URDF format requires it", "", {}},
      {"safety_without_k_velocity.urdf",
       "safety_without_k_velocity.urdf:12: joint 'j1': <safety_controller> lacks k_velocity=\"...\" (the URDF format "
       "requires it",
       "", {}},
      {"dynamics_without_values.urdf",
       "dynamics_without_values.urdf:12: joint 'j1': <dynamics> has neither damping=\"...\" nor friction=\"...\"", "",
       {}},
      {"floating_to_link_with_joints.urdf",
       "floating_to_link_with_joints.urdf:19: joint 'free' (floating) leads to link 'hand', which is not a massless "
       "world link without other joints", "", {}},
      {"floating_inside.urdf",
       "floating_inside.urdf:16: joint 'free' (floating) leads to link 'hand', which is not a massless world link", "",
       {}},
      {"virtual_dof_name.urdf",
       "virtual_dof_name.urdf:7: joint 'upper_body_yaw': the name of one of the virtual dofs wbm adds (heel_x, heel_y",
       "", {}},
      {"virtual_body_name.urdf",
       "virtual_body_name.urdf:7: link 'heel': the name of one of the virtual bodies wbm adds (heel, heel_x", "", {}},
      {"virtual_body_name_root.urdf",
       "virtual_body_name_root.urdf:3: link 'heel': the name of one of the virtual bodies wbm adds", "", {}},
      {"xacro_macro.urdf",
       "xacro_macro.urdf:3: <xacro:property> is a xacro element: expand the file first (`xacro robot.urdf.xacro > "
       "robot.urdf`, ROS's xacro), or, if every link and joint is written out in it, import with "
       "ignore_xacro_elements (--ignore-xacro-elements)",
       "", {}},
      // With the option: what it still refuses.
      {"xacro_macro_makes_links.urdf",
       "xacro_macro_makes_links.urdf:4: <link> inside <xacro:macro> (line 3): xacro makes links or joints here, which "
       "would be missing without it",
       "", {}, true},
      {"xacro_inside_joint.urdf",
       "xacro_inside_joint.urdf:12: <xacro:insert_block> inside <joint> (line 9) is a xacro element: expand the file "
       "first (`xacro robot.urdf.xacro > robot.urdf`, ROS's xacro)",
       "", {}, true},
      {"xacro_expression_in_name.urdf",
       "xacro_expression_in_name.urdf:6: link: <link name> is '${prefix}hand', an unexpanded xacro expression: expand "
       "the file with xacro first",
       "", {}, true},
      {"xacro_expression_in_child.urdf",
       "xacro_expression_in_child.urdf:8: joint 'j1': <child link> is '$(arg prefix)hand', an unexpanded xacro "
       "expression",
       "", {}},
      {"xacro_expression.urdf",
       "xacro_expression.urdf:10: joint 'j1': <origin xyz> has '${h}' where a finite number was expected (an "
       "unexpanded xacro expression",
       "", {}},
      {"negative_mass.urdf", "negative_mass.urdf:8: link 'l1': negative mass -0.5", "", {}},
      {"inertial_without_mass.urdf", "inertial_without_mass.urdf:7: link 'l1': <inertial> lacks <mass>", "", {}},
      {"lower_just_above_upper.urdf",
       "lower_just_above_upper.urdf:12: joint 'j1': lower limit 0.3 is above upper limit 0.2", "", {}},
      {"lower_above_upper.urdf", "lower_above_upper.urdf:11: joint 'j1': lower limit 1.5 is above upper limit -1.5", "",
       {}},
      {"zero_range.urdf", "zero_range.urdf:11: joint 'j1': no position range (lower == upper)", "", {}},
      // Magnitudes whose poses, Jacobians or centre of mass overflowed (found by fuzzing).
      {"origin_too_far.urdf",
       "origin_too_far.urdf:12: joint 'j1': <origin xyz> has -1e+308, beyond the 1e+06 m wbm accepts", "", {}},
      {"mass_too_large.urdf", "mass_too_large.urdf:6: link 'l1': <mass value> has 1e+308, beyond the 1e+06 kg", "", {}},
      {"prismatic_limit_too_far.urdf",
       "prismatic_limit_too_far.urdf:11: joint 'j1': <limit lower> has -1e+16, beyond the 1e+06 m", "", {}},
      {"revolute_one_side_unlimited.urdf",
       "revolute_one_side_unlimited.urdf:11: joint 'j1': limits [0, 1e+16] rad: one side is unlimited", "", {}},
      {"missing_limit.urdf",
       "missing_limit.urdf:7: joint 'j1' (revolute) has no <limit>; add one or import with default limits "
       "(default_limits, --default-limits)",
       "", {}},
      {"missing_velocity.urdf",
       "missing_velocity.urdf:11: joint 'j1': no speed limit (<limit velocity> must be > 0); add one or import with "
       "default limits (default_limits, --default-limits)",
       "", {}},
      {"unknown_joint_type.urdf", "unknown_joint_type.urdf:7: joint 'j1': unknown type 'hinge'", "", {}},
      {"planar_joint.urdf", "planar_joint.urdf:7: joint 'j1': planar joints are not supported", "", {}},
      {"bad_number.urdf", "bad_number.urdf:10: joint 'j1': <axis xyz> has 'x' where a finite number was expected", "", {}},
      {"wrong_number_count.urdf", "wrong_number_count.urdf:12: joint 'j1': <origin xyz> needs 3 numbers, found 2", "", {}},
      {"too_many_numbers.urdf", "too_many_numbers.urdf:13: joint 'j1': <origin xyz> needs 3 numbers, found 4", "", {}},
      // Numbers urdfdom reads but wbm does not use: checked first, so that the line is named.
      {"hex_number.urdf", "hex_number.urdf:11: joint 'j1': <limit velocity> has '0x10' where a finite number was expected",
       "", {}},
      {"bad_dynamics_number.urdf",
       "bad_dynamics_number.urdf:12: joint 'j1': <dynamics damping> has '0,5' where a finite number was expected", "", {}},
      {"bad_inertia.urdf", "bad_inertia.urdf:9: link 'l1': <inertia ixx> has 'nan' where a finite number was expected", "",
       {}},
      {"bad_geometry.urdf", "bad_geometry.urdf:7: link 'l1': <box size> needs 3 numbers, found 2", "", {}},
      {"tab_in_vector.urdf",
       "tab_in_vector.urdf:11: joint 'j1': <origin xyz> is '0\\t0 0.1': urdfdom separates the numbers at spaces only",
       "", {}},
      {"mimic_unknown_joint.urdf", "mimic_unknown_joint.urdf:14: joint 'j2' mimics joint 'j_missing', which is not defined",
       "", {}},
      {"mimic_of_locked_joint.urdf",
       "mimic_of_locked_joint.urdf:15: joint 'j_arm' mimics 'j_leg', which is not a free joint of the imported body", "",
       {"leg"}},
      {"duplicate_link.urdf", "duplicate_link.urdf:7: duplicate link 'l1' (first defined on line 6)", "", {}},
      {"duplicate_joint.urdf", "duplicate_joint.urdf:14: duplicate joint 'j1' (first defined on line 8)", "", {}},
  };
  return cases;
}

std::string malformed_path(const std::string& file) { return wbm_test::source_path("tests/data/malformed/" + file); }

wbm::UrdfImportOptions options_of(const Case& c) {
  wbm::UrdfImportOptions options;
  options.root = c.root;
  options.legs = c.legs;
  options.ignore_xacro_elements = c.ignore_xacro_elements;
  return options;
}

class MalformedUrdf : public testing::TestWithParam<Case> {};

// A misspelt root or leg link gets the closest link names of the file.
TEST(UrdfImportErrors, MisspeltLinkNamesSuggestTheClosest) {
  struct Misspelt {
    std::string file, root;
    std::vector<std::string> legs;
    std::string expected;
  };
  for (const Misspelt& c : {Misspelt{"unknown_root_link.urdf", "Base_", {}, "root link 'Base_' is not defined in the "
                                                                              "URDF (did you mean 'base'?)"},
                            Misspelt{"unknown_leg_link.urdf", "", {"leg", "legs"}, "leg link 'legs' is not defined in "
                                                                                  "the URDF (did you mean 'leg'?)"}}) {
    wbm::UrdfImportOptions options;
    options.root = c.root;
    options.legs = c.legs;
    try {
      wbm::load_urdf(malformed_path(c.file), options);
      ADD_FAILURE() << c.file << " was accepted";
    } catch (const wbm::ParseError& e) {
      EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos) << e.what();
    }
  }
}

// A joint of the URDF that is not a dof is named as what it is: a locked leg's (or any fixed)
// joint, or a mimic joint with its master (scenario and command-line errors pass it on).
TEST(UrdfImportErrors, AJointThatIsNoDofSaysWhatItIs) {
  wbm::UrdfImportOptions options;
  options.legs = {"LPelvis", "RPelvis"};
  const wbm::Model nao = wbm::load_urdf(wbm_test::source_path("models/third_party/nao/nao.urdf"), options);
  const auto message = [&](const std::string& name) {
    try {
      nao.dof_index(name);
    } catch (const wbm::ModelError& e) {
      return std::string(e.what());
    }
    return std::string("(found)");
  };
  EXPECT_NE(message("LKneePitch").find("has no dof named 'LKneePitch' ('LKneePitch' is a fixed joint of the model: a "
                                       "welded link's, or a locked leg's (legs, --legs)); dofs are:"),
            std::string::npos)
      << message("LKneePitch");
  EXPECT_NE(message("RFinger11").find("has no dof named 'RFinger11' ('RFinger11' is a mimic joint: it follows dof "
                                      "'RHand'); dofs are:"),
            std::string::npos)
      << message("RFinger11");
  EXPECT_NE(message("RHan").find("has no dof named 'RHan' (did you mean 'RHand'?)"), std::string::npos) << message("RHan");
  EXPECT_EQ(message("RHand"), "(found)");
}

TEST_P(MalformedUrdf, ThrowsParseErrorNamingFileAndLine) {
  const Case& c = GetParam();
  try {
    wbm::load_urdf(malformed_path(c.file), options_of(c));
    FAIL() << c.file << " was accepted";
  } catch (const wbm::ParseError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(c.expected), std::string::npos)
        << "message:  " << message << "\nexpected: ..." << c.expected << "...";
    // The message starts with the path as given.
    EXPECT_EQ(message.rfind(malformed_path(c.file), 0), 0u) << message;
  } catch (const std::exception& e) {
    FAIL() << c.file << ": expected wbm::ParseError, got " << typeid(e).name() << ": " << e.what();
  }
}

TEST_P(MalformedUrdf, ParseUrdfNamesTheGivenSource) {
  const Case& c = GetParam();
  const std::string source = "memory/" + c.file;
  try {
    wbm::parse_urdf(wbm_test::read_file(malformed_path(c.file)), options_of(c), source);
    FAIL() << c.file << " was accepted";
  } catch (const wbm::ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("memory/" + c.expected), std::string::npos) << e.what();
  }
}

#ifdef WBM_CLI_PATH
using wbm_test::CliRun;
CliRun run(const std::string& command, const std::string& tag) { return wbm_test::run_command(command, tag); }
#endif

TEST_P(MalformedUrdf, CliExitsNonZeroWithTheMessageOnStderr) {
#ifndef WBM_CLI_PATH
  GTEST_SKIP() << "the wbm command-line tool is not built (WBM_BUILD_APPS=OFF)";
#else
  const Case& c = GetParam();
  std::string command = std::string("'") + WBM_CLI_PATH + "' model info '" + malformed_path(c.file) + "'";
  if (!c.root.empty()) command += " --root " + c.root;
  if (!c.legs.empty()) {
    command += " --legs ";
    for (size_t i = 0; i < c.legs.size(); ++i) {
      if (i > 0) command += ',';
      command += c.legs[i];
    }
  }
  if (c.ignore_xacro_elements) command += " --ignore-xacro-elements";
  const CliRun r = run(command, c.file);
  EXPECT_NE(r.status, 0) << command;
  EXPECT_NE(r.err.find("wbm: error: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(c.expected), std::string::npos) << "stderr: " << r.err << "\nexpected: ..." << c.expected;
  EXPECT_TRUE(r.out.empty()) << "stdout: " << r.out;
#endif
}

std::string case_name(const testing::TestParamInfo<Case>& param) {
  std::string name = param.param.file.substr(0, param.param.file.find('.'));
  return name;
}

INSTANTIATE_TEST_SUITE_P(Catalogue, MalformedUrdf, testing::ValuesIn(catalogue()), case_name);

TEST(MalformedUrdfCatalogue, CoversEveryFileAndAtLeastFourteenErrors) {
  std::set<std::string> listed;
  for (const Case& c : catalogue()) EXPECT_TRUE(listed.insert(c.file).second) << "listed twice: " << c.file;
  std::set<std::string> on_disk;
  for (const auto& entry : std::filesystem::directory_iterator(wbm_test::source_path("tests/data/malformed")))
    if (entry.path().extension() == ".urdf") on_disk.insert(entry.path().filename().string());
  EXPECT_EQ(listed, on_disk) << "every file in tests/data/malformed/ needs a catalogue entry";
  EXPECT_GE(listed.size(), 14u);
}

TEST(MalformedUrdfCatalogue, OptionFilesAreValidWithoutTheBadOption) {
  // The files used for option errors are themselves fine: the option is what fails.
  for (const char* file : {"unknown_root_link.urdf", "unknown_leg_link.urdf", "leg_is_root.urdf"}) {
    wbm::UrdfImportOptions options;
    options.legs = {"leg"};
    EXPECT_NO_THROW(wbm::load_urdf(malformed_path(file), options)) << file;
  }
}

TEST(UrdfErrors, MissingFile) {
  try {
    wbm::load_urdf("/nonexistent/robot.urdf");
    FAIL();
  } catch (const wbm::ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/robot.urdf: cannot open the file"), std::string::npos) << e.what();
  }
}

// A single number followed by a space is no number for urdfdom: a mass became 0 kg with its
// message set aside (PNDbotics Adam Lite's <mass value="0.73234339 "/>), a limit rejected the
// file without a line. Both are errors at their line now; vectors may have spaces around.
TEST(UrdfErrors, ANumberFollowedByASpaceIsNamed) {
  const std::string xml = wbm_test::read_file(wbm_test::source_path("models/dual_arm/dual_arm.urdf"));
  const auto message = [&](const std::string& from, const std::string& to) {
    std::string edited = xml;
    const std::size_t at = edited.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    edited.replace(at, from.size(), to);
    try {
      wbm::parse_urdf(edited, {}, "dual_arm_edited.urdf");
    } catch (const wbm::ParseError& e) {
      return std::string(e.what());
    }
    return std::string("(loaded)");
  };
  EXPECT_EQ(message(R"(<mass value="20"/>)", R"(<mass value="20 "/>)"),
            "dual_arm_edited.urdf:11: link 'base': <mass value> is '20 ': urdfdom reads no number followed by a "
            "space there (it would take it as 0 or reject the file); remove the space");
  EXPECT_EQ(message(R"(velocity="0.2"/>)", R"(velocity="0.2 "/>)").rfind(
                "dual_arm_edited.urdf:40: joint 'torso_lift': <limit velocity> is '0.2 ': urdfdom reads no number", 0),
            0u);
  EXPECT_EQ(message(R"(<mass value="20"/>)", R"(<mass value=" 20"/>)"), "(loaded)");  // urdfdom skips a leading one
  EXPECT_EQ(message(R"(<origin xyz="0 0 0.05"/>)", R"(<origin xyz=" 0 0 0.05 "/>)"), "(loaded)");
  // urdfdom splits vectors at spaces only: a tab or line break may lead a component (its
  // number reader skips it) but not follow one. Before, wbm split at any white space and
  // passed the file on to urdfdom, whose message had no line and repeated for every link.
  EXPECT_EQ(message(R"(<origin xyz="0 0 0.05"/>)", "<origin xyz=\"0 \t0 \n0.05\"/>"), "(loaded)");
  EXPECT_EQ(message(R"(<origin xyz="0 0 0.05"/>)", "<origin xyz=\"0\t0 0.05\"/>"),
            "dual_arm_edited.urdf:45: link 'left_link1': <origin xyz> is '0\\t0 0.05': urdfdom separates the numbers at "
            "spaces only (a tab or line break after a number makes it unreadable there); separate them by spaces");
  EXPECT_EQ(message(R"(<mass value="20"/>)", "<mass value=\"20\t\"/>").rfind(
                "dual_arm_edited.urdf:11: link 'base': <mass value> is '20\\t': urdfdom reads no number followed", 0),
            0u);
}

// A directory opened as a file read as an empty document: "malformed XML: Error document empty".
TEST(UrdfErrors, ADirectoryIsNoUrdfFile) {
  const std::string dir = wbm_test::source_path("models/dual_arm");
  try {
    wbm::load_urdf(dir);
    FAIL();
  } catch (const wbm::ParseError& e) {
    EXPECT_EQ(std::string(e.what()), dir + ": is a directory, not a URDF file");
  }
}

// 0 is the ground, where a robot without legs may stand (a fixed base on the world's
// origin); a robot with legs stands above it.
TEST(UrdfErrors, RootHeightGivenMustBeFiniteAndPositive) {
  const wbm_test::ShippedModel& nao = wbm_test::shipped_model("nao");
  ASSERT_FALSE(nao.options.legs.empty());
  for (const bool legs : {true, false})
    for (const double height : {-1.0, 0.0, std::numeric_limits<double>::infinity()}) {
      wbm::UrdfImportOptions options;
      if (legs) options.legs = nao.options.legs;
      options.root_height = height;
      try {
        const wbm::Model model = wbm::load_urdf(nao.path, options);
        EXPECT_TRUE(!legs && height == 0.0) << "root height " << height << " accepted";
        EXPECT_EQ(model.dof(model.virtual_dofs().ub_z).upper, 0.0);
      } catch (const wbm::ParseError& e) {
        EXPECT_FALSE(!legs && height == 0.0) << e.what();
        const std::string expected =
            std::string(": the root height (root_height, --root-height) must be ") +
            (!std::isfinite(height) ? "finite, got"
             : legs                 ? "> 0 m for a robot with legs (the upper body's pivot above the ground: root height "
                                      "+ upper_body_pivot > 0), got"
                                    : ">= 0 m (the upper body's pivot on the ground or above: root height + "
                                      "upper_body_pivot >= 0), got");
        EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
      }
    }
}

TEST(UrdfErrors, UpperBodyRangesMustBeFiniteWithLowerBelowUpper) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const std::string valid = wbm_test::source_path("models/third_party/nao/nao.urdf");
  for (const std::array<double, 2> range : {std::array<double, 2>{0.1, 0.1}, {0.2, -0.1}, {nan, 0.1}, {-0.1, inf},
                                            {-2e6, 0.1}}) {
    for (const bool sideways : {false, true}) {
      wbm::UrdfImportOptions options;
      (sideways ? options.upper_body_y_range : options.upper_body_x_range) = range;
      const std::string expected = sideways ? "nao.urdf: the upper body's shift range (upper_body_y_range, "
                                              "--upper-body-y-range) must be finite with lower < upper [m], got "
                                            : "nao.urdf: the upper body's shift range (upper_body_x_range, "
                                              "--upper-body-x-range) must be finite with lower < upper [m], got ";
      try {
        wbm::load_urdf(valid, options);
        ADD_FAILURE() << "range " << range[0] << ", " << range[1] << " accepted";
      } catch (const wbm::ParseError& e) {
        EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
      }
    }
  }
}

// A leg named twice (a typo for the other leg) left the other leg free and took the height
// from one leg, without a word.
TEST(UrdfErrors, ALegNamedTwiceIsAnError) {
  const wbm_test::ShippedModel& g1 = wbm_test::shipped_model("g1_29dof");
  wbm::UrdfImportOptions options = g1.options;
  ASSERT_EQ(options.legs.size(), 2u);
  options.legs[1] = options.legs[0];
  try {
    wbm::load_urdf(g1.path, options);
    ADD_FAILURE() << "a leg named twice accepted";
  } catch (const wbm::ParseError& e) {
    EXPECT_NE(std::string(e.what()).find(": leg link '" + options.legs[0] +
                                         "' is named twice (legs, --legs): name the first link of each leg once"),
              std::string::npos)
        << e.what();
  }
}

TEST(UrdfErrors, DroppingLegsNeedsTheLegs) {
  wbm::UrdfImportOptions options;
  options.leg_mode = wbm::LegMode::kDrop;
  try {
    wbm::load_urdf(wbm_test::source_path("models/third_party/nao/nao.urdf"), options);
    ADD_FAILURE() << "kDrop without legs accepted";
  } catch (const wbm::ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("nao.urdf: dropping the legs (leg_mode kDrop, --drop-legs) needs the legs"),
              std::string::npos)
        << e.what();
  }
  options.legs = {"LPelvis", "RPelvis"};
  EXPECT_NO_THROW(wbm::load_urdf(wbm_test::source_path("models/third_party/nao/nao.urdf"), options));
}

// A locked or dropped leg's joints never move, so they need no speed limit or position range
// (NimbRo-OP's URDF gives its arms limits and its legs none): with legs given, a missing
// limit is an error only for a joint that becomes a dof, at the same line as without legs.
TEST(UrdfErrors, LockedLegJointsNeedNoLimits) {
  const std::string xml = wbm_test::read_file(wbm_test::source_path("models/third_party/nao/nao.urdf"));
  // The file with one joint's speed limit set to 0 (its <limit> element is unique in it).
  const auto without_speed = [&](const std::string& limit) {
    std::string edited = xml;
    const size_t at = edited.find(limit);
    EXPECT_NE(at, std::string::npos) << limit;
    const size_t speed = limit.find("velocity=");
    return edited.replace(at + speed, limit.size() - speed, "velocity=\"0\"/>");
  };
  const std::string knee = without_speed(R"(<limit effort="3.023" lower="-0.0923279" upper="2.11255" velocity="6.40239"/>)");
  const std::string elbow = without_speed(R"(<limit effort="1.532" lower="-1.54462" upper="-0.0349066" velocity="7.19407"/>)");
  const auto line_of = [](const std::string& text, const std::string& what) {
    return 1 + std::count(text.begin(), text.begin() + text.find(what), '\n');
  };
  const std::string knee_line = std::to_string(line_of(knee, R"(velocity="0")"));
  const std::string elbow_line = std::to_string(line_of(elbow, R"(velocity="0")"));
  wbm::UrdfImportOptions options;
  const auto message = [&](const std::string& text) {
    try {
      wbm::parse_urdf(text, options, "nao_edited.urdf");
    } catch (const wbm::ParseError& e) {
      return std::string(e.what());
    }
    return std::string("(loaded)");
  };
  EXPECT_EQ(message(knee).rfind("nao_edited.urdf:" + knee_line + ": joint 'LKneePitch': no speed limit", 0), 0u)
      << message(knee);
  options.legs = {"LPelvis", "RPelvis"};
  EXPECT_EQ(message(knee), "(loaded)");
  EXPECT_EQ(message(elbow).rfind("nao_edited.urdf:" + elbow_line + ": joint 'LElbowRoll': no speed limit", 0), 0u)
      << message(elbow);
  options.leg_mode = wbm::LegMode::kDrop;
  EXPECT_EQ(message(knee), "(loaded)");
  EXPECT_EQ(message(elbow).rfind("nao_edited.urdf:" + elbow_line + ": joint 'LElbowRoll': no speed limit", 0), 0u)
      << message(elbow);
}

// A written-out .urdf with xacro leftovers beside its links and joints (as NEXTAGE OPEN's:
// an include, a property, macros that only add Gazebo and transmission tags, their calls):
// refused by default, and with ignore_xacro_elements the same model as without them.
std::string with_xacro_leftovers(const std::string& xml) {
  const size_t robot_end = xml.find('>', xml.find("<robot"));
  return xml.substr(0, robot_end + 1) + R"(
  <xacro:include filename="$(find robot_description)/urdf/materials.urdf.xacro" />
  <xacro:property name="damping" value="0.2"/>
  <xacro:macro name="gazebo_link" params="name color">
    <gazebo reference="${name}"><material>Gazebo/${color}</material></gazebo>
  </xacro:macro>
  <xacro:macro name="transmission" params="joint">
    <transmission name="${joint}_trans"><joint name="${joint}"/></transmission>
  </xacro:macro>
  <xacro:gazebo_link name="torso" color="Black"/>
  <xacro:transmission joint="torso_lift"/>
  <gazebo reference="torso"><xacro:if value="true"><material>Gazebo/Grey</material></xacro:if></gazebo>)" +
         xml.substr(robot_end + 1);
}

TEST(XacroLeftovers, RefusedByDefaultAndWithTheOptionTheSameModelAsWithout) {
  const std::string path = wbm_test::source_path("models/dual_arm/dual_arm.urdf");
  const std::string plain = wbm_test::read_file(path), leftovers = with_xacro_leftovers(plain);
  ASSERT_NE(leftovers, plain);
  try {
    wbm::parse_urdf(leftovers, {}, "leftovers.urdf");
    ADD_FAILURE() << "xacro elements accepted without the option";
  } catch (const wbm::ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("<xacro:include> is a xacro element: expand the file first"), std::string::npos)
        << e.what();
  }
  // Inside an element wbm does not read (a <gazebo> tag), a xacro element is passed over
  // without the option, as before it and as urdfdom does.
  const size_t robot_end = plain.find('>', plain.find("<robot")) + 1;
  EXPECT_NO_THROW(wbm::parse_urdf(plain.substr(0, robot_end) +
                                      "<gazebo reference=\"torso\"><xacro:if value=\"1\"><material>Gazebo/Grey</material>"
                                      "</xacro:if></gazebo>" + plain.substr(robot_end),
                                  {}, "gazebo.urdf"));
  wbm::UrdfImportOptions options;
  options.ignore_xacro_elements = true;
  const wbm::Model expected = wbm::parse_urdf(plain, {}), model = wbm::parse_urdf(leftovers, options);
  ASSERT_EQ(model.num_dofs(), expected.num_dofs());
  ASSERT_EQ(model.num_frames(), expected.num_frames());
  for (int i = 0; i < model.num_dofs(); ++i) {
    EXPECT_EQ(model.dof(i).name, expected.dof(i).name);
    EXPECT_EQ(model.dof(i).lower, expected.dof(i).lower);
    EXPECT_EQ(model.dof(i).upper, expected.dof(i).upper);
    EXPECT_EQ(model.dof(i).max_speed, expected.dof(i).max_speed);
  }
  wbm::Data data(model), expected_data(expected);
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd q = expected.home();
    for (int i = 0; i < q.size(); ++i) {
      const wbm::Dof& d = expected.dof(i);
      const double lo = std::max(d.lower, -3.0), hi = std::min(d.upper, 3.0);
      q[i] = std::uniform_real_distribution<double>(lo, hi)(rng);
    }
    wbm::forward_kinematics(model, data, q);
    wbm::forward_kinematics(expected, expected_data, q);
    for (int f = 0; f < model.num_frames(); ++f) {
      ASSERT_EQ(model.frame(f).name, expected.frame(f).name);
      EXPECT_EQ(wbm::frame_pose(model, data, f).p, wbm::frame_pose(expected, expected_data, f).p) << model.frame(f).name;
      EXPECT_EQ(wbm::frame_pose(model, data, f).R, wbm::frame_pose(expected, expected_data, f).R) << model.frame(f).name;
    }
  }
#ifdef WBM_CLI_PATH
  const std::string file = testing::TempDir() + "wbm_xacro_leftovers.urdf";
  std::ofstream(file) << leftovers;
  const std::string info = std::string("'") + WBM_CLI_PATH + "' model info --json '";
  const CliRun refused = run(info + file + "'", "xacro_refused");
  EXPECT_EQ(refused.status, 1);
  EXPECT_NE(refused.err.find("wbm_xacro_leftovers.urdf:7: <xacro:include> is a xacro element"), std::string::npos)
      << refused.err;
  const CliRun accepted = run(info + file + "' --ignore-xacro-elements", "xacro_accepted");
  ASSERT_EQ(accepted.status, 0) << accepted.err;
  const CliRun original = run(info + path + "'", "xacro_original");
  ASSERT_EQ(original.status, 0) << original.err;
  EXPECT_EQ(accepted.out, original.out);
  std::remove(file.c_str());
#endif
}

TEST(UrdfErrors, ParseErrorIsAModelErrorAndAnError) {
  EXPECT_THROW(wbm::load_urdf(malformed_path("bad_axis_zero.urdf")), wbm::ModelError);
  EXPECT_THROW(wbm::load_urdf(malformed_path("bad_axis_zero.urdf")), wbm::Error);
}

}  // namespace
