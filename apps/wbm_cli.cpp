// wbm: command-line tool. Subcommands: model info | model fk | model export.
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "model_notes.hpp"
#include "runner.hpp"
#include "scenario.hpp"
#include "wbm/errors.hpp"
#include "wbm/kinematics.hpp"
#include "wbm/paper_model.hpp"
#include "wbm/urdf_import.hpp"

namespace {

using nlohmann::json;

/// Options every subcommand uses to pick a robot model.
struct ModelSource {
  std::string file;
  wbm::UrdfImportOptions urdf;
  bool drop_legs = false;
  CLI::Option* root_height_option = nullptr;
  CLI::Option* pivot_option = nullptr;
  std::vector<double> root_rpy, upper_body_x_range, upper_body_y_range;
  std::vector<std::string> added_frames;
  std::vector<CLI::Option*> import_options;  ///< every option but the file: the URDF import's

  void add_to(CLI::App& app) {
    const size_t before = app.get_options().size();
    CLI::Option* file_option = app.add_option("file", file, "URDF file (default: the built-in paper model)");
    app.add_option("--root", urdf.root, "URDF link that becomes the upper body (default: the URDF root)");
    app.add_option("--legs", urdf.legs, "first link of each leg subtree")->delimiter(',');
    app.add_flag("--drop-legs", drop_legs, "remove the legs instead of locking them at zero");
    root_height_option = app.add_option("--root-height", urdf.root_height,
                                        "root link height above the ground [m], > 0 with legs, >= 0 without (default: "
                                        "from the legs; without legs above a massless root link cut off below it, e.g. "
                                        "a base_link on the floor, or 0 on a world link at its origin; else 1 m)");
    pivot_option = app.add_option("--upper-body-pivot", urdf.upper_body_pivot,
                                  "height [m] of the upper body's pivot (where the virtual dofs end) above the root "
                                  "link's origin, >= 0 (default 0, or the hips' height where the root link's origin "
                                  "lies at the feet)");
    app.add_option("--root-rpy", root_rpy,
                   "orientation of the root link in wbm's frame (x forward, z up): roll,pitch,yaw [rad], "
                   "e.g. 0,0,3.14159 for a root link whose x axis points backward")
        ->delimiter(',')
        ->expected(3);
    app.add_flag("--default-limits", urdf.default_limits,
                 "give joints without limits [-pi, pi] rad, 2 rad/s ([-1, 1] m, 0.5 m/s prismatic); "
                 "continuous joints keep no position limits and get 2 rad/s where they have no speed limit");
    app.add_flag("--ignore-xacro-elements", urdf.ignore_xacro_elements,
                 "skip xacro elements below <robot> (a .urdf whose links and joints are all written out), as "
                 "urdfdom does");
    app.add_option("--upper-body-x-range", upper_body_x_range,
                   "range of the upper body's forward shift over the heel (the feet's back edge): lower,upper [m] "
                   "(default -0.02,0.14; further forward for long feet)")
        ->delimiter(',')
        ->expected(2);
    app.add_option("--upper-body-y-range", upper_body_y_range,
                   "range of the upper body's sideways shift: lower,upper [m] (default -0.08,0.08)")
        ->delimiter(',')
        ->expected(2);
    app.add_option("--add-frame", added_frames,
                   "a frame to add, NAME:PARENT:X,Y,Z[:ROLL,PITCH,YAW], fixed to the frame PARENT at that position "
                   "[m] and orientation [rad] in it, e.g. a hand point at a forearm's end; repeatable");
    const std::vector<CLI::Option*> all = app.get_options();
    for (size_t i = before; i < all.size(); ++i)
      if (all[i] != file_option) import_options.push_back(all[i]);
  }

