#include "diagnosis/report.h"

#include <cmath>
#include <cstdio>
#include <string>

#include "diagnosis/signatures.h"
#include "render/plot.h"
#include "render/video.h"
#include "scenarios/trial.h"

namespace fesim::diagnosis {
namespace {

std::string F(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

std::string Describe(const std::string& id) {
  if (id == "fatigue") return "muscle fatigue (force falling with accumulated stimulation)";
  if (id == "potentiation") return "post-activation potentiation (force rising with use)";
  if (id == "delay") return "an electromechanical delay between stimulation and movement";
  if (id == "tremor") return "a tremor (periodic joint torque)";
  if (id == "crosstalk") return "electrode crosstalk (current reaching other muscles)";
  if (id == "moment_arm_posture") return "posture-dependent moment arms";
  if (id == "force_length_velocity") return "a different muscle force-velocity property";
  if (id == "unequal_muscle_dynamics") return "unequal activation dynamics of the muscle groups";
  if (id == "passive_stiffness_nonlinear") return "nonlinear passive joint stiffness";
  if (id == "arm_support") return "the arm support";
  if (id == "stiction") return "joint friction / stiction";
  if (id == "spasticity") return "a velocity-dependent stretch reflex (spasticity)";
  if (id == "sensor_drift") return "a drifting sensor offset";
  return id;
}

/// Held-out residual series of one output, per held-out trial concatenated (NaN elsewhere).
void HeldoutResidual(const Diagnosis& d, const std::vector<Trial>& pred, const std::string& o,
                     std::vector<double>* t, std::vector<double>* r) {
  double offset = 0.0;
  for (std::size_t k = 0; k < d.heldout.trials.size(); ++k) {
    const Trial& tr = d.heldout.trials[k];
    const auto& y = tr.Column(o);
    const auto& yh = pred[k].Column(o);
    for (std::size_t i = 0; i < tr.size(); ++i) {
      if (!d.heldout.use[k][i]) continue;
      t->push_back(offset + tr.time[i]);
      r->push_back(y[i] - yh[i]);
    }
    offset += tr.time.back();
  }
}

}  // namespace

std::string CandidateLogLine(const CandidateResult& c) {
  std::string params;
  for (const auto& p : c.parameters) params += " " + p.name + "=" + std::to_string(p.value);
  char line[320];
  std::snprintf(line, sizeof line,
                "%-40s S %9.1f dof %d padj %.2g fitted %d lr_padj %.2g gain %.4f | on top: S %.1f "
                "gain %.4f",
                c.label.c_str(), c.score_statistic, c.dof, c.p_adjusted, c.fitted ? 1 : 0,
                c.lr_p_adjusted, c.heldout_gain, c.score_on_accepted, c.heldout_gain_on_accepted);
  return line + params;
}

Json DiagnosisJson(const Diagnosis& d) {
  Json j = Json::Object();
  j.Set("cause", d.cause);
  j.Set("confidence", d.confidence);
  Json base = Json::Object();
  base.Set("heldout_nrmse", d.baseline_heldout_nrmse);
  j.Set("baseline", base);
  Json ext = Json::Object();
  Json ids = Json::Array();
  for (const auto& m : d.mechanism_ids) ids.Push(m);
  ext.Set("mechanisms", ids);
  Json params = Json::Object();
  for (const auto& p : d.extension_parameters) {
    Json v = Json::Object();
    v.Set("value", p.value);
    v.Set("ci95", p.ci95);
    v.Set("unit", p.unit);
    params.Set(p.name, v);
  }
  ext.Set("parameters", params);
  ext.Set("heldout_nrmse", d.extended_heldout_nrmse);
  j.Set("extended", ext);
  j.Set("gain", d.gain);
  Json cands = Json::Array();
  for (const auto& c : d.candidates) {
    Json e = Json::Object();
    e.Set("id", c.id);
    e.Set("score", c.score);
    e.Set("heldout_gain", c.fitted ? Json(c.heldout_gain) : Json());
    e.Set("evidence", (c.joint.empty() ? "" : "[" + c.joint + "] ") + c.evidence);
    cands.Push(e);
  }
  j.Set("candidates", cands);
  j.Set("model", d.model);
  return j;
}

std::string DiagnosisMarkdown(const Diagnosis& d, const std::string& inputs) {
  std::string notes;
  for (const auto& line : d.notes) notes += "Input: " + line + ".\n\n";
  const std::string model =
      d.model == "full"
          ? std::string("the full model (12) of the rig, subject parameters calibrated")
          : "the reduced model " + d.model +
                " identified on the training part (below); only mechanisms acting on its input or "
                "output can extend it";
  std::string md = "# fesim diagnose\n\n" + inputs + "\n\nModel: " + model +
                   ".\n\nSplit: " + d.split + ".\n\n" + notes + "## Verdict\n\n";
  if (d.cause == "none") {
    md +=
        "The calibrated simulation reproduces the held-out data to within the measurement "
        "noise: no candidate mechanism improved the held-out error enough to be accepted and "
        "the remaining residual is white. Verdict **none** (confidence " +
        F("%.2f", d.confidence) + ").\n";
  } else if (d.cause == "unexplained") {
    md +=
        "The calibrated simulation leaves structure in the held-out residual (see the "
        "signature table: structured share above threshold) that none of the candidate "
        "mechanisms explains on held-out data. Verdict **unexplained** (confidence " +
        F("%.2f", d.confidence) +
        "): the data hold an effect the model library lacks, or an "
        "artefact of the recording.\n";
  } else {
    md += "What the simulation gets wrong is best explained by " + Describe(d.cause) + " (**" +
          d.cause + "**, confidence " + F("%.2f", d.confidence) + ").";
    if (d.mechanisms.size() > 1) {
      md += " A second mechanism was accepted on top:";
      for (std::size_t k = 1; k < d.mechanisms.size(); ++k) md += " **" + d.mechanisms[k] + "**";
      md += ".";
    }
    md += " Extending the model with it and refitting lowers the held-out normalised error from " +
          F("%.4f", d.baseline_heldout_nrmse) + " to " + F("%.4f", d.extended_heldout_nrmse) +
          " (gain " + F("%.1f", 100.0 * d.gain) + " %).";
    if (d.confidence < 0.5) {
      md +=
          " The confidence is low: another candidate explains a comparable share, or "
          "structure remains after the extension — treat the name as a hypothesis.";
    }
    md +=
        "\n\nFitted mechanism parameters (95 % intervals from the Gauss–Newton covariance):\n\n"
        "| parameter | value | ± 95 % | unit |\n|---|---|---|---|\n";
    for (const auto& p : d.extension_parameters) {
      md += "| " + p.name + " | " + F("%.4g", p.value) + " | " +
            (std::isfinite(p.ci95) ? F("%.2g", p.ci95) : std::string("n/a")) + " | " + p.unit +
            " |\n";
    }
  }
  md += "\n## Before / after (held-out data)\n\n";
  for (const auto& o : d.heldout.outputs) {
    md += "![residual " + o + "](residuals_" + o.substr(2) + ".png)\n![spectrum " + o +
          "](spectrum_" + o.substr(2) + ".png)\n\n";
  }
  md +=
      "## Residual signatures (baseline model, training data)\n\n"
      "| output | RMS (rad) | spectrum peak 3–12 Hz | corr time | corr cumulative u | corr "
      "velocity | corr sign(velocity) | corr posture | input lag | structured share held-out "
      "before → after |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& s : d.signatures) {
    md += "| " + s.output + " | " + F("%.4f", s.rms_rad) + " | " +
          F("%.3f Hz", s.spectrum_peak_hz) + F(" (%.1fx)", s.spectrum_peak_ratio) + " | " +
          F("%.2f", s.corr_time) + " | " + F("%.2f", s.corr_cumulative_stimulation) + " | " +
          F("%.2f", s.corr_velocity) + " | " + F("%.2f", s.corr_velocity_sign) + " | " +
          F("%.2f", s.corr_posture) + " | " + F("%.3f s", s.input_lag_s) +
          F(" (%.2f, ", s.input_lag_corr) + s.input_lag_column + ") | " +
          F("%.2f", s.structure_heldout_baseline) + " → " +
          F("%.2f", s.structure_heldout_extended) + " |\n";
  }
  md +=
      "\n## Candidate ranking\n\nScore = −log10 of the Bonferroni-adjusted p-value of the "
      "score test (0 = no evidence); held-out gain of the candidate alone on the baseline "
      "(blank: not fitted); on top: its held-out gain over the model with the other accepted "
      "mechanism(s) (second round; blank: not fitted there).\n\n| candidate | score | held-out "
      "gain | on top | accepted | evidence |\n|---|---|---|---|---|---|\n";
  for (const auto& c : d.candidates) {
    md += "| " + c.label + " | " + F("%.1f", c.score) + " | " +
          (c.fitted ? F("%.4f", c.heldout_gain) : std::string("")) + " | " +
          (std::isfinite(c.heldout_gain_on_accepted) ? F("%.4f", c.heldout_gain_on_accepted)
                                                     : std::string("")) +
          " | " + (c.accepted ? "yes" : "") + " | " + c.evidence + " |\n";
  }
  md +=
      "\nSubject parameters calibrated on the training data:\n\n| parameter | value | ± 95 % | "
      "unit |\n|---|---|---|---|\n";
  for (const auto& p : d.subject_parameters) {
    md += "| " + p.name + " | " + F("%.4g", p.value) + " | " +
          (std::isfinite(p.ci95) ? F("%.2g", p.ci95) : std::string("n/a")) + " | " + p.unit +
          " |\n";
  }
  if (!d.model_yaml.empty()) {
    md += "\nThe reduced model " + d.model +
          " as identified on the training part (the extensions act on its input and output):"
          "\n\n```yaml\n" +
          d.model_yaml + (d.model_yaml.back() == '\n' ? "" : "\n") + "```\n";
  }
  md += "\n" + std::to_string(d.simulations) + " trial simulations, " +
        std::to_string(d.cached_results) + " results read from the resume cache, " +
        F("%.1f", d.wall_s) + " s wall time.\n";
  return md;
}

void WriteDiagnosisReport(const Diagnosis& d, const std::string& inputs, const std::string& dir) {
  // Everything is computed before the first file is written.
  const std::string json = DiagnosisJson(d).Dump(2) + "\n";
  const std::string md = DiagnosisMarkdown(d, inputs);
  struct Figure {
    std::string path;
    render::Axes axes;
    std::vector<render::Series> series;
  };
  std::vector<Figure> figures;
  for (const auto& o : d.heldout.outputs) {
    const std::string joint = o.substr(2);
    render::Series b, a;
    b.label = "baseline";
    b.colour = render::PaletteColour(7);
    a.label = "extended";
    a.colour = render::PaletteColour(0);
    HeldoutResidual(d, d.heldout_baseline, o, &b.x, &b.y);
    HeldoutResidual(d, d.heldout_extended, o, &a.x, &a.y);
    Figure res;
    res.path = dir + "/residuals_" + joint + ".png";
    res.axes.title = "held-out residual y - y_hat, " + o;
    res.axes.x_label = "time (s)";
    res.axes.y_label = "rad";
    res.axes.width_px = 900;
    res.axes.height_px = 300;
    res.series = {b, a};
    const double dt = b.x.size() > 1 ? b.x[1] - b.x[0] : 0.01;
    std::vector<double> f;
    for (double x = 0.05; x <= std::min(15.0, 0.45 / dt); x += 0.02) f.push_back(x);
    render::Series sb = b, sa = a;
    sb.x = sa.x = f;
    sb.y = Periodogram(b.y, dt, f);
    sa.y = Periodogram(a.y, dt, f);
    Figure spec;
    spec.path = dir + "/spectrum_" + joint + ".png";
    spec.axes = res.axes;
    spec.axes.title = "held-out residual periodogram, " + o;
    spec.axes.x_label = "frequency (Hz)";
    spec.axes.y_label = "rad^2";
    spec.axes.log_y = true;
    spec.series = {sb, sa};
    figures.push_back(res);
    figures.push_back(spec);
  }
  std::vector<render::Image> images;
  images.reserve(figures.size());
  for (const auto& f : figures) images.push_back(render::LinePlot(f.axes, f.series));
  // The whole report or none of it (issue 10): when a write fails half-way (a full disk), the
  // files this call already wrote are removed again, so no plots without their report remain.
  std::vector<std::string> written;
  try {
    for (std::size_t k = 0; k < figures.size(); ++k) {
      render::WritePng(figures[k].path, images[k]);
      written.push_back(figures[k].path);
    }
    WriteFileAtomic(dir + "/diagnosis.json", json);
    written.push_back(dir + "/diagnosis.json");
    WriteFileAtomic(dir + "/diagnosis.md", md);
  } catch (...) {
    for (const auto& path : written) std::remove(path.c_str());
    throw;
  }
}

}  // namespace fesim::diagnosis
