// Builds the paper model and prints the left hand position at the home configuration.
#include <iostream>

#include <wbm/kinematics.hpp>
#include <wbm/paper_model.hpp>

int main() {
  const wbm::Model model = wbm::make_paper_model();
  wbm::Data data(model);
  wbm::forward_kinematics(model, data, model.home());
  const wbm::Transform X = wbm::frame_pose(model, data, model.frame_index("l_hand_ref"));
  std::cout << model.name() << ": " << model.num_dofs() << " dofs, l_hand_ref at " << X.p.transpose() << " m\n";
  return 0;
}