  wbm::Model load() {
    if (file.empty()) {  // options of the URDF import: silently ignored, they would hide a missing file
      std::string given;
      int count = 0;
      for (const CLI::Option* option : import_options)
        if (option->count() > 0) given += (count++ == 0 ? "" : ", ") + option->get_name();
      if (count > 0)
        throw wbm::ConfigError(given + (count == 1 ? ": an option" : ": options") +
                               " of the URDF import; the built-in paper model takes none (give a URDF file)");
      return wbm::make_paper_model();
    }
    // NaN is the library's "from the legs"; typed on the command line it is a mistake.
    if (root_height_option->count() > 0 && std::isnan(urdf.root_height))
      throw wbm::ConfigError("--root-height: expected a finite height >= 0 m, got nan");
    if (pivot_option->count() > 0 && std::isnan(urdf.upper_body_pivot))
      throw wbm::ConfigError("--upper-body-pivot: expected a finite height >= 0 m, got nan");
    if (!root_rpy.empty()) urdf.root_rpy = Eigen::Vector3d(root_rpy[0], root_rpy[1], root_rpy[2]);
    if (!upper_body_x_range.empty()) urdf.upper_body_x_range = {upper_body_x_range[0], upper_body_x_range[1]};
    if (!upper_body_y_range.empty()) urdf.upper_body_y_range = {upper_body_y_range[0], upper_body_y_range[1]};
    urdf.leg_mode = drop_legs ? wbm::LegMode::kDrop : wbm::LegMode::kLock;
    for (const std::string& text : added_frames) urdf.added_frames.push_back(wbm::parse_added_frame(text));
    return wbm::load_urdf(file, urdf);
  }
};

json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json matrix_json(const Eigen::MatrixXd& M) {
  json rows = json::array();
  for (int r = 0; r < M.rows(); ++r) {
    json row = json::array();
    for (int c = 0; c < M.cols(); ++c) row.push_back(M(r, c));
    rows.push_back(row);
  }
  return rows;
}

std::vector<std::string> model_notes(const ModelSource& source, const wbm::Model& model) {
  return wbm::model_notes(model, !source.file.empty(), source.urdf.legs);
}

/// The link the virtual upper-body dofs carry (the URDF's root, or --root) and its origin's
/// height above the ground standing straight (upper_body_z's upper limit less the pivot's
/// height above it), or "" and NaN.
std::pair<std::string, double> root_link(const wbm::Model& model) {
  const wbm::VirtualDofs& v = model.virtual_dofs();
  if (v.upper_body < 0 || v.ub_z < 0) return {"", std::nan("")};
  return {model.body(v.upper_body).name, model.dof(v.ub_z).upper - wbm::upper_body_pivot_above_root(model)};
}

int model_info(ModelSource& source, bool as_json) {
  const wbm::Model model = source.load();
  const auto [root, root_height] = root_link(model);
  if (as_json) {
    json out;
    out["name"] = model.name();
    out["total_mass"] = model.total_mass();
    out["root_link"] = root.empty() ? json(nullptr) : json(root);
    out["root_height"] = number(root_height);
    out["upper_body_pivot"] = wbm::upper_body_pivot_above_root(model);
    json dofs = json::array();
    for (int i = 0; i < model.num_dofs(); ++i) {
      const wbm::Dof& d = model.dof(i);
      dofs.push_back({{"index", i}, {"name", d.name}, {"type", d.continuous ? "continuous" : wbm::to_string(d.type)},
                      {"role", wbm::to_string(d.role)}, {"lower", number(d.lower)}, {"upper", number(d.upper)},
                      {"max_speed", d.max_speed}, {"work_range", d.work_range}, {"home", model.home()[i]}});
    }
    out["dofs"] = dofs;
    json frames = json::array();
    for (const wbm::Frame& f : model.frames())
      frames.push_back({{"name", f.name}, {"body", model.body(f.body).name},
                        {"parent", f.parent >= 0 ? json(model.frame(f.parent).name) : json(nullptr)},
                        {"offset", {f.X_BF.p.x(), f.X_BF.p.y(), f.X_BF.p.z()}}});
    out["frames"] = frames;
    out["notes"] = model_notes(source, model);
    std::cout << out.dump(2) << "\n";
    return 0;
  }
  std::cout << "model " << model.name() << ": " << model.num_dofs() << " dofs, " << model.num_bodies() << " bodies, "
            << model.num_frames() << " frames, total mass " << std::fixed << std::setprecision(3) << model.total_mass()
            << " kg\n";
  if (const double pivot = wbm::upper_body_pivot_above_root(model); !root.empty() && pivot > 0.0)
    std::cout << "root link '" << root << "', its origin " << std::abs(root_height)
              << (root_height < 0.0 ? " m below" : " m above") << " the ground standing straight; the upper body pivots "
              << pivot
              << " m above it (upper_body_pivot: chosen at the hips where the root link's origin lies at the feet, or "
                 "given; upper_body_z's upper limit "
              << root_height + pivot << " m; how it is found: docs/model.md)\n";
  else if (!root.empty())
    std::cout << "root link '" << root << "', " << root_height
              << " m above the ground standing straight (upper_body_z's upper limit; how it is found: "
                 "docs/model.md)\n";
  std::cout << "\n";
  int name_width = 28;  // wider for longer names, so that the columns stay aligned
  for (int i = 0; i < model.num_dofs(); ++i) name_width = std::max(name_width, static_cast<int>(model.dof(i).name.size()));
  std::cout << " idx  " << std::left << std::setw(name_width) << "name" << std::right
            << " type        role              lower      upper  max speed  weight(range)\n";
  for (int i = 0; i < model.num_dofs(); ++i) {
    const wbm::Dof& d = model.dof(i);
    std::cout << std::setw(4) << i << "  " << std::left << std::setw(name_width) << d.name << " " << std::setw(11)
              << (d.continuous ? "continuous" : wbm::to_string(d.type)) << " " << std::setw(16) << wbm::to_string(d.role)
              << std::right << std::setw(9) << d.lower << "  " << std::setw(9) << d.upper << "  " << std::setw(9)
              << d.max_speed << "  " << std::setw(9) << d.work_range << "\n";
  }
  for (const std::string& note : model_notes(source, model)) std::cout << "\nnote: " << note << "\n";
  std::cout << "\nframes (body, and the frame it hangs from where given):";
  for (const wbm::Frame& f : model.frames()) {
    std::cout << "\n  " << f.name << " (" << model.body(f.body).name;
    if (f.parent >= 0) std::cout << ", from " << model.frame(f.parent).name;
    std::cout << ")";
  }
  std::cout << "\n";
  return 0;
}

Eigen::VectorXd parse_configuration(const std::string& text, const wbm::Model& model) {
  if (text.empty()) return model.home();
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    // Spaces around a value are allowed ("0, 0.1, ..."). strtod rather than stod: stod throws
    // on a subnormal such as 1e-320 (ERANGE), a legal value; only overflow is out of range.
    const size_t first = item.find_first_not_of(" \t"), last = item.find_last_not_of(" \t");
    const std::string trimmed = first == std::string::npos ? "" : item.substr(first, last - first + 1);
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(trimmed.c_str(), &end);
    if (trimmed.empty() || end != trimmed.c_str() + trimmed.size())
      throw wbm::ConfigError("--q: '" + item + "' is not a number");
    if (errno == ERANGE && std::isinf(value))
      throw wbm::ConfigError("--q: '" + item + "' is beyond the range of a double (about 1.8e308)");
    if (!std::isfinite(value)) throw wbm::ConfigError("--q: '" + item + "' is not a finite number");
    values.push_back(value);
  }
  if (static_cast<int>(values.size()) != model.num_dofs())
    throw wbm::ConfigError("--q has " + std::to_string(values.size()) + " values; the model has " +
                           std::to_string(model.num_dofs()) + " dofs (see `wbm model info`)");
  return Eigen::Map<Eigen::VectorXd>(values.data(), values.size());
}

