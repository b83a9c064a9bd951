// Stage "verdict" of `fesim diagnose` (diagnose.h): the cause, its confidence and the reason in
// words, from the extension's outcome, the candidates' figures and the black-box reference.
//
// The reference gate: output o does not reach the black box when the model's held-out NRMSE
// x_o > reference_gate · b_o + reference_margin (b_o the best reduced model's, reference.h).
//   nothing accepted, a gap on some output  → `unexplained`, naming each such output with both
//       figures ("does not reach a black-box fit on q.pip_flexion: 0.90 vs 0.20
//       (hammerstein-mimo)"); confidence min(1, 0.5 + 0.5 (x/(gate·b) − 1)).
//   nothing accepted, no gap                → `none`; confidence 1 − 0.5 min(1, g_best / g_min)
//       (g_best the largest held-out gain of any fitted candidate).
//   controls only accepted                  → `none`: a normal variation of the person the
//       calibration does not parameterise (mechanisms/mechanism.h Mechanism::control) explains
//       the misfit and no mechanism passes on top of it; confidence 0.75 (0.5 with a gap left).
//   a mechanism accepted                    → the first accepted mechanism; confidence
//       c = (1 − p_LR) · (1 − g_alt / g), g_alt the best held-out gain of another id not accepted
//       whose fit passed its training test (less the share it still removes on top of the accepted
//       ones; nothing when its score test on top of them is no longer significant); capped at 0.45
//       when a gap to the black box remains after the extension (the reason names the outputs):
//       never a confident name on a model that does not fit; capped likewise when a fit whose
//       signature the residual contradicts (Mechanism::shape_contradiction: a structure outside
//       the library) passed its training test and gains more than the cause. Below 0.25 another
//       candidate explains about as much: `unexplained` naming both ("no single cause"),
//       confidence 1 − c — or `none` when that other candidate is a control (normal variation
//       explains as much).
#pragma once

#include <string>
#include <vector>

#include "diagnosis/extension.h"

namespace fesim::diagnosis {

/// Outputs (indices) whose held-out NRMSE `nrmse` misses the black box (see above).
std::vector<int> ReferenceGaps(const std::vector<double>& nrmse, const ReferenceResult& reference,
                               const DiagnoseSettings& settings);
/// Outputs whose held-out NRMSE exceeds `gate` × the black box's plus `margin`.
std::vector<int> ReferenceGaps(const std::vector<double>& nrmse, const ReferenceResult& reference,
                               double gate, double margin);

/// Fills cause, confidence, reason, mechanisms and extension parameters of `d` (its candidates,
/// held-out figures and reference already set; candidates in library order).
void MakeVerdict(const std::vector<Candidate>& library, const ExtensionOutcome& extension,
                 int person_parameters, const DiagnoseSettings& settings, Diagnosis* d);

}  // namespace fesim::diagnosis
