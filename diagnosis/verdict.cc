#include "diagnosis/verdict.h"

#include <algorithm>
#include <cmath>

#include "diagnosis/mechanisms/library.h"
#include "diagnosis/screening.h"

namespace fesim::diagnosis {
namespace {

/// Confidence cap of a name given while the model misses the black box somewhere.
constexpr double kGapConfidenceCap = 0.45;
/// Below this confidence another candidate explains about as much as the first accepted one:
/// the verdict is `unexplained`, naming both, not a name at a confidence near 0.
constexpr double kMinNameConfidence = 0.25;

std::string GapText(const std::vector<int>& gaps, const std::vector<double>& nrmse,
                    const Diagnosis& d) {
  std::string text;
  for (int o : gaps) {
    text += (text.empty() ? "" : "; ") + d.heldout.outputs[o] +
            Fmt(": %.3f vs %.3f", nrmse[o], d.reference.heldout_nrmse_per_output[o]);
  }
  return text + " (held-out NRMSE of the calibrated model vs the black box " + d.reference.method +
         ")";
}

/// "; <label> gains … but is not named …" for the candidate of largest held-out gain that the
/// person-at-bound condition kept out (CandidateResult::person_at_bound), "" when none: what a
/// verdict `none` owes to a person outside the model's range.
std::string HeldByPersonText(const std::vector<CandidateResult>& candidates) {
  const CandidateResult* held = nullptr;
  for (const CandidateResult& cr : candidates) {
    if (!cr.person_at_bound.empty() && cr.heldout_gain > 0.0 &&
        (held == nullptr || cr.heldout_gain > held->heldout_gain)) {
      held = &cr;
    }
  }
  if (held == nullptr) return "";
  return "; " + held->label +
         Fmt(" gains %.1f %% on the held-out data", 100.0 * held->heldout_gain) +
         " but is not named: the person's " + held->person_at_bound +
         " ended at a bound of its range, so the person lies outside the model's range there";
}

/// Verdict `none` when only controls (Mechanism::control) were accepted: the extended model
/// holds a normal variation of the person, no mechanism passes beyond it.
void NoneBeyondControls(const std::vector<Candidate>& library, const ExtensionOutcome& extension,
                        const std::vector<int>& gaps_after, Diagnosis* d) {
  std::string controls;
  for (int c : extension.accepted) {
    controls += (controls.empty() ? "" : ", ") + library[c].label;
  }
  d->cause = "none";
  d->confidence = gaps_after.empty() ? 0.75 : 0.5;
  d->reason = "a normal variation of the person that the calibration does not parameterise (" +
              controls + Fmt(", held-out gain of the extended model %.1f %%)", 100.0 * d->gain) +
              " explains what the calibrated model misses, and no candidate mechanism passes on "
              "top of it";
  if (!gaps_after.empty()) {
    d->reason += "; the extended model still does not reach the black box on " +
                 GapText(gaps_after, d->extended_heldout_nrmse_per_output, *d);
  }
}

/// The accepted candidates' names (mechanisms only) and the extension's parameters (controls'
/// too: they are part of the extended model).
void ListExtension(const std::vector<Candidate>& library, const ExtensionOutcome& extension,
                   int person_parameters, Diagnosis* d) {
  auto at = static_cast<Eigen::Index>(person_parameters);
  for (int c : extension.accepted) {
    if (!library[c].control) {
      d->mechanisms.push_back(library[c].label);
      d->mechanism_ids.push_back(library[c].id);
    }
    for (const auto& p : library[c].params) {
      d->extension_parameters.push_back(
          {library[c].label + ":" + p.name, p.unit, extension.fit.x(at), extension.fit.ci95(at)});
      ++at;
    }
  }
}

/// The candidate whose fit passes its training test and gains on the held-out data but whose
/// signature the residual contradicts (CandidateResult::shape), the largest gain first; −1: none.
int StructureOutsideLibrary(const std::vector<CandidateResult>& candidates,
                            const DiagnoseSettings& settings) {
  int best = -1;
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    const CandidateResult& cr = candidates[c];
    if (cr.shape.empty() || !cr.fitted || cr.not_judged || !(cr.lr_p_adjusted < settings.alpha) ||
        !(cr.heldout_gain > settings.min_heldout_gain)) {
      continue;
    }
    if (best < 0 || cr.heldout_gain > candidates[best].heldout_gain) best = static_cast<int>(c);
  }
  return best;
}

}  // namespace