int model_fk(ModelSource& source, const std::string& q_text, std::vector<std::string> frame_names, bool jacobian,
             bool fixed_base) {
  const wbm::Model model = source.load();
  const Eigen::VectorXd q = fixed_base ? wbm::upright_base_configuration(model, parse_configuration(q_text, model))
                                       : parse_configuration(q_text, model);
  wbm::Data data(model);
  wbm::forward_kinematics(model, data, q);
  if (frame_names.empty())
    for (const wbm::Frame& f : model.frames()) frame_names.push_back(f.name);
  json out;
  out["q"] = std::vector<double>(q.data(), q.data() + q.size());
  json frames = json::object();
  Eigen::MatrixXd J(6, model.num_dofs());
  for (const std::string& name : frame_names) {
    const int id = model.frame_index(name);
    const wbm::Transform X = wbm::frame_pose(model, data, id);
    json f;
    f["position"] = {X.p.x(), X.p.y(), X.p.z()};
    f["rotation"] = matrix_json(X.R);
    if (jacobian) {
      wbm::frame_jacobian(model, data, id, J);
      f["jacobian"] = matrix_json(J);
    }
    frames[name] = f;
  }
  out["frames"] = frames;
  const wbm::Vector3 com = wbm::center_of_mass(model, data);
  out["center_of_mass"] = {com.x(), com.y(), com.z()};
  std::cout << std::setprecision(17) << out.dump(2) << "\n";
  return 0;
}

int model_export(ModelSource& source, const std::string& output, const wbm::UrdfExportOptions& options) {
  const wbm::Model model = source.load();
  const std::string text = wbm::export_urdf(model, options);
  if (output.empty() || output == "-") {
    std::cout << text;
    return 0;
  }
  // Write to a temporary file and rename it, so that nothing half-written is left behind.
  const std::string tmp = output + ".tmp";
  {
    std::ofstream out(tmp);
    out << text;
    if (!out) throw wbm::ConfigError(output + ": cannot write the file");
  }
  if (std::rename(tmp.c_str(), output.c_str()) != 0) throw wbm::ConfigError(output + ": cannot write the file");
  std::cerr << "wrote " << output << "\n";
  return 0;
}

