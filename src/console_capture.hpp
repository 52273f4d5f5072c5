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
  /// The first `most` messages joined by "; ", and how many more there were (urdfdom
  /// repeats a problem for every link that has it: one error message, not a page).
  std::string text(size_t most = 4) const {
    std::string joined;
    for (size_t i = 0; i < messages_.size() && i < most; ++i) joined += (joined.empty() ? "" : "; ") + messages_[i];
    if (messages_.size() > most) joined += "; and " + std::to_string(messages_.size() - most) + " more messages";
    return joined;
  }

 private:
  std::vector<std::string> messages_;
};

}  // namespace wbm::internal
