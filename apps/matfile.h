// MATLAB .mat files (MAT 5, libmatio) of fesim results (README "MATLAB"): identified discrete
// models for the System Identification Toolbox and trials as named arrays. Written atomically
// (a temporary file in the same folder, renamed), so a failed or interrupted write leaves none.
#pragma once

#include <string>

#include "base/trial.h"
#include "identification/method.h"

namespace fesim {

/// One discrete model (identification/method.h) as top-level variables: Ts (s), A, B (one row per
/// input), C = 1, D = 1, F (row vectors in q⁻¹), InputName / InputUnit (cells), OutputName /
/// OutputUnit (char), Breakpoints (2 × N: u in row 1, f(u) in row 2, first input; absent when
/// linear) and OutputOffset. In MATLAB:
///   m = load('model.mat');
///   lin = idpoly(m.A, m.B, m.C, m.D, m.F, 0, m.Ts, 'InputName', m.InputName, 'OutputName',
///   m.OutputName); sys = idnlhw(lin, idPiecewiseLinear('BreakPoints', m.Breakpoints), []);
/// Throws std::runtime_error naming the path when it cannot be written.
void WriteDiscreteModelMat(const identification::DiscreteModel& model, const std::string& path);

/// A trial as variables: `time` (N × 1, s) and one N × 1 double per column, named after it with
/// every character other than letters, digits and '_' as '_' (q.wrist_flexion → q_wrist_flexion;
/// `columns` maps them back: a 2 × K cell of original and variable names), and `metadata`, a
/// K × 2 cell of key/value strings. NaN stays NaN.
void WriteTrialMat(const Trial& trial, const std::string& path);

/// Loads the MAT-file module (apps/matfile_module.h) or throws its one-line error. A command
/// calls it before it writes its first file, so that a missing module leaves no partial output.
void RequireMatOutput();

/// The MATLAB variable name of a trial column (see WriteTrialMat).
std::string MatVariableName(const std::string& column);

}  // namespace fesim
