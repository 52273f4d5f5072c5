// A controller on a shipped model for a number of cycles, to be traced under valgrind's
// lackey by bench/forwarding_stalls.py: the fixtures' elements (both hands position and
// grasp axis, the head's view axis), the heel frozen, moving targets. Before each cycle it
// calls a marker (so that the script finds where the cycles begin) and a function with one
// planted failed store-to-load forwarding (which the script must find: its self-check).
//
// Usage: trace_cycle MODEL_ID [CYCLES]   (MODEL_ID: paper, g1_29dof, romeo_small, ...)
#include <dlfcn.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>

#include "shipped_models.hpp"
#include "wbm/controller.hpp"
#include "wbm/nullspace_criterion.hpp"
#include "wbm/tasks/axis_task.hpp"
#include "wbm/tasks/position_task.hpp"

extern "C" {
/// Called before every cycle; its address tells the script where a cycle begins.
__attribute__((noinline)) void wbm_trace_cycle_marker(int cycle) { asm volatile("" : : "r"(cycle)); }

/// Two 8-byte stores, then a 16-byte load of both: a failed store-to-load forwarding, once
/// per cycle, which the script's report must list (else its analysis is broken).
__attribute__((noinline)) double wbm_trace_planted_stall(double a, double b) {
  volatile double pair[2];
  pair[0] = a;
  pair[1] = b;
#if defined(__x86_64__)
  double sum;
  asm volatile(  // one 16-byte load of both (a compiler would load them one by one)
      "movupd %1, %%xmm0\n\t"
      "movapd %%xmm0, %%xmm1\n\t"
      "unpckhpd %%xmm1, %%xmm1\n\t"
      "addsd %%xmm1, %%xmm0\n\t"
      "movsd %%xmm0, %0"
      : "=m"(sum)
      : "m"(pair)
      : "xmm0", "xmm1");
  return sum;
#else
  return pair[0] + pair[1];  // the self-check needs an x86-64 core's 16-byte load
#endif
}
}

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) {
    std::fprintf(stderr, "usage: trace_cycle MODEL_ID [CYCLES]\n");
    return 2;
  }
  const int cycles = argc == 3 ? std::atoi(argv[2]) : 130;
  if (cycles < 1) {
    std::fprintf(stderr, "trace_cycle: CYCLES must be a positive number, got '%s'\n", argv[2]);
    return 2;
  }
  const wbm_test::ShippedModel* entry = nullptr;
  try {
    entry = &wbm_test::shipped_model(argv[1]);
  } catch (const std::out_of_range& e) {
    std::fprintf(stderr, "trace_cycle: %s\n", e.what());
    return 2;
  }
  const wbm::Model m = entry->load();
  wbm::Controller c(m);
  c.set_criterion(std::make_unique<wbm::CubicJointLimitCriterion>(m, 0.0));  // as the fixtures
  c.add_task(std::make_unique<wbm::PositionTask>(m, "l_pos", entry->left_hand));
  c.add_task(std::make_unique<wbm::PositionTask>(m, "r_pos", entry->right_hand));
  c.add_task(std::make_unique<wbm::AxisTask>(m, "l_axis", entry->left_hand));
  c.add_task(std::make_unique<wbm::AxisTask>(m, "r_axis", entry->right_hand));
  c.add_task(std::make_unique<wbm::AxisTask>(m, "view_axis", entry->head));
  c.reset(m.home());
  wbm::Command command = c.make_command();
  const wbm::VirtualDofs& v = m.virtual_dofs();
  for (int heel : {v.heel_x, v.heel_y, v.heel_yaw})
    if (heel >= 0) command.free_dofs[heel] = false;
  // Where the library and the two functions are in this process (under valgrind: the guest's
  // addresses, as in the trace).
  Dl_info library{};
  if (dladdr(reinterpret_cast<void*>(&wbm::forward_kinematics), &library) == 0 || library.dli_fname == nullptr) {
    std::fprintf(stderr, "trace_cycle: dladdr found no library for wbm::forward_kinematics\n");
    return 1;
  }
  std::printf("library %s base %p marker %p planted %p\n", library.dli_fname, library.dli_fbase,
              reinterpret_cast<void*>(&wbm_trace_cycle_marker), reinterpret_cast<void*>(&wbm_trace_planted_stall));
  const Eigen::VectorXd start = c.values();
  double sum = 0.0;
  for (int k = 0; k < cycles; ++k) {
    const double t = 0.001 * k;
    command.targets = start;
    for (int i = 0; i < 2; ++i)
      command.targets.segment<3>(3 * i) += 0.05 * Eigen::Vector3d(std::sin(3 * t), std::cos(2 * t) - 1, std::sin(t));
    for (int i = 0; i < 3; ++i) command.targets.segment<3>(6 + 3 * i) += 0.2 * Eigen::Vector3d(std::sin(2 * t), 0, 0);
    wbm_trace_cycle_marker(k);
    sum += wbm_trace_planted_stall(t, 2 * t);
    if (!c.update(command, 0.001).ok()) {
      std::fprintf(stderr, "trace_cycle: cycle %d failed\n", k);
      return 1;
    }
  }
  std::printf("done %d cycles (%g)\n", cycles, sum);
  return 0;
}