/// Fails unless `directory` is a directory or can be created as one (its nearest existing
/// ancestor is a writable directory), so that a bad --out stops the run before it starts.
void check_output_directory(const std::string& directory) {
  namespace fs = std::filesystem;
  std::error_code error;
  fs::path path = fs::absolute(directory, error);
  if (error) throw wbm::ConfigError(directory + ": not a usable output directory (" + error.message() + ")");
  if (fs::exists(path, error)) {
    if (!fs::is_directory(path, error)) throw wbm::ConfigError(directory + ": exists and is not a directory (--out)");
  } else {
    while (!path.empty() && !fs::exists(path, error)) {
      if (path.filename().native().size() > wbm::kMaxFileNameBytes)
        throw wbm::ConfigError(directory + ": cannot be created: '" + path.filename().native().substr(0, 40) +
                               "...' is longer than a file name may be (" + std::to_string(wbm::kMaxFileNameBytes) +
                               " bytes; --out)");
      path = path.parent_path();
    }
    if (!fs::is_directory(path, error))
      throw wbm::ConfigError(directory + ": cannot be created: " + path.string() + " is not a directory (--out)");
  }
  if (access(path.c_str(), W_OK | X_OK) != 0)
    throw wbm::ConfigError(directory + ": cannot write into " + path.string() + " (--out)");
}

