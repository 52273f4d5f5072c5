#!/usr/bin/env python3
"""Mutation check: does the unit-test suite fail when the library's rules are broken?

  python3 tests/mutation_check.py [--work DIR] [--only ID,ID,...] [--list] [--jobs N]

"A test that cannot fail is a defect": each case below changes one rule of the library or of
the command-line tool's code the unit tests cover (a sign, a factor, a bound, a branch, a SIMD
lane or loop tail, a model parameter) and the unit tests (`ctest -L unit`) must then fail.
The script copies the files git tracks (as they are in the working tree, so uncommitted
changes count; a new file must be added with `git add` first) to a work directory (a temp
dir unless given; web/dist is copied too, which the configuration needs: run
scripts/setup.sh once first), builds there without the benchmarks, and then for each case
applies the change, rebuilds (whatever the changed file is part of) and runs the unit tests,
stopping at the first failure. Prints a line per case, KILLED (with the first failing tests)
or SURVIVED, and exits 1 if any case survived or a case no longer applies (its text not
found exactly once: update the case with the code). About 8 s per case of src/ and 15-30 s
per case of apps/ on a 2-core machine after a build of 3-4 minutes (about an hour for the
232); not a CTest for that reason.

The first 123 cases (src/, 24 files) were written in the thirty-fifth session. Their first
runs found nine that no test caught, not even the longer CTests (random scenarios and the
rest): the squared-distance criterion's gradient (never checked against its cost), a filter
switched on while its value moves and rows switched on beside active ones (both started at
rest), the balance law's dead zone, near-unit vectors left unnormalised, a target receding
faster than the walk (read as a stall; the runner's target_changed() masked it), a walk that
only turns (its feet left unturned), the extra inverse-iteration step of independent blocks
of rows, an external velocity stopped at a limit still fed to the tasks as x_bal (without
braking); each now has a test. One more case could not be told from the original by any run
(the walking converge timer paused while the heel is held): that condition was dead and is
gone. The thirty-sixth session added 55 cases of the URDF import and the model builder and
44 of the command-line tool's code (apps/: scenario runner, reader, drawn legs, task and model
notes, report data, the CLI); 16 and 27 of them survived at first, among them the import's
inertials (never compared with anything), default limits, a locked leg's mimic offsets, a
test file whose comment named a rule it never reached, most of the run summary's numbers,
the report's targets and samples, and the output directory's write check (root writes
anywhere: its test now runs the tool without that capability); each now has a test. Its
last eleven walking cases left three survivors, cases since the thirty-seventh session with
a test each: the feet's position tolerance at a walk's end (no walk moved the heel by less
than three tolerances, so three times it passed), walking's error counting rows the stack
has not yet switched on (a stale error of a row switched on), and a walk triggered by a dof
frozen at its limit (not clamped). A loop check given ten times the steps was dropped as
equivalent (a loop is found either way).
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
    # A third list (thirty-sixth session): the URDF import's checks, soles, inertials, tree
    # and root placement, and the model's checks and precomputed tables.
    # src/urdf_import.cpp: the checker
    ('urdf_axis_tolerance', 'src/urdf_import.cpp',
     'constexpr double kAxisNormTolerance = 0.01;',
     'constexpr double kAxisNormTolerance = 0.1;'),
    ('urdf_unlimited_bound', 'src/urdf_import.cpp',
     'constexpr double kUnlimitedRevolute = 1e6;',
     'constexpr double kUnlimitedRevolute = 1e17;'),
    ('urdf_trailing_space', 'src/urdf_import.cpp',
     'if (count == 1 && !text.empty() && std::isspace(static_cast<unsigned char>(text.back())))',
     'if (false && count == 1 && !text.empty() && std::isspace(static_cast<unsigned char>(text.back())))'),
    ('urdf_whole_token', 'src/urdf_import.cpp',
     'const bool bad = number.fail() || !number.eof() || !std::isfinite(v);',
     'const bool bad = number.fail() || !std::isfinite(v);'),
    ('urdf_number_count', 'src/urdf_import.cpp',
     'if (values.size() != count)',
     'if (values.size() < count)'),
    ('urdf_magnitude_sign', 'src/urdf_import.cpp',
     'if (std::abs(v) > largest) {',
     'if (v > largest) {'),
    ('urdf_negative_mass', 'src/urdf_import.cpp',
     'if (m < 0.0) fail(mass->Row()',
     'if (m < -1.0) fail(mass->Row()'),
    ('urdf_zero_axis', 'src/urdf_import.cpp',
     'if (n < 1e-12) fail(axis->Row()',
     'if (n < 0.0) fail(axis->Row()'),
    ('urdf_limit_order', 'src/urdf_import.cpp',
     'if (bounded && lower > upper) {',
     'if (bounded && lower > upper + 1.0) {'),
    ('urdf_no_range', 'src/urdf_import.cpp',
     'if (bounded && lower == upper && j.mimic.empty() && !options_.default_limits)',
     'if (false && bounded && lower == upper && j.mimic.empty() && !options_.default_limits)'),
    ('urdf_zero_speed', 'src/urdf_import.cpp',
     'if (velocity <= 0.0 && j.mimic.empty() && !options_.default_limits)',
     'if (velocity < 0.0 && j.mimic.empty() && !options_.default_limits)'),
    ('urdf_self_loop', 'src/urdf_import.cpp',
     'if (j.parent == j.child) fail(',
     'if (false) fail('),
    ('urdf_xacro_skip', 'src/urdf_import.cpp',
     'if (!options_.ignore_xacro_elements)',
     'if (true)'),
    ('urdf_xacro_expression', 'src/urdf_import.cpp',
     'if (v.find("${") != std::string::npos || v.find("$(") != std::string::npos)\n',
     'if (v.find("$(") != std::string::npos)\n'),
    # src/urdf_import.cpp: soles, inertials, the tree
    ('urdf_capsule_radius', 'src/urdf_import.cpp',
     'const double depth = 0.5 * std::abs(X_RG.R(2, 2)) * k.length + k.radius;',
     'const double depth = 0.5 * std::abs(X_RG.R(2, 2)) * k.length;'),
    ('urdf_box_half', 'src/urdf_import.cpp',
     'depth = 0.5 * (std::abs(row(0)) * size.x + std::abs(row(1)) * size.y + std::abs(row(2)) * size.z);',
     'depth = 0.5 * size.z;'),
    ('urdf_cylinder_side', 'src/urdf_import.cpp',
     'cylinder.radius * std::sqrt(std::max(0.0, 1.0 - row(2) * row(2)));',
     '0.0;'),
    ('urdf_visual_always', 'src/urdf_import.cpp',
     'if (link.collision_array.empty() && collision_capsules.empty()) {',
     'if (true) {'),
    ('urdf_capsule_kind', 'src/urdf_import.cpp',
     "(kind[0] == 'c' ? collision_capsules_ : visual_capsules_)[name].push_back(k);",
     "(kind[0] == 'v' ? collision_capsules_ : visual_capsules_)[name].push_back(k);"),
    ('urdf_leg_primitives', 'src/urdf_import.cpp',
     'const double lowest = std::min(X_RL.p.z(), lowest_primitive_z(',
     'const double lowest = std::max(X_RL.p.z(), lowest_primitive_z('),
    ('urdf_inertia_turn', 'src/urdf_import.cpp',
     'in.inertia = X_BI.R * I * X_BI.R.transpose();',
     'in.inertia = I;'),
    ('urdf_parallel_axis', 'src/urdf_import.cpp',
     'return Matrix3(in.inertia + in.mass * (d.squaredNorm() * Matrix3::Identity() - d * d.transpose()));',
     'return Matrix3(in.inertia + in.mass * (d.squaredNorm() * Matrix3::Identity()));'),
    ('urdf_mimic_zero', 'src/urdf_import.cpp',
     'const Transform X_PC = X_PC0 * joint_motion(joint, joint.mimic ? joint.mimic->offset : 0.0);',
     'const Transform X_PC = X_PC0 * joint_motion(joint, 0.0);'),
    ('urdf_world_floating', 'src/urdf_import.cpp',
     'neighbours_.at(other).size() == 1;',
     'neighbours_.at(other).size() >= 1;'),
    ('urdf_reversed_pose', 'src/urdf_import.cpp',
     'X_BO = X_PC0.inverse();',
     'X_BO = X_PC0;'),
    ('urdf_default_range', 'src/urdf_import.cpp',
     'const double default_range = prismatic ? 1.0 : M_PI;',
     'const double default_range = prismatic ? 1.0 : 2.0;'),
    ('urdf_effort_negative', 'src/urdf_import.cpp',
     'std::max(joint.limits->effort, 0.0)',
     'joint.limits->effort'),
    ('urdf_world_root_mass', 'src/urdf_import.cpp',
     'if ((!root.inertial || root.inertial->mass == 0.0) && root.child_joints.size() == 1 &&',
     'if (root.child_joints.size() == 1 &&'),
    # src/urdf_import.cpp: where the root stands
    ('urdf_feet_root', 'src/urdf_import.cpp',
     'if (has_legs && std::abs(tree.lowest_leg_z_) < 0.1 * tree.leg_length_) {',
     'if (false && has_legs && std::abs(tree.lowest_leg_z_) < 0.1 * tree.leg_length_) {'),
    ('urdf_hips_down', 'src/urdf_import.cpp',
     'if (hips > 0.0 && hips - tree.lowest_leg_z_ >= 0.5 * tree.leg_length_) pivot = hips;',
     'if (hips > 0.0) pivot = hips;'),
    ('urdf_legs_down', 'src/urdf_import.cpp',
     'if (depth < 0.1 * tree.leg_length_) {',
     'if (depth < 0.001 * tree.leg_length_) {'),
    ('urdf_pivot_far', 'src/urdf_import.cpp',
     'if (depth > 2.0 * tree.leg_length_ && pivot_given) {',
     'if (depth > 20.0 * tree.leg_length_ && pivot_given) {'),
    ('urdf_height_legs', 'src/urdf_import.cpp',
     'height = -tree.lowest_leg_z_;',
     'height = -tree.lowest_leg_z_ + 0.01;'),
    ('urdf_cut_below', 'src/urdf_import.cpp',
     'if (cut_off && cut->second < -1e-3)',
     'if (cut_off && cut->second < -1e-1)'),
    ('urdf_stands_on', 'src/urdf_import.cpp',
     'return z - lowest_link <= std::max(highest_link - z, 1e-3);',
     'return true;'),
    ('urdf_footprint', 'src/urdf_import.cpp',
     'return link == "world" || link == "base_footprint";',
     'return link == "world";'),
    ('urdf_default_height', 'src/urdf_import.cpp',
     'if (std::isnan(height)) height = 1.0;',
     'if (std::isnan(height)) height = 0.5;'),
    ('urdf_rpy_bound', 'src/urdf_import.cpp',
     'if (!(rpy.array().abs() <= 2.0 * M_PI + 1e-6).all()) {',
     'if (!(rpy.array().abs() <= 4.0 * M_PI).all()) {'),
    ('urdf_leg_twice', 'src/urdf_import.cpp',
     'static_cast<std::ptrdiff_t>(k), leg) !=',
     'static_cast<std::ptrdiff_t>(k), leg) =='),
    ('urdf_added_frame_parent', 'src/urdf_import.cpp',
     'parent->second.X_BF * Transform{rotation_from_rpy(added.rpy.x(), added.rpy.y(), added.rpy.z()), added.xyz}};',
     'Transform{rotation_from_rpy(added.rpy.x(), added.rpy.y(), added.rpy.z()), added.xyz}};'),
    ('urdf_added_frame_whole', 'src/urdf_import.cpp',
     'if (used != value.size() || !std::isfinite(v[k])) throw ConfigError(expected);',
     'if (!std::isfinite(v[k])) throw ConfigError(expected);'),
    ('urdf_virtual_names', 'src/urdf_import.cpp',
     'if (spec.joint && !spec.joint->mimic && dofs.count(spec.joint->name))',
     'if (false && spec.joint && !spec.joint->mimic && dofs.count(spec.joint->name))'),
    ('urdf_range_order', 'src/urdf_import.cpp',
     'range[0] < range[1])) {',
     'range[0] <= range[1])) {'),
    # src/model.cpp
    ('model_rpy_roll', 'src/model.cpp',
     'const double roll = std::atan2(s * R(0, 2) - c * R(1, 2), c * R(1, 1) - s * R(0, 1));',
     'const double roll = std::atan2(R(2, 1), R(2, 2));'),
    ('model_axis_code_sign', 'src/model.cpp',
     'if (body.axis == -Vector3::Unit(k)) m.axis_code_[b] = -(k + 1);',
     'if (body.axis == -Vector3::Unit(k)) m.axis_code_[b] = k + 1;'),
    ('model_offset_rotation', 'src/model.cpp',
     'm.offset_without_rotation_[b] = body.X_PJ.R == Matrix3::Identity();',
     'm.offset_without_rotation_[b] = true;'),
    ('model_axis_tolerance', 'src/model.cpp',
     'constexpr double kAxisTolerance = 1e-5;',
     'constexpr double kAxisTolerance = 1e-2;'),
    ('model_continuous_range', 'src/model.cpp',
     'if (!(dof.work_range > 0.0)) dof.work_range = 2.0 * M_PI;',
     'if (!(dof.work_range > 0.0)) dof.work_range = M_PI;'),
    ('model_driven', 'src/model.cpp',
     'if (driven[d] == 0) throw ModelError(',
     'if (driven[d] < 0) throw ModelError('),
    ('model_orthonormal', 'src/model.cpp',
     'if (!(body.X_PJ.R.transpose() * body.X_PJ.R).isIdentity(1e-6))',
     'if (!(body.X_PJ.R.transpose() * body.X_PJ.R).isIdentity(1e-1))'),
    ('model_chain_dofs', 'src/model.cpp',
     'if (m.bodies_[a].dof >= 0) m.chain_bodies_.push_back(a);',
     'if (m.bodies_[a].dof > 0) m.chain_bodies_.push_back(a);'),
    ('model_heel_speed', 'src/model.cpp',
     'const double heel_speed = height > 0.05 ? 0.5 * std::sqrt(height / 0.6) : 0.5;',
     'const double heel_speed = 0.5;'),
    ('model_crouch', 'src/model.cpp',
     'const double crouch = height > 0.0 ? 0.2 * height : 0.2;',
     'const double crouch = 0.2;'),
    ('model_speed_positive', 'src/model.cpp',
     'if (!std::isfinite(dof.max_speed) || dof.max_speed <= 0.0)',
     'if (!std::isfinite(dof.max_speed) || dof.max_speed < 0.0)'),
    ('model_frame_parent_body', 'src/model.cpp',
     'if (p.body != expected)',
     'if (false && p.body != expected)'),
    # A fourth list (thirty-sixth session): the command-line tool's scenario runner, scenario
    # reader, drawn legs, task and model notes, report data and the CLI itself (apps/), which
    # the unit tests also cover.
    # apps/runner.cpp: the scenario runner and its summary
    ('run_axis_angle', 'apps/runner.cpp',
     'return std::atan2(u.cross(v).norm(), u.dot(v));',
     'return (u - v).norm();'),
    ('run_distance_max', 'apps/runner.cpp',
     'if (type == "joints" || max == 0.0 || std::isinf(max)) return max;',
     'if (true) return max;'),
    ('run_shift_share', 'apps/runner.cpp',
     'const double needed = c.q()[dofs[k]] + offset_H[k] / share;',
     'const double needed = c.q()[dofs[k]] + offset_H[k];'),
    ('run_condition_weights', 'apps/runner.cpp',
     "Jp.col(i) *= keep ? model.dof(i).work_range : 0.0;",
     "Jp.col(i) *= keep ? 1.0 : 0.0;"),
    ('run_release_virtual', 'apps/runner.cpp',
     'if (s.fixed_base && model.dof(r.release.back()).role != DofRole::kJoint)',
     'if (false && s.fixed_base && model.dof(r.release.back()).role != DofRole::kJoint)'),
    ('run_given_walking', 'apps/runner.cpp',
     '        if (given) continue;\n',
     '        (void)given;\n'),
    ('run_scaled_tolerance', 'apps/runner.cpp',
     'if (!s.walking.tolerance_given) p.position_tolerance = scaled.position_tolerance;',
     '(void)scaled.position_tolerance;'),
    ('run_event_time', 'apps/runner.cpp',
     's.events[next_event].time <= t_start + 1e-12',
     's.events[next_event].time < t_start'),
    ('run_relative_target', 'apps/runner.cpp',
     'cmd.targets.segment(stack.target_offset(e), v.size()) = c.values().segment(stack.target_offset(e), v.size()) + v;',
     'cmd.targets.segment(stack.target_offset(e), v.size()) = v;'),
    ('run_walk_target_changed', 'apps/runner.cpp',
     'if (walking && (!r.targets.empty() || !r.relative.empty())) walking->target_changed();',
     'if (walking && !r.targets.empty()) walking->target_changed();'),
    ('run_balance_off', 'apps/runner.cpp',
     'if (!balance_on && balance) balance->disable(cmd);',
     'if (false) balance->disable(cmd);'),
    ('run_error_while_active', 'apps/runner.cpp',
     '      if (run.active[k][i] > 0.0) {\n        max_error',
     '      if (true) {\n        max_error'),
    ('run_limit_distance', 'apps/runner.cpp',
     'const double d = std::min(run.q[k][i] - model.dof(i).lower, model.dof(i).upper - run.q[k][i]);',
     'const double d = run.q[k][i] - model.dof(i).lower;'),
    ('run_error_scale', 'apps/runner.cpp',
     'if (task.type == "axis" || task.type == "attitude") return 180.0 / M_PI;',
     'if (task.type == "axis") return 180.0 / M_PI;'),
    # apps/scenario.cpp
    ('scn_filter_order', 'apps/scenario.cpp',
     'order < 2 || order > 6)',
     'order < 2 || order > 7)'),
    ('scn_positive', 'apps/scenario.cpp',
     'if (v <= 0.0) fail(node, field, "expected a number > 0");',
     'if (v < 0.0) fail(node, field, "expected a number > 0");'),
    ('scn_relative_urdf', 'apps/scenario.cpp',
     "if (!s.urdf.empty() && s.urdf[0] != '/') s.urdf = base_dir + \"/\" + s.urdf;",
     "(void)base_dir;"),
    ('scn_cycles_round', 'apps/scenario.cpp',
     'const double cycles = dt > 0.0 ? std::round(duration / dt) : 0.0;',
     'const double cycles = dt > 0.0 ? std::floor(duration / dt) : 0.0;'),
    # apps/leg_poser.cpp: the legs drawn standing on the feet
    ('pose_blend', 'apps/leg_poser.cpp',
     'const double blend = s * s * (3 - 2 * s);',
     'const double blend = s;'),
    ('pose_lift', 'apps/leg_poser.cpp',
     'out.lift[side] = 0.2 * p.max_step_length * std::sin(std::numbers::pi * s);',
     'out.lift[side] = 0.0;'),
    ('pose_left', 'apps/leg_poser.cpp',
     'left[leg] = X_WE.p.y() > 0;',
     'left[leg] = X_WE.p.y() < 0;'),
    # apps/model_notes.cpp
    ('notes_legs_apart', 'apps/model_notes.cpp',
     'if (mean.norm() < 0.1 * length / counted) {',
     'if (false) {'),
    ('notes_legs_down', 'apps/model_notes.cpp',
     'if (!(horizontal > -mean.z())) return "";',
     'if (!(horizontal > -2.0 * mean.z())) return "";'),
    # apps/task_notes.cpp: elements no free dof moves
    ('tnote_free_any', 'apps/task_notes.cpp',
     'free_mover = free_mover || ever_free[i];',
     'free_mover = ever_free[i];'),
    ('tnote_considered', 'apps/task_notes.cpp',
     '    if (!considered[e]) continue;\n    std::string movers;',
     '    std::string movers;'),
    ('tnote_six', 'apps/task_notes.cpp',
     'if (++count <= 6) movers',
     'if (++count <= 60) movers'),
    ('tnote_vanishing', 'apps/task_notes.cpp',
     'constexpr double kVanishing = 1e-10;',
     'constexpr double kVanishing = 1e-1;'),
    # apps/runner.cpp: which dofs count as free for those notes
    ('run_balance_frees', 'apps/runner.cpp',
     'if (balance && d >= 0) ever_free[d] = true;',
     'if (false && balance && d >= 0) ever_free[d] = true;'),
    ('run_walking_frees', 'apps/runner.cpp',
     'if (walking && d >= 0) ever_free[d] = true;',
     'if (false && walking && d >= 0) ever_free[d] = true;'),
    ('run_event_considered', 'apps/runner.cpp',
     'considered[e] = considered[e] || (row >= stack.row_offset(e)',
     'considered[e] = considered[e] && (row >= stack.row_offset(e)'),
    ('run_default_feet_note', 'apps/runner.cpp',
     'if (supported && !s.urdf.empty() && s.feet.line == 0) {',
     'if (false && supported && !s.urdf.empty() && s.feet.line == 0) {'),
    # apps/report_writer.cpp: what the report draws
    ('rep_stride', 'apps/report_writer.cpp',
     'const int stride = std::max(1, (K + kMaxSamples - 1) / kMaxSamples);',
     'const int stride = std::max(1, K / kMaxSamples);'),
    ('rep_last_sample', 'apps/report_writer.cpp',
     'if (samples.back() != K - 1) samples.push_back(K - 1);',
     '(void)K;'),
    ('rep_target_reference', 'apps/report_writer.cpp',
     'target_values[e].push_back(xyz(t.type == "position" ? Vector3(X_WR * v) : Vector3(X_WR.R * v.normalized())));',
     'target_values[e].push_back(xyz(t.type == "position" ? Vector3(v) : Vector3(X_WR.R * v.normalized())));'),
    ('rep_inactive_target', 'apps/report_writer.cpp',
     'if (run.active[k][e] == 0.0 || (t.type != "position" && t.type != "axis")) {',
     'if (t.type != "position" && t.type != "axis") {'),
    ('rep_hidden_heel_yaw', 'apps/report_writer.cpp',
     'hidden[b] = role != DofRole::kJoint && role != DofRole::kHeelYaw && b != chain.upper_body;',
     'hidden[b] = role != DofRole::kJoint && b != chain.upper_body;'),
    ('rep_micrometres', 'apps/report_writer.cpp',
     'double micrometres(double x) { return std::round(x * 1e6) / 1e6; }',
     'double micrometres(double x) { return std::round(x * 1e3) / 1e3; }'),
    # apps/wbm_cli.cpp: the command-line tool
    ('cli_q_whole', 'apps/wbm_cli.cpp',
     'if (trimmed.empty() || end != trimmed.c_str() + trimmed.size())',
     'if (trimmed.empty())'),
    ('cli_q_count', 'apps/wbm_cli.cpp',
     'if (static_cast<int>(values.size()) != model.num_dofs())',
     'if (static_cast<int>(values.size()) < model.num_dofs())'),
    ('cli_same_names', 'apps/wbm_cli.cpp',
     'if (files.size() > 1 && !by_name.emplace(s.name, &s).second)',
     'if (false && files.size() > 1 && !by_name.emplace(s.name, &s).second)'),
    ('cli_usage_status', 'apps/wbm_cli.cpp',
     '    std::cerr << "wbm: error: " << e.what() << "\\nRun with --help for more information.\\n";\n    return 2;',
     '    std::cerr << "wbm: error: " << e.what() << "\\nRun with --help for more information.\\n";\n    return 1;'),
    ('cli_writable', 'apps/wbm_cli.cpp',
     'if (access(path.c_str(), W_OK | X_OK) != 0)',
     'if (false && access(path.c_str(), W_OK | X_OK) != 0)'),
    ('cli_root_below', 'apps/wbm_cli.cpp',
     '(root_height < 0.0 ? " m below" : " m above")',
     '(root_height <= 0.0 ? " m below" : " m above")'),
    ('cli_pivot_line', 'apps/wbm_cli.cpp',
     '!root.empty() && pivot > 0.0)',
     '!root.empty() && pivot > 1.0)'),
    # src/walking.cpp: a second list (thirty-sixth session)
    ('walk_brake_from_rate', 'src/walking.cpp',
     'if (was_free) heel_brake_[k] = c.qdot()[d];',
     'if (was_free) heel_brake_[k] = 0.0;'),
    ('walk_commanded_distance', 'src/walking.cpp',
     'error = std::max(error, std::abs(period > 0.0 ? std::remainder(d, period) : d) * per_tolerance(i));',
     '(void)d;'),
    ('walk_trigger_time', 'src/walking.cpp',
     'if (trigger_timer_ < p_.trigger_time || trigger_timer_ == 0.0) return flags;',
     'if (trigger_timer_ == 0.0) return flags;'),
    ('walk_stalled_ends', 'src/walking.cpp',
     '  if (stalled) finishing_ = true;\n',
     '\n'),
    ('walk_near_yaw', 'src/walking.cpp',
     'const double step_yaw = far ? std::atan2(to_go.y(), to_go.x()) : yaw;',
     'const double step_yaw = std::atan2(to_go.y(), to_go.x());'),
    ('walk_too_many', 'src/walking.cpp',
     'const bool too_many = steps_this_walk_ >= p_.max_steps;',
     'const bool too_many = false;'),
    ('walk_converged_speed', 'src/walking.cpp',
     'converge_timer_ = heel_speed < p_.converged_speed || finishing_ ? converge_timer_ + dt : 0.0;',
     'converge_timer_ = finishing_ ? converge_timer_ + dt : converge_timer_ + 0.1 * dt;'),
    # src/walking.cpp: the three survivors the thirty-sixth session named (thirty-seventh)
    ('walk_feet_tolerance', 'src/walking.cpp',
     'return (l.position - left_.position).norm() < tol && (r.position - right_.position).norm() < tol &&',
     'return (l.position - left_.position).norm() < 3 * tol && (r.position - right_.position).norm() < 3 * tol &&'),
    ('walk_error_stack_rows', 'src/walking.cpp',
     'if (active[r0 + i] && stack.activation()[r0 + i])',
     'if (active[r0 + i])'),
    ('walk_limit_frozen', 'src/walking.cpp',
     'last.has(kJointLimitClamped | kDofAtLimitFrozen)',
     'last.has(kJointLimitClamped)'),
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
