#pragma once
/// @file
/// Internal (not installed): urdfdom's console messages (console_bridge) collected instead
/// of printed, while an instance exists. The URDF import puts them into its error message;
/// the tests' KDL reference (tests/kdl_parse.cpp) counts them into one line.

#include <string>
#include <vector>

#include <console_bridge/console.h>

namespace wbm::internal {

class ConsoleCapture : public console_bridge::OutputHandler {
 public:
  ConsoleCapture() { console_bridge::useOutputHandler(this); }
  ~ConsoleCapture() override { console_bridge::restorePreviousOutputHandler(); }
  ConsoleCapture(const ConsoleCapture&) = delete;
  ConsoleCapture& operator=(const ConsoleCapture&) = delete;
  /// Warnings and errors, what console_bridge prints by default (not urdfdom's debug lines).
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_WARN) messages_.push_back(text);
  }
  const std::vector<std::string>& messages() const { return messages_; }
  /// The messages joined by "; ".
  std::string text() const {
    std::string joined;
    for (const std::string& m : messages_) joined += (joined.empty() ? "" : "; ") + m;
    return joined;
  }

 private:
  std::vector<std::string> messages_;
};

}  // namespace wbm::internal
