#pragma once
/// @file
/// report.html: the offline viewer template (web/) with a scenario run's data inlined.

#include <string>

namespace wbm {

struct ScenarioRun;

/// The template built by web/build.mjs, embedded at build time.
const char* report_template();

/// The complete self-contained report page of a run.
std::string render_report(const ScenarioRun& run);

}  // namespace wbm
