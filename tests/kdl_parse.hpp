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

#include <vector>

#include <kdl/tree.hpp>
#include <urdf_world/types.h>

#include "wbm/urdf_import.hpp"

namespace wbm_test {

struct KdlParse {
  bool ok = false;  ///< kdl_parser built the tree
  int messages = 0;  ///< urdfdom's warnings and errors on the console while it did
  std::string first_message;
  /// "" without messages, else one line: how many, the first, and that they were set aside.
  std::string summary() const;
};

KdlParse kdl_tree_from_string(const std::string& xml, KDL::Tree& tree);
/// urdfdom's model of the text (for the reference's mimic joints and link tree), its
/// console messages dropped (the same as kdl_tree_from_string's, summarised there); null
/// where urdfdom rejects it.
urdf::ModelInterfaceSharedPtr urdf_model_from_string(const std::string& xml);

/// The URDF file's text with the frames wbm adds to the model (UrdfImportOptions::added_frames,
/// --add-frame) written in as fixed links on their parents before the closing </robot>, so that
/// the references (KDL, urdfdom) have them too; the text unchanged without any.
/// @throws std::runtime_error if the file cannot be read or has no </robot>.
std::string urdf_text_with_added_frames(const std::string& path, const std::vector<wbm::AddedFrame>& frames);

}  // namespace wbm_test
