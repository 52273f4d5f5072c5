#include "kdl_parse.hpp"

#include <functional>

#include <console_bridge/console.h>
#include <kdl_parser/kdl_parser.hpp>
#include <urdf_parser/urdf_parser.h>

namespace wbm_test {
namespace {

/// Collects console_bridge's messages while it is installed (one parse).
class MessageCounter : public console_bridge::OutputHandler {
 public:
  explicit MessageCounter(KdlParse& result) : result_(result) { console_bridge::useOutputHandler(this); }
  ~MessageCounter() override { console_bridge::restorePreviousOutputHandler(); }
  MessageCounter(const MessageCounter&) = delete;
  MessageCounter& operator=(const MessageCounter&) = delete;
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    // What console_bridge prints by default: warnings and errors (not urdfdom's debug lines).
    if (level < console_bridge::CONSOLE_BRIDGE_LOG_WARN) return;
    if (result_.messages++ == 0) result_.first_message = text;
  }

 private:
  KdlParse& result_;
};

KdlParse parse(const std::function<bool()>& run) {
  KdlParse result;
  {
    MessageCounter counter(result);
    result.ok = run();
  }
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
