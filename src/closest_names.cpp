#include "closest_names.hpp"

#include <algorithm>
#include <cctype>
#include <limits>

namespace wbm::internal {
namespace {

/// Edit distance (insertions, deletions, substitutions), ignoring case.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  auto lower = [](char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); };
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitution = diagonal + (lower(a[i - 1]) == lower(b[j - 1]) ? 0 : 1);
      diagonal = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, substitution});
    }
  }
  return row[b.size()];
}

bool contains_ignoring_case(const std::string& text, const std::string& part) {
  return std::search(text.begin(), text.end(), part.begin(), part.end(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         }) != text.end();
}

}  // namespace

std::string did_you_mean(const std::string& name, const std::vector<std::string>& names) {
  if (name.empty()) return {};
  // The names within the edit distance, the closest; failing those, the names that contain
  // the typed one (a prefix or part of a name) or that it contains and that make at least
  // half of it (a name typed with an ending it lacks: "left_hand_link" for "left_hand").
  const std::size_t limit = std::max<std::size_t>(1, name.size() / 3);
  std::size_t best = std::numeric_limits<std::size_t>::max();
  std::vector<std::string> closest, containing;
  for (const std::string& candidate : names) {
    const std::size_t d = edit_distance(name, candidate);
    if (d <= limit) {
      if (d < best) {
        best = d;
        closest.clear();
      }
      if (d == best && closest.size() < 3) closest.push_back(candidate);
    } else if (name.size() >= 3 && (contains_ignoring_case(candidate, name) ||
                                    (2 * candidate.size() >= name.size() && contains_ignoring_case(name, candidate)))) {
      containing.push_back(candidate);
    }
  }
  if (closest.empty()) {  // the closest in length first (the least added to or left out of what was typed)
    const auto gap = [&](const std::string& a) { return a.size() > name.size() ? a.size() - name.size() : name.size() - a.size(); };
    std::stable_sort(containing.begin(), containing.end(),
                     [&](const std::string& a, const std::string& b) { return gap(a) < gap(b); });
    containing.resize(std::min<std::size_t>(containing.size(), 3));
    closest = containing;
  }
  if (closest.empty()) return {};
  std::string text = " (did you mean";
  for (std::size_t k = 0; k < closest.size(); ++k) {
    text += k == 0 ? " " : k + 1 == closest.size() ? " or " : ", ";
    text += "'" + closest[k] + "'";
  }
  return text + "?)";
}

}  // namespace wbm::internal
