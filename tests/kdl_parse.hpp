#pragma once
/// @file
/// kdl_parser for the tests and benchmarks (the KDL reference), with urdfdom's console
/// messages set aside: a file such as Unitree's H1_2 has urdfdom print a line per link
/// ("Visual material must contain a name attribute"), 58 per parse, harmless for
/// kinematics, yet they drowned check_model.sh's output in red. They are counted and the
/// first kept (src/console_capture.hpp, as the URDF import collects them), to be shown in
/// one line (and in the message when kdl_parser rejects the file).
/// kdl_parser's own rosconsole warning (a root link with inertia) is not routed through
/// console_bridge and still prints.

#include <string>

#include <kdl/tree.hpp>
#include <urdf_world/types.h>

namespace wbm_test {

struct KdlParse {
  bool ok = false;  ///< kdl_parser built the tree
  int messages = 0;  ///< urdfdom's warnings and errors on the console while it did
  std::string first_message;
  /// "" without messages, else one line: how many, the first, and that they were set aside.
  std::string summary() const;
};

KdlParse kdl_tree_from_string(const std::string& xml, KDL::Tree& tree);
KdlParse kdl_tree_from_file(const std::string& path, KDL::Tree& tree);
/// urdfdom's model of the file (for the reference's mimic joints and link tree), its
/// console messages dropped (the same as kdl_tree_from_file's, summarised there); null
/// where urdfdom rejects the file.
urdf::ModelInterfaceSharedPtr urdf_model_from_file(const std::string& path);
urdf::ModelInterfaceSharedPtr urdf_model_from_string(const std::string& xml);

}  // namespace wbm_test
