// Kinematics benchmark: wbm against Orocos KDL in the same run.
//
// Per model, the work a whole-body controller cycle needs from kinematics: forward
// kinematics and the 12-row Jacobian of both hands (frame_jacobian of each hand, 6 rows
// each). KDL does the same with TreeFkSolverPos_recursive (both hand poses) and
// TreeJntToJacSolver (both hand Jacobians) on a tree loaded from the same URDF; for the
// paper model that URDF is wbm::export_urdf(make_paper_model()). Note that wbm's FK
// computes every body including the 9 virtual dofs, KDL's solvers only the chains to the
// requested segments (and without the virtual dofs).
//
// At the end a table prints the time ratio KDL / wbm for each case.
#include <unistd.h>

#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>
#include <kdl/tree.hpp>
#include <kdl/treefksolverpos_recursive.hpp>
#include <kdl/treejnttojacsolver.hpp>
#include <kdl_parser/kdl_parser.hpp>

#include "shipped_models.hpp"
#include "wbm/kinematics.hpp"
#include "wbm/paper_model.hpp"
#include "wbm/urdf_import.hpp"

namespace {

/// One model in both libraries, with a few random configurations to cycle through.
struct Case {
  std::string name;
  std::unique_ptr<wbm::Model> model;
  std::unique_ptr<wbm::Data> data;
  int left = -1, right = -1;  // hand frames
  std::string left_name, right_name;
  KDL::Tree tree;
  std::unique_ptr<KDL::TreeFkSolverPos_recursive> kdl_fk;
  std::unique_ptr<KDL::TreeJntToJacSolver> kdl_jac;
  std::vector<Eigen::VectorXd> q;
  std::vector<KDL::JntArray> kq;
};

void load_case(Case& c, wbm::Model model, const std::string& urdf_xml, const std::string& left,
               const std::string& right) {
  c.model = std::make_unique<wbm::Model>(std::move(model));
  c.data = std::make_unique<wbm::Data>(*c.model);
  c.left_name = left;
  c.right_name = right;
  c.left = c.model->frame_index(left);
  c.right = c.model->frame_index(right);
  if (!kdl_parser::treeFromString(urdf_xml, c.tree)) throw std::runtime_error("kdl_parser rejected " + c.name);
  c.kdl_fk = std::make_unique<KDL::TreeFkSolverPos_recursive>(c.tree);
  c.kdl_jac = std::make_unique<KDL::TreeJntToJacSolver>(c.tree);

  // The same configurations in both: KDL joints by name, others (locked legs) at zero.
  std::map<std::string, unsigned> q_nr;
  for (const auto& [name, element] : c.tree.getSegments()) {
    const KDL::Joint& joint = GetTreeElementSegment(element).getJoint();
    if (joint.getType() != KDL::Joint::None) q_nr[joint.getName()] = GetTreeElementQNr(element);
  }
  std::mt19937_64 rng(42);
  for (int k = 0; k < 64; ++k) {
    Eigen::VectorXd q(c.model->num_dofs());
    for (int i = 0; i < q.size(); ++i) {
      const wbm::Dof& d = c.model->dof(i);
      q[i] = d.continuous ? std::uniform_real_distribution<double>(-3.0, 3.0)(rng)
                          : std::uniform_real_distribution<double>(d.lower, d.upper)(rng);
    }
    KDL::JntArray kq(c.tree.getNrOfJoints());
    for (int i = 0; i < q.size(); ++i) {
      const auto it = q_nr.find(c.model->dof(i).name);
      if (it != q_nr.end()) kq(it->second) = q[i];
    }
    c.q.push_back(q);
    c.kq.push_back(kq);
  }

  // Sanity check: both libraries agree on the hand position relative to the root link.
  const std::string root = c.model->body(c.model->virtual_dofs().upper_body).name;
  wbm::forward_kinematics(*c.model, *c.data, c.q[0]);
  const wbm::Transform X_root = wbm::frame_pose(*c.model, *c.data, c.model->frame_index(root));
  const wbm::Vector3 ours = X_root.inverse() * wbm::frame_pose(*c.model, *c.data, c.left).p;
  KDL::Frame kdl_root, kdl_hand;
  c.kdl_fk->JntToCart(c.kq[0], kdl_root, root);
  c.kdl_fk->JntToCart(c.kq[0], kdl_hand, left);
  const KDL::Vector theirs = kdl_root.Inverse(kdl_hand.p);
  if ((ours - wbm::Vector3(theirs.x(), theirs.y(), theirs.z())).norm() > 1e-9)
    throw std::runtime_error(c.name + ": wbm and KDL disagree on the hand position");
}

std::vector<std::unique_ptr<Case>>& cases() {
  static std::vector<std::unique_ptr<Case>> list;
  return list;
}

void wbm_fk(benchmark::State& state, Case* c) {
  size_t k = 0;
  for (auto _ : state) {
    wbm::forward_kinematics(*c->model, *c->data, c->q[k++ & 63]);
    benchmark::DoNotOptimize(c->data->X_WB.data());
    benchmark::ClobberMemory();
  }
}

void kdl_fk(benchmark::State& state, Case* c) {
  KDL::Frame left, right;
  size_t k = 0;
  for (auto _ : state) {
    const KDL::JntArray& q = c->kq[k++ & 63];
    c->kdl_fk->JntToCart(q, left, c->left_name);
    c->kdl_fk->JntToCart(q, right, c->right_name);
    benchmark::DoNotOptimize(left);
    benchmark::DoNotOptimize(right);
  }
}

void wbm_fk_jacobians(benchmark::State& state, Case* c) {
  Eigen::MatrixXd J(12, c->model->num_dofs());
  size_t k = 0;
  for (auto _ : state) {
    wbm::forward_kinematics(*c->model, *c->data, c->q[k++ & 63]);
    const wbm::Transform left = wbm::frame_pose(*c->model, *c->data, c->left);
    const wbm::Transform right = wbm::frame_pose(*c->model, *c->data, c->right);
    wbm::frame_jacobian(*c->model, *c->data, c->left, J.topRows(6));
    wbm::frame_jacobian(*c->model, *c->data, c->right, J.bottomRows(6));
    benchmark::DoNotOptimize(left);
    benchmark::DoNotOptimize(right);
    benchmark::DoNotOptimize(J.data());
    benchmark::ClobberMemory();
  }
}

void kdl_fk_jacobians(benchmark::State& state, Case* c) {
  KDL::Frame left, right;
  KDL::Jacobian J_left(c->tree.getNrOfJoints()), J_right(c->tree.getNrOfJoints());
  size_t k = 0;
  for (auto _ : state) {
    const KDL::JntArray& q = c->kq[k++ & 63];
    c->kdl_fk->JntToCart(q, left, c->left_name);
    c->kdl_fk->JntToCart(q, right, c->right_name);
    c->kdl_jac->JntToJac(q, J_left, c->left_name);
    c->kdl_jac->JntToJac(q, J_right, c->right_name);
    benchmark::DoNotOptimize(left);
    benchmark::DoNotOptimize(right);
    benchmark::DoNotOptimize(J_left.data.data());
    benchmark::DoNotOptimize(J_right.data.data());
    benchmark::ClobberMemory();
  }
}

/// Console output plus a KDL / wbm ratio table at the end.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  RatioReporter() : ConsoleReporter(isatty(fileno(stdout)) ? OO_ColorTabular : OO_Tabular) {}

  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& run : runs)
      if (run.run_type == Run::RT_Iteration && !run.error_occurred)
        times_[run.benchmark_name()] = run.GetAdjustedCPUTime();  // in the run's time unit (ns)
  }

  void print_ratios() const {
    std::printf("\n%-28s %14s %14s %12s\n", "case", "wbm CPU [ns]", "KDL CPU [ns]", "KDL / wbm");
    for (const auto& [name, t_wbm] : times_) {
      const std::string prefix = "wbm/";
      if (name.rfind(prefix, 0) != 0) continue;
      const std::string what = name.substr(prefix.size());
      const auto kdl = times_.find("kdl/" + what);
      if (kdl == times_.end()) continue;
      std::printf("%-28s %14.1f %14.1f %12.2f\n", what.c_str(), t_wbm, kdl->second, kdl->second / t_wbm);
    }
  }

 private:
  std::map<std::string, double> times_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;

  // The paper model, and KDL on its URDF export (root: the upper body).
  auto paper = std::make_unique<Case>();
  paper->name = "paper";
  {
    wbm::Model model = wbm::make_paper_model();
    const std::string xml = wbm::export_urdf(model);
    load_case(*paper, std::move(model), xml, "l_hand_ref", "r_hand_ref");
  }
  cases().push_back(std::move(paper));
  // Unitree G1 (29 dof), legs locked; KDL on the original file.
  auto g1 = std::make_unique<Case>();
  g1->name = "g1_29dof";
  {
    const wbm_test::ShippedModel& entry = wbm_test::shipped_model("g1_29dof");
    std::FILE* f = std::fopen(entry.path.c_str(), "rb");
    if (f == nullptr) throw std::runtime_error("cannot open " + entry.path);
    std::string xml;
    char buffer[65536];
    size_t n;
    while ((n = std::fread(buffer, 1, sizeof buffer, f)) > 0) xml.append(buffer, n);
    std::fclose(f);
    load_case(*g1, entry.load(), xml, entry.left_hand, entry.right_hand);
  }
  cases().push_back(std::move(g1));

  for (const auto& c : cases()) {
    Case* p = c.get();
    benchmark::RegisterBenchmark(("wbm/" + c->name + "/fk+jac12").c_str(), wbm_fk_jacobians, p);
    benchmark::RegisterBenchmark(("kdl/" + c->name + "/fk+jac12").c_str(), kdl_fk_jacobians, p);
    benchmark::RegisterBenchmark(("wbm/" + c->name + "/fk").c_str(), wbm_fk, p);
    benchmark::RegisterBenchmark(("kdl/" + c->name + "/fk").c_str(), kdl_fk, p);
  }
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.print_ratios();
  benchmark::Shutdown();
  return 0;
}
