// The report of `fesim diagnose` (PRODUCT.md "Diagnosis" output): diagnosis.json with exactly the
// keys PRODUCT.md lists, diagnosis.md (verdict paragraph, ranking table, residual signatures,
// before/after plots) and the plots as PNG drawn with render/plot.h (residuals_<joint>.png:
// held-out residual over time, baseline vs extended; spectrum_<joint>.png: their periodograms
// 0.05–15 Hz).
#pragma once

#include <string>
#include <vector>

#include "base/json.h"
#include "diagnosis/diagnose.h"

namespace fesim::diagnosis {

/// {"cause", "confidence", "baseline": {"heldout_nrmse"}, "extended": {"mechanisms": [id…],
/// "parameters": {"<label>:<name>": {"value", "ci95", "unit"}…}, "heldout_nrmse"}, "gain",
/// "candidates": [{"id", "score", "heldout_gain", "evidence"}…]} (heldout_gain null when the
/// candidate was not fitted).
Json DiagnosisJson(const Diagnosis& d);

/// One candidate's figures on one line (label, score statistic, dof, adjusted p, fitted, LR p,
/// held-out gain, the second round's figures, fitted parameters), for logs and benchmarks.
std::string CandidateLogLine(const CandidateResult& c);

/// The Markdown report; `inputs` names the measured files and the scenario.
std::string DiagnosisMarkdown(const Diagnosis& d, const std::string& inputs);

/// Writes DIR/diagnosis.json, DIR/diagnosis.md, DIR/residuals_<joint>.png and
/// DIR/spectrum_<joint>.png per output, each atomically (WriteFileAtomic / render::WritePng);
/// DIR must exist. A failed write removes the files this call wrote before it, then rethrows.
void WriteDiagnosisReport(const Diagnosis& d, const std::string& inputs, const std::string& dir);

}  // namespace fesim::diagnosis
