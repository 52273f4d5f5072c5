#pragma once
/// @file
/// Internal (not installed): suggestions for a misspelt name in the errors of name lookups.

#include <string>
#include <vector>

namespace wbm::internal {

/// " (did you mean 'x'?)" for the names closest to a misspelt one: the closest within an
/// edit distance (case ignored) of a third of its length, at least 1; failing those, the
/// names that contain it, shortest first (`left_elbow` -> `left_elbow_link`). At most three;
/// empty if none is close.
std::string did_you_mean(const std::string& name, const std::vector<std::string>& names);

}  // namespace wbm::internal