int run_scenarios(const std::vector<std::string>& files, const std::string& out, bool no_report) {
  // Parse every file and look up its names in its model first, so that a bad file stops
  // the run before anything is printed, simulated or written.
  std::vector<wbm::Scenario> scenarios;
  for (const std::string& f : files) scenarios.push_back(wbm::load_scenario(f));
  auto directory = [&](const wbm::Scenario& s) { return files.size() == 1 ? out : out + "/" + s.name; };
  std::map<std::string, const wbm::Scenario*> by_name;  // each writes to out/<name>: no two alike
  for (const wbm::Scenario& s : scenarios)
    if (files.size() > 1 && !by_name.emplace(s.name, &s).second)
      throw wbm::ConfigError(s.source + ":" + std::to_string(s.name_line) + ": name: '" + s.name +
                             "' is also the name of the scenario in " + by_name[s.name]->source + "; both would write to " +
                             directory(s));
  wbm::RunOptions check;
  check.check_only = true;
  for (const wbm::Scenario& s : scenarios) {
    wbm::run_scenario(s, check);
    check_output_directory(directory(s));
  }
  // The results on stdout (`wbm run ... > log` keeps them), the progress on stderr.
  for (const wbm::Scenario& s : scenarios) {
    const std::string dir = directory(s);
    std::cout << "scenario " << s.name << " (" << s.duration << " s at dt = " << s.dt * 1e3 << " ms)\n";
    wbm::RunOptions options;
    options.progress = true;
    const auto run = wbm::run_scenario(s, options);
    wbm::write_outputs(*run, dir, !no_report);
    const json summary = wbm::summarize(*run);
    for (const json& note : summary["model_notes"]) std::cout << "  note: " << note.get<std::string>() << "\n";
    for (const json& note : summary["task_notes"]) std::cout << "  note: " << note.get<std::string>() << "\n";
    for (const auto& [name, e] : summary["elements"].items()) {
      std::cout << "  " << name << ": ";
      if (e["final_error"].is_null()) std::cout << "inactive at the end\n";
      else std::cout << "final error " << e["final_error"].get<double>() << " " << e["unit"].get<std::string>() << "\n";
    }
    // Why a target may be unmet: the last cycle damped, joints at a position limit.
    if (const std::string why = wbm::describe_last_cycle(summary["at_end"]); !why.empty())
      std::cout << "  last cycle: " << why << "\n";
    {  // how close the joints came to their speed limits and to the bound on their acceleration
      std::ostringstream joints;
      joints << std::fixed << std::setprecision(2) << "  joints: fastest at " << summary["max_joint_speed"]["ratio_to_limit"].get<double>()
             << " of its speed limit (" << summary["max_joint_speed"]["dof"].get<std::string>() << ")";
      if (summary.contains("max_joint_acceleration_to_bound")) {
        const json& a = summary["max_joint_acceleration_to_bound"];
        joints << ", largest acceleration " << a["ratio"].get<double>() << " of its bound k v_max ("
               << a["dof"].get<std::string>() << ")";
      }
      std::cout << joints.str() << "\n";
    }
    if (summary.contains("balance") && summary["balance"]["final_com_margin"].is_number()) {
      const double margin = summary["balance"]["final_com_margin"].get<double>();
      std::ostringstream cm;
      cm << std::fixed << std::setprecision(1) << std::abs(margin) * 100.0;
      const bool on = summary["balance"]["on_at_end"].get<bool>();
      std::cout << "  balance: centre of mass " << cm.str() << " cm "
                << (margin >= 0.0 ? "inside the feet at the end"
                    : on          ? "OUTSIDE the feet at the end (the upper-body shift could not bring it over them)"
                                  : "OUTSIDE the feet at the end")
                << (on ? "\n" : " (balance off)\n");
      // The shift held at a limit of its range: name the range to widen and by how much.
      for (const json& a : summary["balance"]["shift_at_limit"])
        std::cout << "  balance: " << wbm::describe_shift_at_limit(a, summary["balance"]["balanced_cycles"].get<int>()) << "\n";
    }
    if (summary.contains("walking"))
      for (const std::string& line : wbm::describe_walking(summary["walking"])) std::cout << "  walking: " << line << "\n";
    std::cout << "  wrote " << dir << "/{trajectory.csv,summary.json" << (no_report ? "" : ",report.html") << "}\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"wbm: task-oriented whole-body motion control (Gienger, Janssen, Goerick 2005)"};
  app.require_subcommand(1);
  CLI::App* model_cmd = app.add_subcommand("model", "inspect robot models");
  model_cmd->require_subcommand(1);

  ModelSource info_source;
  bool info_json = false;
  CLI::App* info = model_cmd->add_subcommand("info", "list dofs, limits, frames and mass");
  info_source.add_to(*info);
  info->add_flag("--json", info_json, "machine-readable output");

  ModelSource fk_source;
  std::string q_text;
  std::vector<std::string> fk_frames;
  bool fk_jacobian = false;
  bool fk_json = false;
  bool fk_fixed_base = false;
  CLI::App* fk = model_cmd->add_subcommand("fk", "world poses (and Jacobians) of frames for a configuration");
  fk_source.add_to(*fk);
  fk->add_option("--q", q_text, "configuration, comma separated, in `model info` order (default: home)");
  fk->add_option("--frames", fk_frames, "frames to print (default: all)")->delimiter(',');
  fk->add_flag("--jacobian", fk_jacobian, "also print 6 x n Jacobians (rows: v_x v_y v_z w_x w_y w_z, world frame)");
  fk->add_flag("--json", fk_json, "JSON output (the only format)");
  fk->add_flag("--fixed-base", fk_fixed_base,
               "the base upright, as for a robot bolted to the world (scripts' --fixed-base, robot.fixed_base): the "
               "virtual dofs at the heel's origin and the root's full height, untilted (their values in --q replaced)");

  ModelSource export_source;
  std::string export_out;
  CLI::App* exp = model_cmd->add_subcommand("export", "write the model as URDF");
  export_source.add_to(*exp);
  exp->add_option("-o,--output", export_out, "output file (default: standard output)");
  wbm::UrdfExportOptions export_options;
  exp->add_flag("--virtual-dofs", export_options.virtual_dofs,
                "write the whole tree: the virtual heel and upper-body dofs as joints below a 'world' link");

  std::vector<std::string> run_files;
  std::string run_out = "out";
  bool run_no_report = false;
  CLI::App* run = app.add_subcommand("run", "simulate scenario files; write trajectory.csv, summary.json, report.html");
  run->add_option("scenarios", run_files, "scenario YAML files")->required()->check(CLI::ExistingFile);
  run->add_option("--out", run_out, "output directory (one subdirectory per scenario when several are given)");
  run->add_flag("--no-report", run_no_report, "skip report.html");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    // A bad command line: the message as for a bad file, and exit status 2 (a usage error,
    // as scripts/check_model.sh and bench.sh give), not CLI11's 100-odd codes.
    std::cerr << "wbm: error: " << e.what() << "\nRun with --help for more information.\n";
    return 2;
  }
  try {
    if (info->parsed()) return model_info(info_source, info_json);
    if (fk->parsed()) return model_fk(fk_source, q_text, fk_frames, fk_jacobian, fk_fixed_base);
    if (exp->parsed()) return model_export(export_source, export_out, export_options);
    if (run->parsed()) return run_scenarios(run_files, run_out, run_no_report);
  } catch (const wbm::Error& e) {
    std::cerr << "wbm: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {  // not expected; an error message instead of an abort
    std::cerr << "wbm: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
