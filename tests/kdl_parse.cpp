#include "kdl_parse.hpp"

#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>

#include <kdl_parser/kdl_parser.hpp>
#include <urdf_parser/urdf_parser.h>

#include "console_capture.hpp"

namespace wbm_test {
namespace {

KdlParse parse(const std::function<bool()>& run) {
  KdlParse result;
  wbm::internal::ConsoleCapture capture;
  result.ok = run();
  result.messages = static_cast<int>(capture.messages().size());
  if (result.messages > 0) result.first_message = capture.messages().front();
  return result;
}

}  // namespace

std::string KdlParse::summary() const {
  if (messages == 0) return "";
  return "urdfdom printed " + std::to_string(messages) + " message" + (messages == 1 ? "" : "s") +
         " while kdl_parser read the file (the first: '" + first_message +
         "'), set aside: the comparison with KDL's tree decides whether it is right";
}

KdlParse kdl_tree_from_string(const std::string& xml, KDL::Tree& tree) {
  return parse([&] { return kdl_parser::treeFromString(xml, tree); });
}

urdf::ModelInterfaceSharedPtr urdf_model_from_string(const std::string& xml) {
  urdf::ModelInterfaceSharedPtr model;
  parse([&] { return (model = urdf::parseURDF(xml)) != nullptr; });
  return model;
}

std::string urdf_text_with_added_frames(const std::string& path, const std::vector<wbm::AddedFrame>& frames) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot read the file");
  std::stringstream text;
  text << in.rdbuf();
  std::string xml = text.str();
  if (frames.empty()) return xml;
  const std::size_t end = xml.rfind("</robot>");
  if (end == std::string::npos) throw std::runtime_error(path + ": no </robot> to add frames before");
  std::ostringstream links;
  links.precision(17);
  for (const wbm::AddedFrame& f : frames)
    links << "  <link name=\"" << f.name << "\"/>\n  <joint name=\"wbm_added_frame_" << f.name
          << "\" type=\"fixed\">\n    <parent link=\"" << f.parent << "\"/>\n    <child link=\"" << f.name
          << "\"/>\n    <origin xyz=\"" << f.xyz.x() << " " << f.xyz.y() << " " << f.xyz.z() << "\" rpy=\"" << f.rpy.x()
          << " " << f.rpy.y() << " " << f.rpy.z() << "\"/>\n  </joint>\n";
  return xml.insert(end, links.str());
}

}  // namespace wbm_test
