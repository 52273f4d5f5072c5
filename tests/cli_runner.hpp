#pragma once
/// @file
/// Runs a shell command from a test and captures its exit status, stdout and stderr.

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include <gtest/gtest.h>

#include "test_util.hpp"

namespace wbm_test {

struct CliRun {
  int status = -1;
  std::string out, err;
};

/// `tag` keeps the temporary files of parallel test processes apart.
inline CliRun run_command(const std::string& command, const std::string& tag) {
  const std::string dir = testing::TempDir() + std::to_string(getpid()) + "_";
  const std::string out = dir + "cli_" + tag + ".out", err = dir + "cli_" + tag + ".err";
  const int raw = std::system((command + " >'" + out + "' 2>'" + err + "'").c_str());
  CliRun r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = read_file(out);
  r.err = read_file(err);
  std::remove(out.c_str());
  std::remove(err.c_str());
  return r;
}

}  // namespace wbm_test
