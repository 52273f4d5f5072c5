#!/usr/bin/env python3
"""Mutation check: does the unit-test suite fail when the library's rules are broken?

  python3 tests/mutation_check.py [--work DIR] [--only ID,ID,...] [--list] [--jobs N]

"A test that cannot fail is a defect": each case below changes one rule of the library (a
sign, a factor, a bound, a branch, a SIMD lane or loop tail, a model parameter) and the
unit tests (`ctest -L unit`) must then fail. The script copies the files git tracks (as
they are in the working tree, so uncommitted changes count) to a work directory (a temp
dir unless given; web/dist is copied too, which the configuration needs: run
scripts/setup.sh once first), builds there without the benchmarks, and then for each case
applies the change, rebuilds (libwbm and whatever includes a changed header) and runs the
unit tests, stopping at the first failure. Prints a line per case, KILLED (with the first
failing tests) or SURVIVED, and exits 1 if any case survived or a case no longer applies
(its text not found exactly once: update the case with the code). About 8 s per case on a
2-core machine after a build of 3-4 minutes (20 minutes for the 123); not a CTest for that reason.

The 123 cases (24 files) were written in the thirty-fifth session. Their first runs found
nine that no test caught, not even the longer CTests (random scenarios and the rest): the
squared-distance criterion's gradient (never checked against its cost), a filter switched on
while its value moves and rows switched on beside active ones (both started at rest), the
balance law's dead zone, near-unit vectors left unnormalised, a target receding faster than
the walk (read as a stall; the runner's target_changed() masked it), a walk that only turns
(its feet left unturned), the extra inverse-iteration step of independent blocks of rows,
an external velocity stopped at a limit still fed to the tasks as x_bal (without braking);
each now has a test. One more case could not be told from the original by any run (the
walking converge timer paused while the heel is held): that condition was dead and is gone.
Standard library only.
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# (id, file, text, replacement): `text` must occur exactly once in the file.
CASES = [
    # src/solver.cpp
    ('factor_pivot', 'src/solver.cpp',
     'pivot_[j1] -= l * e;',
     'pivot_[j1] -= 0.5 * l * e;'),
    ('factor_tiny', 'src/solver.cpp',
     'const double tiny = 1e-13 * std::max',
     'const double tiny = 1e-3 * std::max'),
    ('weight_g', 'src/solver.cpp',
     'w_[i] = free_[i] ? range_sq_[i] : 0.0;',
     'w_[i] = free_[i] ? 1.0 : 0.0;'),
    ('null_gain', 'src/solver.cpp',
     'out_.qdot_null *= -parameters_.nullspace_gain;',
     'out_.qdot_null *= -0.5 * parameters_.nullspace_gain;'),
    ('mu2_const', 'src/solver.cpp',
     'mu2 = effective_damping_factor_ * max2 * (1.0 - std::max(lambda_min, 0.0) / eps2);',
     'mu2 = effective_damping_factor_ * max2;'),
    ('extra_step', 'src/solver.cpp',
     'if (lambda_min < 4.0 * eps2 && 1.0 - cosine * cosine > kSettledIterate)',
     'if (false && lambda_min < 4.0 * eps2 && 1.0 - cosine * cosine > kSettledIterate)'),
    ('task_bound', 'src/solver.cpp',
     'if (task_rhs2 < lambda_min * lambda_min * task_solution2)',
     'if (false && task_rhs2 < lambda_min * lambda_min * task_solution2)'),
    ('null_scale_floor', 'src/solver.cpp',
     's = std::min(s, std::max(bound, 0.0));',
     's = std::min(s, std::max(bound, 0.5));'),
    ('task_scale_loose', 'src/solver.cpp',
     'if (v > vmax[i]) task_scale = std::min(task_scale, vmax[i] / v);',
     'if (v > vmax[i]) task_scale = std::min(task_scale, 1.1 * vmax[i] / v);'),
    ('jerk_off', 'src/solver.cpp',
     'double s = hi;\n',
     'double s = scale;\n'),
    ('brake_unapplied', 'src/solver.cpp',
     '      out_.qdot[i] = rate;\n',
     '      out_.qdot[i] = v;\n'),
    ('freeze_strict', 'src/solver.cpp',
     '((*q)[i] <= model_.lower_limits()[i] && v < 0.0)',
     '((*q)[i] < model_.lower_limits()[i] && v < 0.0)'),
    ('no_clamp', 'src/solver.cpp',
     'const double clamped = std::clamp(x, model.lower_limits()[i], model.upper_limits()[i]);',
     'const double clamped = x;'),
    ('no_raise', 'src/solver.cpp',
     'damping_factor_ = std::min(kDampingFactorStep * effective_damping_factor_, kMaxDampingFactor);',
     'damping_factor_ = 1.0;'),
    ('w_unweighted', 'src/solver.cpp',
     'range_[i] = model.dof(i).work_range;',
     'range_[i] = 1.0;'),
    ('w_sqrt', 'src/solver.cpp',
     'range_sq_[i] = range_[i] * range_[i];',
     'range_sq_[i] = range_[i];'),
    ('brake_time', 'src/solver.cpp',
     'braking_time_per_rate_[i] = 1.0 / (parameters.nullspace_rate_change_limit',
     'braking_time_per_rate_[i] = 0.5 / (parameters.nullspace_rate_change_limit'),
    # src/controller.cpp
    ('ctl_rate_step', 'src/controller.cpp',
     'const double step = rate_limit * vmax[i] * dt;',
     'const double step = 2.0 * rate_limit * vmax[i] * dt;'),
    ('ctl_xbal_sign', 'src/controller.cpp',
     'stack_.task_velocity().noalias() -= stack_.jacobian() * external_;',
     'stack_.task_velocity().noalias() += stack_.jacobian() * external_;'),
    ('ctl_ext_frozen', 'src/controller.cpp',
     'if (!command.free_dofs[i]) v = std::clamp(',
     'if (false) v = std::clamp('),
    ('ctl_period', 'src/controller.cpp',
     'commanded_[t0 + k] = from + std::remainder(commanded_[t0 + k] - from, period);',
     'commanded_[t0 + k] = from + (commanded_[t0 + k] - from);'),
    ('ctl_reset_rate', 'src/controller.cpp',
     '    if (active && !was_active_[i]) {\n      filters_[i].reset(values_.segment(t0, n), value_rates_.segment(t0, n));',
     '    if (active && !was_active_[i]) {\n      filters_[i].reset(values_.segment(t0, n), 0.0 * value_rates_.segment(t0, n));'),
    ('ctl_zero_dir', 'src/controller.cpp',
     '(e.target_kind() != TargetKind::kDirection || target.squaredNorm() > 1e-18);',
     'true;'),
    ('ctl_partial_reset', 'src/controller.cpp',
     'filters_[i].reset_component(r, values_[t0 + r], value_rates_[t0 + r]);',
     'filters_[i].reset_component(r, values_[t0 + r], 0.0);'),
    ('ctl_invalid_keep', 'src/controller.cpp',
     '      copy_entries(target.data(), n, commanded_.data() + t0);\n    } else if (active) {',
     '      copy_entries(target.data(), n, commanded_.data() + t0);\n    } else if (false) {'),
    # src/trajectory_filter.cpp
    ('filter_reset_vel', 'src/trajectory_filter.cpp',
     'for (int k = 0; k < n; ++k) stages_.col(k) = value + (n - 1 - k) * velocity / w;',
     'for (int k = 0; k < n; ++k) stages_.col(k) = value;'),
    ('filter_speed3', 'src/trajectory_filter.cpp',
     'if (fraction * fraction * distance2 <= max_step * max_step) {',
     'if (true) {'),
    ('filter_dir_speed', 'src/trajectory_filter.cpp',
     'const double step = std::min(angle * fraction, max_step);',
     'const double step = angle * fraction;'),
    ('filter_slerp_limit', 'src/trajectory_filter.cpp',
     'stage1_v_limit_ = std::min(kSlerpMaxV, 4.0 * half_chord * half_chord);',
     'stage1_v_limit_ = kSlerpMaxV;'),
    ('filter_velocity', 'src/trajectory_filter.cpp',
     'velocity_.head<3>() = (last - value_.head<3>()) * inverse_dt;',
     'velocity_.head<3>() = (last - value_.head<3>()) * (0.5 * inverse_dt);'),
    ('filter_speedN', 'src/trajectory_filter.cpp',
     'if (!(fraction * fraction * distance2 <= max_step * max_step))',
     'if (false)'),
    # src/tasks/axis_task.cpp
    ('axis_rate_swap', 'src/tasks/axis_task.cpp',
     'rate << x_sl.dot(w), y_sl.dot(w);',
     'rate << y_sl.dot(w), x_sl.dot(w);'),
    ('axis_ref_sign', 'src/tasks/axis_task.cpp',
     'u, v, -1.0, J);',
     'u, v, 1.0, J);'),
    ('axis_fallback', 'src/tasks/axis_task.cpp',
     'y = s > 1e-12 ? Vector3(c * (1.0 / s))',
     'y = s > 1e-2 ? Vector3(c * (1.0 / s))'),
    # src/kinematics.cpp
    ('pj_cross', 'src/kinematics.cpp',
     'Vector3(a.cross(p_WQ - data.X_WB[b].p))',
     'Vector3((p_WQ - data.X_WB[b].p).cross(a))'),
    ('com_prismatic', 'src/kinematics.cpp',
     'add(w.col(B.dof), B.multiplier * inv_mass * subtree_mass[b], a);',
     'add(w.col(B.dof), B.multiplier * inv_mass, a);'),
    ('fk_prismatic_offset', 'src/kinematics.cpp',
     'X.p += data.a_W[b] * (body.multiplier * q[body.dof] + body.offset);',
     'X.p += data.a_W[b] * (body.multiplier * q[body.dof]);'),
    ('fk_axis_code_neg', 'src/kinematics.cpp',
     ': code < 0 ? Vector3(-base->col(-code - 1))',
     ': code < 0 ? Vector3(base->col(-code - 1))'),
    ('kin_rot_jac', 'src/kinematics.cpp',
     '    if (B.joint_type == JointType::kRevolute) add(w.col(B.dof), B.multiplier, data.a_W[b]);',
     '    if (B.joint_type == JointType::kRevolute) add(w.col(B.dof), 1.0, data.a_W[b]);'),
    ('frame_jac_rot', 'src/kinematics.cpp',
     '      add(w.col(B.dof) + 3, B.multiplier, a);',
     '      add(w.col(B.dof) + 3, 1.0, a);'),
    # src/task_element.cpp
    ('rel_change', 'src/task_element.cpp',
     'Vector3((p_WQ - data.X_WB[b].p).cross(a))',
     'Vector3(a.cross(p_WQ - data.X_WB[b].p))'),
    ('rel_prismatic', 'src/task_element.cpp',
     ': Vector3(-a);',
     ': Vector3(a);'),
    # src/nullspace_criterion.cpp
    ('cubic_scale', 'src/nullspace_criterion.cpp',
     'gradient_scale_ = 3.0 / std::pow(1.0 - band_, 3);',
     'gradient_scale_ = 2.0 / std::pow(1.0 - band_, 3);'),
    ('center_grad', 'src/nullspace_criterion.cpp',
     '/ half_range_.array().square()).matrix();',
     '/ half_range_.array()).matrix();'),
    # src/task_stack.cpp
    ('clamp_sqrt', 'src/task_stack.cpp',
     'const double clamped = limit / std::sqrt(squared);',
     'const double clamped = limit / squared;'),
    ('no_feedforward', 'src/task_stack.cpp',
     'xdot_[active_rows_] = feed_forward_[r] + gain * errors_[r];',
     'xdot_[active_rows_] = gain * errors_[r];'),
    ('stack_partial_row', 'src/task_stack.cpp',
     'if (!all) J_.row(active_rows_) = J_full_.row(r);',
     'if (!all) J_.row(active_rows_) = J_full_.row(r0);'),
    ('stack_clamp_off', 'src/task_stack.cpp',
     'if (gain * gain * squared > limit * limit) [[unlikely]] {',
     'if (false) {'),
    # src/balance.cpp
    ('bal_sign', 'src/balance.cpp',
     'return gain_ * (support.centroid() - com);',
     'return gain_ * (com - support.centroid());'),
    ('bal_margin', 'src/balance.cpp',
     'support.signed_distance(com) >= margin_) return',
     'support.signed_distance(com) >= 0.0) return'),
    ('bal_heel_frame', 'src/balance.cpp',
     'Vector2 v_H = R_WH.topLeftCorner<2, 2>().transpose() * v_W;',
     'Vector2 v_H = v_W;'),
    ('bal_limit_flag', 'src/balance.cpp',
     'return v > 0.0 && q >= d.upper - 1e-6 ? 1 : v < 0.0 && q <= d.lower + 1e-6 ? -1 : 0;',
     'return v > 0.0 && q >= d.upper - 1e-6 ? 1 : 0;'),
    ('bal_saturate', 'src/balance.cpp',
     'const double scale = std::min({1.0, vx /',
     'const double scale = std::min({2.0, vx /'),
    # src/walking.cpp
    ('walk_back_full', 'src/walking.cpp',
     'd.x() = std::clamp(d.x(), -0.5 * p_.max_step_length, p_.max_step_length);',
     'd.x() = std::clamp(d.x(), -p_.max_step_length, p_.max_step_length);'),
    ('walk_hysteresis', 'src/walking.cpp',
     '(holding_ && lead > max_lead - 0.5 * p_.max_step_length)',
     '(holding_ && lead > max_lead)'),
    ('walk_far', 'src/walking.cpp',
     'const bool far = lead > 2.0 * p_.max_step_length || holding_;',
     'const bool far = holding_;'),
    ('walk_width', 'src/walking.cpp',
     'd.y() = side * std::clamp(side * d.y(), p_.min_step_width, p_.max_step_width);',
     'd.y() = std::clamp(d.y(), -p_.max_step_width, p_.max_step_width);'),
    ('walk_turn', 'src/walking.cpp',
     'const double turn = std::clamp(wrap(target.yaw - support.yaw), -p_.max_step_turn, p_.max_step_turn);',
     'const double turn = wrap(target.yaw - support.yaw);'),
    ('walk_brake', 'src/walking.cpp',
     'heel_brake_[k] = std::abs(v) <= fall ? 0.0 : v - std::copysign(fall, v);',
     'heel_brake_[k] = 0.0;'),
    ('walk_stall_band', 'src/walking.cpp',
     'if (error < best_error_ * 0.99 || error > best_error_ * 1.01) {',
     'if (error < best_error_ * 0.99) {'),
    ('walk_trigger_error', 'src/walking.cpp',
     'const bool wanted = error > 1.0 && (limit || cost || stalled);',
     'const bool wanted = (limit || cost || stalled);'),
    ('walk_no_progress', 'src/walking.cpp',
     'walks_without_progress_ = error > 0.9 * error_at_trigger_ ? walks_without_progress_ + 1 : 0;',
     'walks_without_progress_ = 0;'),
    ('walk_feet_at_yaw', 'src/walking.cpp',
     'std::abs(wrap(l.yaw - left_.yaw)) < 2 * tol && std::abs(wrap(r.yaw - right_.yaw)) < 2 * tol;',
     'true;'),
    ('walk_alternate', 'src/walking.cpp',
     '      next_left_ = !next_left_;\n',
     '\n'),
    # src/unit_row_elimination.cpp
    ('elim_damped_grad', 'src/unit_row_elimination.cpp',
     'const double c = range[d] * gradient[d] * mu2(k) / (h_[k] * h_[k] + mu2(k));',
     'const double c = range[d] * gradient[d] * mu2(k) / (h_[k] * h_[k] + 2.0 * mu2(k));'),
    ('elim_task_entry', 'src/unit_row_elimination.cpp',
     'return (mu2 * coupling_dot(k, y_kept) + h_[k] * xdot[row_[k]]) / (h_[k] * h_[k] + mu2);',
     'return (h_[k] * xdot[row_[k]]) / (h_[k] * h_[k] + mu2);'),
    ('elim_expand', 'src/unit_row_elimination.cpp',
     ': (f[row_[k]] - h_[k] * coupling_dot(k, z)) / dd;',
     ': (f[row_[k]] - h_[k] * coupling_dot(k, z)) / (dd + mu2);'),
    ('elim_null_entry', 'src/unit_row_elimination.cpp',
     'return mu2 * (scaled_gradient - coupling_dot(k, u_kept)) / (h_[k] * h_[k] + mu2);',
     'return 0.0 * scaled_gradient * u_kept[0];'),
    ('elim_isolated', 'src/unit_row_elimination.cpp',
     'const bool isolated = (bits << 1) == 0;',
     'const bool isolated = false;'),
    # src/dot_kernels.cpp
    ('gram_portable', 'src/dot_kernels.cpp',
     'A[j1 * lda + i] = s[1];',
     'A[j1 * lda + i] = s[2];'),
    ('solves_portable', 'src/dot_kernels.cpp',
     'X[4 * i + r] *= inv_d[i];',
     'X[4 * i + r] *= inv_d[m - 1 - i];'),
    # src/fast_trig.hpp
    ('asin_series', 'src/fast_trig.hpp',
     'const double q0 = 1.0 + y * (1.0 / 6)',
     'const double q0 = 1.0 + y * (1.0 / 5)'),
    ('near_unit', 'src/fast_trig.hpp',
     'if (std::abs(length2 - 1.0) <= 1e-8) return v * (1.5 - 0.5 * length2);',
     'if (std::abs(length2 - 1.0) <= 1e-8) return v;'),
    # src/model.cpp
    ('subtree_mass', 'src/model.cpp',
     'if (m.bodies_[b].parent >= 0) m.subtree_mass_[m.bodies_[b].parent] += m.subtree_mass_[b];',
     'if (m.bodies_[b].parent >= 0) m.subtree_mass_[m.bodies_[b].parent] += 0.0;'),
    ('home_lower', 'src/model.cpp',
     'for (int d = 0; d < nq; ++d) home_[d] = m.dofs_[d].center();',
     'for (int d = 0; d < nq; ++d) home_[d] = m.dofs_[d].lower;'),
    ('work_range_half', 'src/model.cpp',
     'if (!(dof.work_range > 0.0)) dof.work_range = dof.upper - dof.lower;',
     'if (!(dof.work_range > 0.0)) dof.work_range = 0.5 * (dof.upper - dof.lower);'),
    # src/row_blocks.cpp
    ('blocks_none', 'src/row_blocks.cpp',
     'if (A[i + j * lda] != 0.0) unite(i, j);',
     'if (A[i + j * lda] > 0.0) unite(i, j);'),
    ('blocks_coupling', 'src/row_blocks.cpp',
     '        unite(j, first);',
     '        (void)first;'),
    # src/paper_model.cpp
    ('paper_elbow_axis', 'src/paper_model.cpp',
     '{"forearm", revolute("elbow", -2.4, 0.0, 3.0), {0.0, 0.0, -kUpperArm}, Vector3::UnitY(),',
     '{"forearm", revolute("elbow", -2.4, 0.0, 3.0), {0.0, 0.0, -kUpperArm}, Vector3::UnitX(),'),
    ('paper_hand_axis', 'src/paper_model.cpp',
     '{"hand", revolute("hand_rot", -1.7, 1.7, 4.0), {0.0, 0.0, -kForearm}, Vector3::UnitZ(),',
     '{"hand", revolute("hand_rot", -1.7, 1.7, 4.0), {0.0, 0.0, -kForearm}, Vector3::UnitY(),'),
    ('paper_grasp_dir', 'src/paper_model.cpp',
     'ref.X_BF.R = Eigen::AngleAxisd(M_PI / 2, Vector3::UnitY()).toRotationMatrix();',
     'ref.X_BF.R = Eigen::AngleAxisd(-M_PI / 2, Vector3::UnitY()).toRotationMatrix();'),
    ('paper_camera', 'src/paper_model.cpp',
     'camera.X_BF.R = Eigen::AngleAxisd(M_PI / 2, Vector3::UnitY()).toRotationMatrix();',
     'camera.X_BF.R = Eigen::AngleAxisd(M_PI / 2, Vector3::UnitX()).toRotationMatrix();'),
    ('paper_roll_mirror', 'src/paper_model.cpp',
     'const double roll_lower = side > 0 ? -0.35 : -1.05;',
     'const double roll_lower = side > 0 ? -1.05 : -1.05;'),
    ('paper_tilt_axis', 'src/paper_model.cpp',
     'head.axis = Vector3::UnitY();',
     'head.axis = Vector3::UnitX();'),
    # src/rate_checks.hpp
    ('rc_exceeds_tail', 'src/rate_checks.hpp',
     '  for (; i < n; ++i) exceeded |= std::abs(x[i]) > bound[i];',
     '  for (; false;) exceeded |= std::abs(x[i]) > bound[i];'),
    ('rc_exceeds_lane', 'src/rate_checks.hpp',
     '    any = _mm_or_pd(any, _mm_cmpgt_pd(abs_lanes(_mm_loadu_pd(x + i)), _mm_loadu_pd(bound + i)));\n  exceeded = _mm_movemask_pd(any) != 0;',
     '    any = _mm_or_pd(any, _mm_cmpgt_pd(abs_lanes(_mm_loadu_pd(x + i)), _mm_loadu_pd(bound + i)));\n  exceeded = (_mm_movemask_pd(any) & 1) != 0;'),
    ('rc_combination_lane', 'src/rate_checks.hpp',
     '    any = _mm_or_pd(any, _mm_cmpgt_pd(abs_lanes(v), _mm_mul_pd(vs, _mm_loadu_pd(bound + i))));\n  }\n  exceeded = _mm_movemask_pd(any) != 0;',
     '    any = _mm_or_pd(any, _mm_cmpgt_pd(abs_lanes(v), _mm_mul_pd(vs, _mm_loadu_pd(bound + i))));\n  }\n  exceeded = (_mm_movemask_pd(any) & 1) != 0;'),
    ('rc_rate_change_lane', 'src/rate_checks.hpp',
     '    any = _mm_or_pd(any, _mm_cmpgt_pd(abs_lanes(d), _mm_mul_pd(k, _mm_loadu_pd(vmax + i))));\n  }\n  exceeded = _mm_movemask_pd(any) != 0;',
     '    any = _mm_or_pd(any, _mm_cmpgt_pd(abs_lanes(d), _mm_mul_pd(k, _mm_loadu_pd(vmax + i))));\n  }\n  exceeded = (_mm_movemask_pd(any) & 1) != 0;'),
    ('rc_outwards_lane', 'src/rate_checks.hpp',
     '  outwards = _mm_movemask_pd(any) != 0;',
     '  outwards = (_mm_movemask_pd(any) & 1) != 0;'),
    ('rc_close_lane', 'src/rate_checks.hpp',
     '  close = _mm_movemask_pd(any) != 0;',
     '  close = (_mm_movemask_pd(any) & 1) != 0;'),
    ('rc_close_tail', 'src/rate_checks.hpp',
     '    close |= (reach > upper[i]) | (reach < lower[i]);',
     '    close |= (reach > upper[i]);'),
    ('rc_close_time', 'src/rate_checks.hpp',
     'const __m128d time = _mm_max_pd(_mm_mul_pd(abs_lanes(rate), _mm_loadu_pd(t + i)), vdt);',
     'const __m128d time = vdt;'),
    # src/braking.hpp
    ('brake_no_landing', 'src/braking.hpp',
     'const double rate = distance > 0.0 ? std::min(std::sqrt(k_vmax * distance), distance / dt) : 0.0;',
     'const double rate = distance > 0.0 ? std::sqrt(k_vmax * distance) : 0.0;'),
    ('brake_harder_limit', 'src/braking.hpp',
     'const double rate = distance > 0.0 ? std::min(std::sqrt(k_vmax * distance), distance / dt) : 0.0;',
     'const double rate = distance > 0.0 ? std::min(std::sqrt(2.0 * k_vmax * distance), distance / dt) : 0.0;'),
    ('brake_trigger', 'src/braking.hpp',
     'if (v == 0.0 || !(v * v > k_vmax * distance || std::abs(v) * dt > distance)) return v;',
     'if (v == 0.0 || !(v * v > k_vmax * distance)) return v;'),
    # src/urdf_import.cpp
    ('urdf_mimic_mult', 'src/urdf_import.cpp',
     'body.multiplier = joint.mimic->multiplier;',
     'body.multiplier = 1.0;'),
    ('urdf_mimic_offset', 'src/urdf_import.cpp',
     'body.offset = joint.mimic->offset;',
     'body.offset = 0.0;'),
    ('urdf_reversed_axis', 'src/urdf_import.cpp',
     'spec.body.axis = -axis;',
     'spec.body.axis = axis;'),
    ('urdf_speed_default', 'src/urdf_import.cpp',
     'dof.max_speed = joint.limits && joint.limits->velocity > 0.0 ? joint.limits->velocity : default_speed;',
     'dof.max_speed = default_speed;'),
    # A second list of the same session: damping of independent blocks and isolated rows,
    # the raised damping, external velocities, attitude elements, exports, model checks.
    # src/solver.cpp
    ('blocks_mu2', 'src/solver.cpp',
     'mu2[b] = lambda[b] < eps2 ? max2 * (1.0 - std::max(lambda[b], 0.0) / eps2) : 0.0;',
     'mu2[b] = lambda[b] < eps2 ? max2 : 0.0;'),
    ('blocks_extra_step', 'src/solver.cpp',
     '    if (turning) block_iteration_step(m, blocks, shift);',
     '    (void)turning;'),
    ('blocks_task_scale', 'src/solver.cpp',
     'if (dof_block_[i] >= 0 && v > vmax[i]) scale[dof_block_[i]] = std::min(scale[dof_block_[i]], vmax[i] / v);',
     'if (dof_block_[i] >= 0 && v > vmax[i]) scale[0] = std::min(scale[0], vmax[i] / v);'),
    ('isolated_damping', 'src/solver.cpp',
     'return h2 < eps2 ? raised_max2 * (1.0 - h2 / eps2) : 0.0;',
     'return 0.0 * h2;'),
    ('clamp_flag', 'src/solver.cpp',
     '      flags |= kJointLimitClamped;',
     '      flags |= 0;'),
    ('raised_hold', 'src/solver.cpp',
     'const double rate = std::min(1.0, xdot.norm() / raised_at_rate_);',
     'const double rate = 1.0;'),
    ('damping_turn', 'src/solver.cpp',
     '(noticeable && a > 0.5 * b && out_.qdot.dot(previous_qdot_) < -0.5 * a * b)',
     '(noticeable && a > 0.5 * b && out_.qdot.dot(previous_qdot_) < -0.99 * a * b)'),
    ('jerk_skip_frozen', 'src/solver.cpp',
     'out_.nullspace_scale > 0.0 && !frozen_set_changed) {',
     'out_.nullspace_scale > 0.0) {'),
    # src/controller.cpp
    ('ctl_wrap_rate', 'src/controller.cpp',
     'value_rates_[k] = std::remainder(values_[k] - previous_values_[k], period) * (1.0 / dt);',
     'value_rates_[k] = (values_[k] - previous_values_[k]) * (1.0 / dt);'),
    ('ctl_ext_speed', 'src/controller.cpp',
     'if (solver_parameters_.limit_speeds) v = std::clamp(v, -vmax, vmax);',
     'if (false) v = std::clamp(v, -vmax, vmax);'),
    ('ctl_ext_clamp', 'src/controller.cpp',
     'external_[i] = (std::clamp(q_[i] + v * dt, lower, upper) - q_[i]) / dt;',
     'external_[i] = v;'),
    # src/tasks/attitude_task.cpp
    ('att_canonical', 'src/tasks/attitude_task.cpp',
     'return {angles.x() + M_PI, std::copysign(M_PI, b) - b, angles.z() + M_PI};',
     'return angles;'),
    ('att_rate', 'src/tasks/attitude_task.cpp',
     'rate = E_inv * (kardan_rate_matrix(t) * Vector3(target_rate));',
     'rate = target_rate;'),
    ('att_partial_sign', 'src/tasks/attitude_task.cpp',
     'if (t.y() != target[1]) rate[1] = -target_rate[1];',
     'if (false) rate[1] = -target_rate[1];'),
    ('att_einv', 'src/tasks/attitude_task.cpp',
     'E_inv << 1.0, sa * sb / cb, -ca * sb / cb, 0.0, ca, sa, 0.0, -sa / cb, ca / cb;',
     'E_inv << 1.0, sa * sb / cb, -ca * sb / cb, 0.0, ca, sa, 0.0, sa / cb, ca / cb;'),
    # src/task_element.cpp
    ('rel_rot_sub', 'src/task_element.cpp',
     '    col[0] -= a.x();\n    col[1] -= a.y();\n    col[2] -= a.z();',
     '    col[0] -= a.x();\n    col[1] -= a.y();\n    col[2] -= 0.0 * a.z();'),
    # src/tasks/com_task.cpp
    ('com_rel_value', 'src/tasks/com_task.cpp',
     'x = X_WR.R.transpose() * (data.p_WCm - X_WR.p);',
     'x = data.p_WCm - X_WR.p;'),
    # src/tasks/joint_task.cpp
    ('joint_err', 'src/tasks/joint_task.cpp',
     'error[i] = target[i] - data.q[dofs_[i]];',
     'error[i] = target[i] - data.q[dofs_[0]];'),
    # src/trajectory_filter.cpp
    ('filter_order_reset', 'src/trajectory_filter.cpp',
     'for (int k = 0; k < n; ++k) stages_(i, k) = value + (n - 1 - k) * velocity / parameters_.bandwidth;',
     'for (int k = 0; k < n; ++k) stages_(i, k) = value + (n - 1) * velocity / parameters_.bandwidth;'),
    ('filter_dir_reset', 'src/trajectory_filter.cpp',
     'const Vector3 rv = omega * ((n - 1 - k) / w);',
     'const Vector3 rv = omega * ((n - 1 - k) / (2.0 * w));'),
    # src/fast_trig.hpp
    ('anchor_window', 'src/fast_trig.hpp',
     '  if (std::abs(d) <= kSeriesRange) {\n    double sin_d, cos_d_minus_1;',
     '  if (std::abs(d) <= 4.0 * kSeriesRange) {\n    double sin_d, cos_d_minus_1;'),
    # src/urdf_export.cpp
    ('export_axis', 'src/urdf_export.cpp',
     'vec(body.axis)',
     'vec(-body.axis)'),
    # src/model.cpp
    ('model_limits_check', 'src/model.cpp',
     'if (q[i] < d.lower - 1e-9 || q[i] > d.upper + 1e-9) {',
     'if (q[i] < d.lower - 1e-9) {'),
    # src/balance.cpp
    ('support_centroid', 'src/balance.cpp',
     'poly.centroid_ = std::abs(area) > 1e-12 ? Vector2(c / (3.0 * area))',
     'poly.centroid_ = std::abs(area) > 1e-12 ? Vector2(c / (6.0 * area))'),
]

def run(command, cwd, timeout=None):
    return subprocess.run(command, cwd=cwd, shell=True, capture_output=True, text=True, timeout=timeout)


def copy_tree(work):
    """The files git tracks, from the working tree, and web/dist (built, not tracked). Into a
    work directory used before only the files that differ, with a new time stamp, so that
    make rebuilds what they changed and nothing else."""
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    for name in files.decode().split("\0"):
        source, target = os.path.join(ROOT, name), os.path.join(work, name)
        if not name or not os.path.isfile(source):
            continue
        if os.path.isfile(target):
            with open(source, "rb") as a, open(target, "rb") as b:
                if a.read() == b.read():
                    continue
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copy(source, target)
    dist = os.path.join(ROOT, "web", "dist")
    if not os.path.isfile(os.path.join(dist, "report_template.html")):
        sys.exit("mutation_check: web/dist/report_template.html is missing: run scripts/setup.sh "
                 "(or `cd web && npm ci && node build.mjs`) first")
    shutil.copytree(dist, os.path.join(work, "web", "dist"), dirs_exist_ok=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--work", help="work directory (kept); default a temp dir, removed at the end")
    parser.add_argument("--only", help="comma-separated case ids")
    parser.add_argument("--list", action="store_true", help="list the cases and exit")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    ids = [c[0] for c in CASES]
    if len(set(ids)) != len(ids):
        sys.exit("mutation_check: duplicate case ids")
    if args.list:
        for c in CASES:
            print(f"{c[0]:24s} {c[1]}")
        return 0
    cases = CASES
    if args.only:
        wanted = args.only.split(",")
        unknown = [w for w in wanted if w not in ids]
        if unknown:
            sys.exit(f"mutation_check: unknown case ids: {', '.join(unknown)} (--list shows them)")
        cases = [c for c in CASES if c[0] in wanted]

    work = args.work or tempfile.mkdtemp(prefix="wbm_mutation_")
    copy_tree(work)
    build = os.path.join(work, "build")
    print(f"mutation_check: building in {build} ...", flush=True)
    started = time.time()
    configure = run("cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DWBM_BUILD_BENCHMARKS=OFF "
                    "-DCMAKE_LINK_DEPENDS_NO_SHARED=ON", work)
    if configure.returncode != 0:
        sys.exit("mutation_check: cmake failed:\n" + configure.stdout[-2000:] + configure.stderr[-2000:])
    made = run(f"make -j{args.jobs}", build)
    if made.returncode != 0:
        sys.exit("mutation_check: the unmutated build failed:\n" + made.stdout[-3000:] + made.stderr[-3000:])
    clean = run(f"ctest -j{args.jobs} -L unit --timeout 120", build)
    if clean.returncode != 0:
        sys.exit("mutation_check: the unit tests fail without a mutation:\n" + clean.stdout[-3000:])
    print(f"mutation_check: built and tested in {time.time() - started:.0f} s; {len(cases)} cases", flush=True)

    survived, stale = [], []
    for k, (case, name, text, replacement) in enumerate(cases, 1):
        path = os.path.join(work, name)
        with open(path) as f:
            original = f.read()
        if original.count(text) != 1:
            stale.append(case)
            print(f"[{k}/{len(cases)}] {case}: STALE (its text occurs {original.count(text)} times in {name})",
                  flush=True)
            continue
        t0 = time.time()
        try:
            with open(path, "w") as f:
                f.write(original.replace(text, replacement))
            made = run(f"make -j{args.jobs}", build)
            if made.returncode != 0:
                verdict, detail = "KILLED", "(does not build)"
            else:
                tested = run(f"ctest -j{args.jobs} -L unit --timeout 120 --stop-on-failure", build, timeout=1800)
                failing = [line.split(":", 1)[1].split("...")[0].strip() for line in tested.stdout.splitlines()
                           if "***Failed" in line or "***Timeout" in line or "***Exception" in line]
                verdict = "KILLED" if tested.returncode != 0 else "SURVIVED"
                detail = ", ".join(failing[:2])
        finally:
            with open(path, "w") as f:
                f.write(original)
        if verdict == "SURVIVED":
            survived.append(case)
        print(f"[{k}/{len(cases)}] {case} ({name}): {verdict} {detail} [{time.time() - t0:.0f} s]", flush=True)
    run(f"make -j{args.jobs}", build)  # leave the work tree built as it is
    print(f"mutation_check: {len(cases) - len(survived) - len(stale)} of {len(cases)} cases killed; "
          f"survived: {', '.join(survived) or 'none'}; stale: {', '.join(stale) or 'none'}")
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if survived or stale else 0


if __name__ == "__main__":
    sys.exit(main())
