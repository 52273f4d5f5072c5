#pragma once
/// @file
/// Helpers shared by the tests: seeded random configurations, the rotation logarithm for
/// finite differences, printing, solver parameters for exact checks, errors and their text.

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "wbm/model.hpp"
#include "wbm/solver.hpp"

namespace wbm_test {

/// The whole text of a file (empty if it cannot be read).
inline std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// Solver parameters for exact checks of the solve itself: no speed scaling, no jerk limit.
inline wbm::SolverParameters raw_parameters() {
  wbm::SolverParameters p;
  p.limit_speeds = false;
  p.nullspace_rate_change_limit = 0.0;
  return p;
}

/// Success if `call` throws an E whose message contains `expected`; else what it did.
template <class E>
testing::AssertionResult throws_with(const std::function<void()>& call, const std::string& expected) {
  try {
    call();
  } catch (const E& e) {
    if (std::string(e.what()).find(expected) != std::string::npos) return testing::AssertionSuccess();
    return testing::AssertionFailure() << "threw \"" << e.what() << "\", wanted \"" << expected << "\"";
  }
  return testing::AssertionFailure() << "accepted; wanted \"" << expected << "\"";
}

/// A chain of one-dof revolute bodies (limits +-1, speed 1), each named after its dof,
/// recording the virtual dofs given (say a heel without its yaw): for the modules' checks
/// of the models they are given.
inline wbm::Model chain_model(const std::string& name, const std::vector<std::string>& dofs,
                              const wbm::VirtualDofs& virtual_dofs) {
  wbm::ModelBuilder builder(name);
  for (const std::string& dof_name : dofs) {
    wbm::Dof dof;
    dof.name = dof_name;
    dof.lower = -1.0;
    dof.upper = 1.0;
    dof.max_speed = 1.0;
    wbm::Body body;
    body.name = dof_name;
    body.parent = builder.num_bodies() - 1;
    body.dof = builder.add_dof(dof);
    builder.add_body(body);
  }
  builder.set_virtual_dofs(virtual_dofs);
  return builder.build();
}

/// Uniformly random configuration within the limits; continuous joints in [-pi, pi].
inline Eigen::VectorXd random_configuration(const wbm::Model& model, std::mt19937_64& rng) {
  Eigen::VectorXd q(model.num_dofs());
  for (int i = 0; i < model.num_dofs(); ++i) {
    const wbm::Dof& d = model.dof(i);
    const double lo = d.continuous ? -M_PI : d.lower;
    const double hi = d.continuous ? M_PI : d.upper;
    q[i] = std::uniform_real_distribution<double>(lo, hi)(rng);
  }
  return q;
}

/// Cases per seeded property test: 10^4, or WBM_PROPERTY_CASES=<n>.
inline int property_cases() {
  const char* env = std::getenv("WBM_PROPERTY_CASES");
  return env ? std::max(1, std::atoi(env)) : 10000;
}

/// Random unit vector of dimension n.
inline Eigen::VectorXd random_direction(int n, std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = normal(rng);
  return v.normalized();
}

inline wbm::Vector3 random_vector3(std::mt19937_64& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return {u(rng), u(rng), u(rng)};
}

/// Axis-angle vector (log map) of a rotation: angle * axis.
inline wbm::Vector3 rotation_log(const wbm::Matrix3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

/// Hands out indices 0..n-1 in random order, reshuffling when all were used, so that a
/// long run of random picks covers every index.
class Deck {
 public:
  Deck(int n, std::mt19937_64& rng) : order_(n), rng_(rng) { reshuffle(); }
  int next() {
    if (pos_ == order_.size()) reshuffle();
    return order_[pos_++];
  }
 private:
  void reshuffle() {
    std::iota(order_.begin(), order_.end(), 0);
    std::shuffle(order_.begin(), order_.end(), rng_);
    pos_ = 0;
  }
  std::vector<int> order_;
  std::mt19937_64& rng_;
  size_t pos_ = 0;
};

/// "name=value, ..." of a configuration with full precision, for failure messages.
inline std::string describe_configuration(const wbm::Model& model, const Eigen::VectorXd& q) {
  std::ostringstream out;
  out.precision(17);
  for (int i = 0; i < q.size(); ++i) out << (i ? ", " : "") << model.dof(i).name << "=" << q[i];
  return out.str();
}

inline std::string describe_vector(const Eigen::VectorXd& v) {
  std::ostringstream out;
  out.precision(12);
  out << "(";
  for (int i = 0; i < v.size(); ++i) out << (i ? ", " : "") << v[i];
  out << ")";
  return out.str();
}

/// Largest absolute difference of two transforms (rotation entries and position).
inline double transform_distance(const wbm::Transform& a, const wbm::Transform& b) {
  return std::max((a.R - b.R).cwiseAbs().maxCoeff(), (a.p - b.p).cwiseAbs().maxCoeff());
}

}  // namespace wbm_test
