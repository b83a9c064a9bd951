#include "diagnosis/report.h"

#include <cmath>
#include <cstdio>
#include <string>

#include "base/trial.h"
#include "diagnosis/signatures.h"
#include "render/plot.h"
#include "render/video.h"

namespace fesim::diagnosis {
namespace {

/// {name: {value, ci95, unit}} of fitted extension parameters.
Json ParametersJson(const std::vector<NamedValue>& parameters) {
  Json params = Json::Object();
  for (const auto& p : parameters) {
    Json v = Json::Object();
    v.Set("value", p.value).Set("ci95", p.ci95).Set("unit", p.unit);
    params.Set(p.name, v);
  }
  return params;
}

std::string F(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

std::string Status(const PersonValue& v) {
  if (!v.fitted) return "held at nominal: not identifiable from these data";
  if (v.at_bound) return "at a bound";
  if (v.prior_dominated) return "calibrated, weakly (prior-dominated)";
  return "calibrated";
}

std::string Cell(double v, const char* fmt) {
  return std::isfinite(v) ? F(fmt, v) : std::string("");
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

/// Held-out measured series of one output and a prediction of it, trials concatenated.
void HeldoutSeries(const Diagnosis& d, const std::vector<Trial>& pred, const std::string& o,
                   std::vector<double>* t, std::vector<double>* y, std::vector<double>* yh) {
  double offset = 0.0;
  for (std::size_t k = 0; k < d.heldout.trials.size(); ++k) {
    const Trial& tr = d.heldout.trials[k];
    for (std::size_t i = 0; i < tr.size(); ++i) {
      if (!d.heldout.use[k][i]) continue;
      t->push_back(offset + tr.time[i]);
      y->push_back(tr.Column(o)[i]);
      yh->push_back(pred[k].Column(o)[i]);
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
                "%-40s S %9.1f dof %d padj %.2g infl %.1f fitted %d lr_padj %.2g gain %.4f own "
                "%.4f z %.1f | on top: S %.1f gain %.4f",
                c.label.c_str(), c.score_statistic, c.dof, c.p_adjusted, c.variance_inflation,
                c.fitted ? 1 : 0, c.lr_p_adjusted, c.heldout_gain, c.heldout_own_gain, c.heldout_z,
                c.score_on_accepted, c.heldout_gain_on_accepted);
  return line + params;
}

Json DiagnosisJson(const Diagnosis& d) {
  Json j = Json::Object();
  j.Set("cause", d.cause);
  j.Set("confidence", d.confidence);
  j.Set("reason", d.reason);
  Json base = Json::Object();
  base.Set("heldout_nrmse", d.baseline_heldout_nrmse);
  Json per = Json::Object();
  for (std::size_t o = 0; o < d.heldout.outputs.size(); ++o) {
    per.Set(d.heldout.outputs[o], d.baseline_heldout_nrmse_per_output[o]);
  }
  base.Set("per_output", per);
  j.Set("baseline", base);
  Json ext = Json::Object();
  Json ids = Json::Array();
  for (const auto& m : d.mechanism_ids) ids.Push(m);
  ext.Set("mechanisms", ids);
  ext.Set("parameters", ParametersJson(d.extension_parameters));
  ext.Set("heldout_nrmse", d.extended_heldout_nrmse);
  Json ext_per = Json::Object();
  for (std::size_t o = 0; o < d.heldout.outputs.size(); ++o) {
    ext_per.Set(d.heldout.outputs[o], d.extended_heldout_nrmse_per_output[o]);
  }
  ext.Set("per_output", ext_per);
  j.Set("extended", ext);
  j.Set("gain", d.gain);
  Json cands = Json::Array();
  for (const auto& c : d.candidates) {
    Json e = Json::Object();
    e.Set("id", c.id).Set("label", c.label).Set("joint", c.joint.empty() ? Json() : Json(c.joint));
    e.Set("control", c.control);
    e.Set("score", c.score).Set("statistic", c.score_statistic).Set("dof", c.dof);
    e.Set("p_value", c.p_value).Set("p_adjusted", c.p_adjusted);
    e.Set("variance_inflation", c.variance_inflation);
    e.Set("heldout_gain", c.fitted ? Json(c.heldout_gain) : Json());
    e.Set("heldout_z", c.fitted ? Json(c.heldout_z) : Json());
    e.Set("heldout_own_gain",
          std::isfinite(c.heldout_own_gain) ? Json(c.heldout_own_gain) : Json());
    e.Set("heldout_own_z", std::isfinite(c.heldout_own_z) ? Json(c.heldout_own_z) : Json());
    e.Set("person_at_bound", c.person_at_bound.empty() ? Json() : Json(c.person_at_bound));
    e.Set("lr_p_adjusted", c.fitted ? Json(c.lr_p_adjusted) : Json());
    e.Set("shape_contradiction", c.shape.empty() ? Json() : Json(c.shape));
    e.Set("parameters", c.fitted ? ParametersJson(c.parameters) : Json());
    // Judged: its fit went through the acceptance tests (false: another joint of its mechanism
    // was chosen by the fit, CandidateResult::not_judged; null: not fitted).
    e.Set("judged", c.fitted ? Json(!c.not_judged) : Json());
    // Second round, on top of the mechanism(s) accepted before it (null: not tested or fitted).
    e.Set("score_on_accepted",
          std::isfinite(c.score_on_accepted) ? Json(c.score_on_accepted) : Json());
    e.Set("heldout_gain_on_accepted",
          std::isfinite(c.heldout_gain_on_accepted) ? Json(c.heldout_gain_on_accepted) : Json());
    e.Set("accepted", c.accepted).Set("decision", c.decision).Set("evidence", c.evidence);
    cands.Push(e);
  }
  j.Set("candidates", cands);
  Json person = Json::Object();
  for (const auto& v : d.person) {
    Json e = Json::Object();
    e.Set("value", v.value).Set("unit", v.unit).Set("ci95", v.ci95).Set("nominal", v.nominal);
    e.Set("calibrated", v.fitted).Set("at_bound", v.at_bound);
    e.Set("prior_dominated", v.prior_dominated).Set("status", Status(v));
    person.Set(v.name, e);
  }
  j.Set("person", person);
  Json ref = Json::Object();
  ref.Set("method", d.reference.method.empty() ? Json() : Json(d.reference.method));
  ref.Set("heldout_nrmse", d.reference.heldout_nrmse);
  Json ref_per = Json::Object();
  for (std::size_t o = 0; o < d.reference.heldout_nrmse_per_output.size(); ++o) {
    ref_per.Set(d.heldout.outputs[o], d.reference.heldout_nrmse_per_output[o]);
  }
  ref.Set("per_output", ref_per);
  j.Set("reference", ref);
  Json noise = Json::Object();
  for (std::size_t o = 0; o < d.noise_rad.size(); ++o)
    noise.Set(d.heldout.outputs[o], d.noise_rad[o]);
  j.Set("noise_rad", noise);
  j.Set("model", d.model);
  Json notes = Json::Array();
  for (const auto& line : d.notes) notes.Push(line);
  j.Set("notes", notes);
  return j;
}

std::string DiagnosisMarkdown(const Diagnosis& d, const std::string& inputs) {
  std::string notes;
  for (const auto& line : d.notes) notes += "Note: " + line + ".\n\n";
  const std::string model =
      d.model == "full"
          ? std::string("the full model (12) of the rig, the person calibrated")
          : "the reduced model " + d.model +
                " identified on the training part (below); only mechanisms acting on its input or "
                "output can extend it";
  std::string md = "# fesim diagnose\n\n" + inputs + "\n\nModel: " + model +
                   ".\n\nSplit: " + d.split + ".\n\n" + notes + "## Verdict\n\n";
  md += "**" + d.cause + "** (confidence " + F("%.2f", d.confidence) + "): " + d.reason + ".";
  if (d.mechanisms.size() > 1) {
    md += " A second mechanism was accepted on top:";
    for (std::size_t k = 1; k < d.mechanisms.size(); ++k) md += " **" + d.mechanisms[k] + "**";
    md += ".";
  }
  if (!d.mechanisms.empty()) {
    md += " Extending the model and refitting lowers the held-out normalised error from " +
          F("%.4f", d.baseline_heldout_nrmse) + " to " + F("%.4f", d.extended_heldout_nrmse) +
          " (gain " + F("%.1f", 100.0 * d.gain) + " %).";
    if (d.confidence < 0.5) md += " The confidence is low: treat the name as a hypothesis.";
    md +=
        "\n\nFitted mechanism parameters (95 % intervals from the Gauss–Newton covariance):\n\n"
        "| parameter | value | ± 95 % | unit |\n|---|---|---|---|\n";
    for (const auto& p : d.extension_parameters) {
      md += "| " + p.name + " | " + F("%.4g", p.value) + " | " + Cell(p.ci95, "%.2g") + " | " +
            p.unit + " |\n";
    }
  }
  md +=
      "\n## Fit quality beside a black box (held-out NRMSE)\n\n| output | calibrated model | "
      "extended model | black box " +
      d.reference.method + " | noise σ (rad) |\n|---|---|---|---|---|\n";
  for (std::size_t o = 0; o < d.heldout.outputs.size(); ++o) {
    const double ref = o < d.reference.heldout_nrmse_per_output.size()
                           ? d.reference.heldout_nrmse_per_output[o]
                           : NAN;
    md += "| " + d.heldout.outputs[o] + " | " + F("%.4f", d.baseline_heldout_nrmse_per_output[o]) +
          " | " + F("%.4f", d.extended_heldout_nrmse_per_output[o]) + " | " + Cell(ref, "%.4f") +
          " | " + (o < d.noise_rad.size() ? F("%.4f", d.noise_rad[o]) : std::string("")) + " |\n";
  }
  for (const auto& [method, result] : d.reference.tried) {
    md += "\nBlack box " + method + ": " + result + ".";
  }
  md += "\n\n## Before / after (held-out data)\n\n";
  for (const auto& o : d.heldout.outputs) {
    md += "![prediction " + o + "](prediction_" + o.substr(2) + ".png)\n![residual " + o +
          "](residuals_" + o.substr(2) + ".png)\n![spectrum " + o + "](spectrum_" + o.substr(2) +
          ".png)\n\n";
  }
  md +=
      "## Residual signatures (calibrated model, training data)\n\n"
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
      "\n## Candidates\n\nRobust score test (noise_model.h: the residual's coloured noise "
      "along the candidate's directions) with its Bonferroni-adjusted p; for fitted candidates the "
      "held-out gain on the calibrated model, its own part (the fitted model with the candidate "
      "switched off against the fitted model), its Diebold–Mariano z and the decision.\n\n"
      "| candidate | joint | χ² | dof | p (adj.) | held-out gain | own | z | on top | accepted | "
      "decision | evidence |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& c : d.candidates) {
    md += "| " + c.label + " | " + c.joint + " | " + F("%.1f", c.score_statistic) + " | " +
          std::to_string(c.dof) + " | " + F("%.2g", c.p_adjusted) + " | " +
          (c.fitted ? F("%.4f", c.heldout_gain) : std::string("")) + " | " +
          Cell(c.heldout_own_gain, "%.4f") + " | " +
          (c.fitted ? Cell(c.heldout_z, "%.1f") : std::string("")) + " | " +
          Cell(c.heldout_gain_on_accepted, "%.4f") + " | " + (c.accepted ? "yes" : "") + " | " +
          c.decision + " | " + c.evidence + " |\n";
  }
  md +=
      "\n## The person, calibrated on the training data\n\n| parameter | value | ± 95 % | "
      "nominal | unit | status |\n|---|---|---|---|---|---|\n";
  for (const auto& v : d.person) {
    md += "| " + v.name + " | " + F("%.4g", v.value) + " | " + Cell(v.ci95, "%.2g") + " | " +
          F("%.4g", v.nominal) + " | " + v.unit + " | " + Status(v) + " |\n";
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
  // Joint angles (q.* outputs, rad in the data) are plotted in degrees.
  const auto to_plot_unit = [](const std::string& output, std::vector<double>* v) {
    if (output.rfind("q.", 0) != 0) return;
    for (double& x : *v) x *= 180.0 / 3.14159265358979323846;
  };
  for (const auto& o : d.heldout.outputs) {
    const std::string joint = o.substr(2);
    const bool angle = o.rfind("q.", 0) == 0;
    render::Series b, a;
    b.label = "baseline";
    b.colour = render::PaletteColour(7);
    a.label = "extended";
    a.colour = render::PaletteColour(0);
    HeldoutResidual(d, d.heldout_baseline, o, &b.x, &b.y);
    HeldoutResidual(d, d.heldout_extended, o, &a.x, &a.y);
    to_plot_unit(o, &b.y);
    to_plot_unit(o, &a.y);
    Figure res;
    res.path = dir + "/residuals_" + joint + ".png";
    res.axes.title = "held-out residual y - y_hat, " + o;
    res.axes.x_label = "time (s)";
    res.axes.y_label = angle ? "residual (deg)" : "residual";
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
    spec.axes.y_label = angle ? "periodogram (deg^2)" : "periodogram";
    spec.axes.log_y = true;
    spec.series = {sb, sa};
    Figure over;
    over.path = dir + "/prediction_" + joint + ".png";
    over.axes = res.axes;
    over.axes.title = "held-out " + o + ": measured and predicted";
    over.axes.y_label = angle ? "joint angle (deg)" : "value";
    render::Series meas, before, after;
    std::vector<double> unused_t, unused_y;
    HeldoutSeries(d, d.heldout_baseline, o, &meas.x, &meas.y, &before.y);
    HeldoutSeries(d, d.heldout_extended, o, &unused_t, &unused_y, &after.y);
    before.x = after.x = meas.x;
    for (auto* v : {&meas.y, &before.y, &after.y}) to_plot_unit(o, v);
    meas.label = "measured";
    meas.colour = render::PaletteColour(7);
    before.label = "calibrated model";
    before.colour = render::PaletteColour(1);
    after.label = "extended model";
    after.colour = render::PaletteColour(0);
    over.series = {meas, before, after};
    figures.push_back(over);
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
