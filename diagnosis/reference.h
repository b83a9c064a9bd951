// The black-box reference of `fesim diagnose` (PRODUCT.md "Diagnosis" step 1): the reduced models
// of the identification library that map the stimulation to the joint angles by simulation (the
// Hammerstein family: papers/000_0a6c0de9fc69df7c.txt eq. 16–24, papers/002_78a57b74c57ee464.txt
// Algorithms 1–2), each identified on the same training trials as the person and evaluated on
// the same held-out samples. The best of them is the fit quality the data support without any
// physiology: a calibrated full model well above it misses something (verdict.h), as in MATLAB's
// practice of judging a grey-box fit beside a black-box one (System Identification Toolbox
// `compare`).
#pragma once

#include <string>
#include <vector>

#include "diagnosis/diagnose.h"
#include "diagnosis/measured.h"
#include "identification/method.h"

namespace fesim::diagnosis {

/// The methods tried: every identification method with a fit_simulator, in registry order.
std::vector<identification::MethodEntry> ReferenceMethods();

/// Identifies each method on data.train (gaps filled as ReducedTrainingTrials does) and predicts
/// the held-out samples; the lowest mean held-out NRMSE over the outputs is the reference. A
/// method that fails (data it cannot use) is listed in `tried` with its one-line reason. Methods
/// run on `threads` threads side by side.
ReferenceResult FitReference(const MeasuredData& data,
                             const std::vector<identification::MethodEntry>& methods, int threads);

}  // namespace fesim::diagnosis
