#include "kdl_parse.hpp"

#include <functional>

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

KdlParse kdl_tree_from_file(const std::string& path, KDL::Tree& tree) {
  return parse([&] { return kdl_parser::treeFromFile(path, tree); });
}

urdf::ModelInterfaceSharedPtr urdf_model_from_file(const std::string& path) {
  urdf::ModelInterfaceSharedPtr model;
  parse([&] { return (model = urdf::parseURDFFile(path)) != nullptr; });
  return model;
}

urdf::ModelInterfaceSharedPtr urdf_model_from_string(const std::string& xml) {
  urdf::ModelInterfaceSharedPtr model;
  parse([&] { return (model = urdf::parseURDF(xml)) != nullptr; });
  return model;
}

}  // namespace wbm_test
