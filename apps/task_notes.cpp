#include "task_notes.hpp"

#include <cmath>
#include <random>

#include "wbm/kinematics.hpp"

namespace wbm {

std::vector<std::string> immovable_task_notes(const Model& model, TaskStack& stack, const std::vector<bool>& ever_free,
                                              const std::vector<bool>& considered, const Eigen::VectorXd& q0) {
  constexpr double kVanishing = 1e-10;  // structural zeros are exact; a parallel axis leaves rounding
  constexpr int kRandomConfigurations = 4;
  const int n = model.num_dofs();
  std::vector<Eigen::VectorXd> configurations{q0};
  std::mt19937_64 rng(20051205);  // fixed: the same notes on every run
  for (int k = 0; k < kRandomConfigurations; ++k) {
    Eigen::VectorXd q(n);
    for (int i = 0; i < n; ++i) {
      const Dof& d = model.dof(i);
      const double lower = d.continuous ? -M_PI : d.lower, upper = d.continuous ? M_PI : d.upper;
      q[i] = std::uniform_real_distribution<double>(lower, upper)(rng);
    }
    configurations.push_back(q);
  }
  // moves[e][i]: dof i moves element e at one of the configurations.
  std::vector<std::vector<bool>> moves(stack.num_elements(), std::vector<bool>(n, false));
  Data data(model);
  for (const Eigen::VectorXd& q : configurations) {
    forward_kinematics(model, data, q);
    center_of_mass(model, data);
    for (int e = 0; e < stack.num_elements(); ++e) {
      if (!considered[e]) continue;
      TaskElement& element = stack.element(e);
      Eigen::VectorXd x(element.target_dim()), error(element.dim()), rate(element.dim());
      Eigen::MatrixXd J(element.dim(), n);
      element.value(model, data, x);
      element.evaluate(model, data, x, Eigen::VectorXd::Zero(element.target_dim()), J, error, rate);
      for (int i = 0; i < n; ++i)
        if (J.col(i).cwiseAbs().maxCoeff() > kVanishing) moves[e][i] = true;
    }
  }
  std::vector<std::string> notes;
  for (int e = 0; e < stack.num_elements(); ++e) {
    if (!considered[e]) continue;
    std::string movers;
    int count = 0;
    bool free_mover = false;
    for (int i = 0; i < n; ++i) {
      if (!moves[e][i]) continue;
      free_mover = free_mover || ever_free[i];
      if (++count <= 6) movers += (count > 1 ? ", " : "") + model.dof(i).name;
    }
    if (free_mover) continue;
    if (count > 6) movers += " and " + std::to_string(count - 6) + " more";
    const std::string task = "task '" + stack.element(e).name() + "': ";
    notes.push_back(count == 0 ? task + "no dof of the model moves it, so it stays where it is"
                               : task + "only frozen dofs move it (" + movers +
                                     "; frozen by robot.fixed_base or frozen, and no event releases one), so it "
                                     "stays where it is");
  }
  return notes;
}

}  // namespace wbm