std::vector<int> ReferenceGaps(const std::vector<double>& nrmse, const ReferenceResult& reference,
                               double gate, double margin) {
  std::vector<int> gaps;
  if (reference.method.empty()) return gaps;
  for (std::size_t o = 0; o < nrmse.size() && o < reference.heldout_nrmse_per_output.size(); ++o) {
    const double b = reference.heldout_nrmse_per_output[o];
    if (std::isfinite(b) && !(nrmse[o] <= gate * b + margin)) gaps.push_back(static_cast<int>(o));
  }
  return gaps;
}

std::vector<int> ReferenceGaps(const std::vector<double>& nrmse, const ReferenceResult& reference,
                               const DiagnoseSettings& settings) {
  return ReferenceGaps(nrmse, reference, settings.reference_gate, settings.reference_margin);
}

void MakeVerdict(const std::vector<Candidate>& library, const ExtensionOutcome& extension,
                 int person_parameters, const DiagnoseSettings& settings, Diagnosis* d) {
  const std::vector<int> gaps_before =
      ReferenceGaps(d->baseline_heldout_nrmse_per_output, d->reference, settings);
  const std::vector<int> gaps_after =
      ReferenceGaps(d->extended_heldout_nrmse_per_output, d->reference, settings);
  double best_gain = 0.0;
  for (const auto& cr : d->candidates) {
    if (cr.fitted && !cr.not_judged && std::isfinite(cr.heldout_gain))
      best_gain = std::max(best_gain, cr.heldout_gain);
  }
  if (extension.cause < 0) {
    const int outside = StructureOutsideLibrary(d->candidates, settings);
    if (outside >= 0) {
      const CandidateResult& cr = d->candidates[outside];
      d->cause = "unexplained";
      d->confidence = 0.5 + 0.5 * std::min(1.0, cr.heldout_gain / settings.clear_heldout_gain);
      d->reason = "the residual holds a structure no candidate of the library has: " +
                  FindMechanism(cr.id).description +
                  Fmt(" would gain %.1f %% on the held-out data, but ", 100.0 * cr.heldout_gain) +
                  cr.shape;
      ListExtension(library, extension, person_parameters, d);
      return;
    }
    if (!extension.accepted.empty()) {
      NoneBeyondControls(library, extension, gaps_after, d);
      ListExtension(library, extension, person_parameters, d);
      return;
    }
    if (!gaps_before.empty()) {
      d->cause = "unexplained";
      double worst = 0.0;
      for (int o : gaps_before) {
        worst = std::max(worst,
                         d->baseline_heldout_nrmse_per_output[o] /
                             (settings.reference_gate * d->reference.heldout_nrmse_per_output[o]));
      }
      d->confidence = std::clamp(0.5 + 0.5 * (worst - 1.0), 0.5, 1.0);
      d->reason =
          "the calibrated model does not reach a black-box fit and no candidate mechanism "
          "closes the gap: " +
          GapText(gaps_before, d->baseline_heldout_nrmse_per_output, *d);
    } else {
      d->cause = "none";
      d->confidence = 1.0 - 0.5 * std::min(1.0, best_gain / settings.min_heldout_gain);
      d->reason =
          "the calibrated model predicts the held-out data as well as the black box " +
          (d->reference.method.empty() ? std::string("(none identified)") : d->reference.method) +
          " (within the gate) and no candidate mechanism passes its tests" +
          HeldByPersonText(d->candidates);
    }
    return;
  }
  const std::string& id = library[extension.cause].id;
  d->cause = id;
  // An alternative competes for the share of its gain it loses once the accepted mechanisms are
  // in the model (fitted on top of them: the NRMSE it still removes there explains something
  // else); not fitted there: all of it.
  // Alternatives: other ids whose fit passed its training test (a fit that explains nothing on
  // the training data is no explanation), less what they lose on top of the accepted mechanisms
  // — nothing left when their score test there is no longer significant — and at most their own
  // part of the gain (CandidateResult::heldout_own_gain: what the person's refit gained is no
  // explanation by the mechanism).
  const int m = ApplicableCount(library);
  double g_alt = 0.0;
  std::string alternative;
  bool alternative_is_control = false;
  for (std::size_t c = 0; c < d->candidates.size(); ++c) {
    const CandidateResult& cr = d->candidates[c];
    if (!cr.fitted || cr.not_judged || cr.id == id || !std::isfinite(cr.heldout_gain) ||
        cr.accepted || !cr.collapsed.empty() || !(cr.lr_p_adjusted < settings.alpha)) {
      continue;
    }
    if (std::isfinite(cr.score_on_accepted) &&
        AdjustedChiSquareP(cr.score_on_accepted, std::max(1, cr.dof), m) >= settings.alpha) {
      continue;
    }
    double g = cr.heldout_gain;
    if (std::isfinite(cr.heldout_own_gain)) g = std::min(g, cr.heldout_own_gain);
    if (std::isfinite(cr.heldout_gain_on_accepted) &&
        std::isfinite(extension.on_top_reference[c])) {
      g -= std::max(0.0, cr.heldout_gain_on_accepted) * extension.on_top_reference[c] /
           d->baseline_heldout_nrmse;
    }
    if (g > g_alt) {
      g_alt = g;
      alternative = cr.label;
      alternative_is_control = library[c].control;
    }
  }
  d->confidence =
      std::clamp((1.0 - extension.cause_lr_p) * (1.0 - g_alt / extension.cause_gain), 0.0, 1.0);
  if (d->confidence < kMinNameConfidence) {
    const std::string compared = library[extension.cause].label +
                                 Fmt(": held-out gain %.1f %%; ", 100.0 * extension.cause_gain) +
                                 alternative + Fmt(": %.1f %%", 100.0 * g_alt);
    d->confidence = 1.0 - d->confidence;
    if (alternative_is_control) {
      d->cause = "none";
      d->reason =
          "the misfit is explained about as well by a normal variation of the person "
          "that the calibration does not parameterise as by the best mechanism (" +
          compared + ")";
    } else if (extension.cause_gain < settings.min_heldout_gain && gaps_before.empty()) {
      // Near the black box, two candidates that each gain under min_heldout_gain share a small
      // misfit of a normal person (a clean in-family person: 1.0 % and 0.8 %; docs/diagnosis.md,
      // Verdict): no structure to report.
      d->cause = "none";
      d->reason = "the calibrated model predicts the held-out data as well as the black box " +
                  d->reference.method +
                  " (within the gate); candidates gain about as little each (" + compared +
                  Fmt(", under %.0f %%): no cause", 100.0 * settings.min_heldout_gain);
    } else {
      d->cause = "unexplained";
      d->reason = "the misfit is explained about as well by other candidates as by the best one (" +
                  compared + "): no single cause";
    }
    return;
  }
  d->reason = FindMechanism(id).description + " explains what the calibrated model misses";
  if (!gaps_after.empty()) {
    d->confidence = std::min(d->confidence, kGapConfidenceCap);
    d->reason += "; but the extended model still does not reach the black box on " +
                 GapText(gaps_after, d->extended_heldout_nrmse_per_output, *d);
  }
  // A structure outside the library that would gain more than the cause: the cause explains the
  // lesser part of what the residual holds (foreign glove slip 1018: posture-dependent arms at
  // the PIP gain 1.4 %, the slip fitted as a drift 10.5 %).
  const int outside = StructureOutsideLibrary(d->candidates, settings);
  if (outside >= 0 && d->candidates[outside].heldout_gain > extension.cause_gain) {
    const CandidateResult& cr = d->candidates[outside];
    d->confidence = std::min(d->confidence, kGapConfidenceCap);
    d->reason += "; but the residual holds a larger structure no candidate of the library has: " +
                 FindMechanism(cr.id).description +
                 Fmt(" would gain %.1f %% on the held-out data (this cause %.1f %%), but ",
                     100.0 * cr.heldout_gain, 100.0 * extension.cause_gain) +
                 cr.shape;
  }
  ListExtension(library, extension, person_parameters, d);
}

}  // namespace fesim::diagnosis
