// The README's library example, built and run by the tests: reach with the right hand and
// look somewhere else, on the built-in paper model.
#include <cstdio>
#include <memory>

#include <wbm/controller.hpp>
#include <wbm/paper_model.hpp>
#include <wbm/tasks/axis_task.hpp>
#include <wbm/tasks/position_task.hpp>

int main() {
  const wbm::Model model = wbm::make_paper_model();
  wbm::Controller controller(model);
  controller.add_task(std::make_unique<wbm::PositionTask>(model, "r_hand", "r_hand_ref"), {4.0, 0.4, 2});
  controller.add_task(std::make_unique<wbm::AxisTask>(model, "view", "head_camera"));
  controller.reset(model.home());
  wbm::Command command = controller.make_command();
  command.free_dofs.head(3).setConstant(false);
  command.targets.head<3>() << 0.45, -0.30, 1.02;
  command.targets.segment<3>(3) << 1.0, 0.5, -0.2;
  for (int k = 0; k < 3000; ++k) {
    const wbm::ControllerStatus status = controller.update(command, 0.001);
    if (!status.ok()) return 1;
  }
  const double error = (controller.values().head<3>() - command.targets.head<3>()).norm();
  std::printf("right hand error after 3 s: %.3g mm\n", error * 1e3);
  return error < 1e-3 ? 0 : 1;
}
