#pragma once
/// @file
/// What `wbm model info`, `wbm run` (its console lines, summary.json and the report) and
/// scripts/check_model.sh note about a robot model that imports and computes right but may
/// not be what its file's author meant (docs/model.md).
#include <string>
#include <vector>

#include "wbm/model.hpp"

namespace wbm {

/// The notes on a model, each one sentence without a "note: " prefix; empty for the built-in
/// paper model (`from_urdf` false) and for a file with nothing to note. Two kinds: speed
/// limits of 100 rad/s or m/s or more (placeholders such as 1e9 or a round 100, under which the speed limits, the
/// braking before position limits and the bound on the rates' change hardly act), and locked
/// legs (`legs`: the import's first leg links; dropped ones are skipped) that point more
/// forward, backward or sideways than down with the base upright (a root link turned without
/// root_rpy).
std::vector<std::string> model_notes(const Model& model, bool from_urdf, const std::vector<std::string>& legs);

}  // namespace wbm
