#include "diagnosis/stages.h"

#include <algorithm>
#include <stdexcept>

#include "base/parallel.h"
#include "diagnosis/person.h"
#include "diagnosis/reference.h"

namespace fesim::diagnosis {

void StageContext::Report(double fraction, const std::string& stage) const {
  if (progress) {
    progress(fraction, stage + " [" + std::to_string(simulations->load()) + " simulations]");
  }
}

std::vector<std::string> StageContext::Map(
    std::size_t n, const std::function<std::string(std::size_t)>& fn) const {
  if (map) return map(n, fn);
  std::vector<std::string> texts(n);
  ParallelFor(n, fit.threads, [&](std::size_t k) { texts[k] = fn(k); });
  return texts;
}

namespace {

Json PersonValueJson(const PersonValue& v) {
  Json j = Json::Object();
  j.Set("name", v.name).Set("unit", v.unit).Set("nominal", v.nominal).Set("value", v.value);
  j.Set("ci95", v.ci95).Set("prior_width", v.prior_width).Set("fitted", v.fitted);
  j.Set("at_bound", v.at_bound).Set("prior_dominated", v.prior_dominated);
  j.Set("information", v.information);
  return j;
}

PersonValue PersonValueFrom(const Json& j) {
  PersonValue v;
  v.name = Member(j, "name").AsString();
  v.unit = Member(j, "unit").AsString();
  v.nominal = Member(j, "nominal").AsNumber();
  v.value = Member(j, "value").AsNumber();
  v.ci95 = Member(j, "ci95").AsNumber();
  v.prior_width = Member(j, "prior_width").AsNumber();
  v.fitted = Member(j, "fitted").AsBool();
  v.at_bound = Member(j, "at_bound").AsBool();
  v.prior_dominated = Member(j, "prior_dominated").AsBool();
  v.information = Member(j, "information").AsNumber();
  return v;
}

}  // namespace

Json ToJson(const CalibrationStage& s) {
  Json j = Json::Object();
  Json names = Json::Array();
  for (const auto& n : s.fitted_names) names.Push(n);
  j.Set("fitted_names", names).Set("fit", ToJson(s.fit)).Set("jacobian", ToJson(s.jacobian));
  j.Set("train_predictions", ToJson(s.train_predictions));
  j.Set("heldout_predictions", ToJson(s.heldout_predictions));
  Json table = Json::Array();
  for (const auto& v : s.table) table.Push(PersonValueJson(v));
  j.Set("table", table).Set("noise_rad", Json(s.noise_rad));
  j.Set("prior_sigma_rad", s.prior_sigma_rad).Set("starts", s.starts);
  return j;
}

void FromJson(const Json& j, CalibrationStage* s) {
  s->fitted_names.clear();
  for (const auto& n : Member(j, "fitted_names").Items()) s->fitted_names.push_back(n.AsString());
  FromJson(Member(j, "fit"), &s->fit);
  FromJson(Member(j, "jacobian"), &s->jacobian);
  FromJson(Member(j, "train_predictions"), &s->train_predictions);
  FromJson(Member(j, "heldout_predictions"), &s->heldout_predictions);
  s->table.clear();
  for (const auto& v : Member(j, "table").Items()) s->table.push_back(PersonValueFrom(v));
  s->noise_rad.clear();
  for (const auto& v : Member(j, "noise_rad").Items()) s->noise_rad.push_back(v.AsNumber());
  s->prior_sigma_rad = Member(j, "prior_sigma_rad").AsNumber();
  s->starts = static_cast<int>(Member(j, "starts").AsNumber());
}

Json ToJson(const ReferenceResult& r) {
  Json j = Json::Object();
  j.Set("method", r.method).Set("heldout_nrmse", r.heldout_nrmse);
  j.Set("per_output", Json(r.heldout_nrmse_per_output));
  Json tried = Json::Array();
  for (const auto& [name, what] : r.tried) {
    Json t = Json::Object();
    t.Set("method", name).Set("result", what);
    tried.Push(t);
  }
  j.Set("tried", tried);
  return j;
}

void FromJson(const Json& j, ReferenceResult* r) {
  r->method = Member(j, "method").AsString();
  r->heldout_nrmse = Member(j, "heldout_nrmse").AsNumber();
  r->heldout_nrmse_per_output.clear();
  for (const auto& v : Member(j, "per_output").Items()) {
    r->heldout_nrmse_per_output.push_back(v.AsNumber());
  }
  r->tried.clear();
  for (const auto& t : Member(j, "tried").Items()) {
    r->tried.emplace_back(Member(t, "method").AsString(), Member(t, "result").AsString());
  }
}

std::vector<ModelParameter> FittedPersonParameters(const StageContext& ctx,
                                                   const CalibrationStage& calibration) {
  std::vector<ModelParameter> out;
  for (const auto& p : PersonParameters(ctx.rig, ctx.library)) {
    if (std::find(calibration.fitted_names.begin(), calibration.fitted_names.end(), p.name) !=
        calibration.fitted_names.end()) {
      out.push_back(p);
    }
  }
  if (out.size() != calibration.fitted_names.size()) {
    throw std::runtime_error("diagnose: cached calibration names parameters this rig lacks");
  }
  return out;
}

CalibrationStage Calibrate(const StageContext& ctx, bool corner_starts_only) {
  ctx.Report(corner_starts_only ? 0.25 : 0.0,
             corner_starts_only ? "calibrating the person again from the corner starts"
                                : "calibrating the person");
  const std::vector<std::string> key = corner_starts_only
                                           ? std::vector<std::string>{"calibrate", "corner starts"}
                                           : std::vector<std::string>{"calibrate"};
  return ctx.cache.Get<CalibrationStage>(key, [&] {
    const DataView& train = ctx.data.train;
    PersonCalibrationOptions options = ctx.settings.person;
    options.corner_starts_only = corner_starts_only;
    const PersonCalibration person = CalibratePerson(ctx.rig, ctx.library, train, ctx.fit, options);
    CalibrationStage s;
    int sims = person.fit.simulations;
    for (const auto& p : person.fitted) s.fitted_names.push_back(p.name);
    s.fit = person.fit;
    s.table = person.table;
    s.noise_rad = person.noise_rad;
    s.prior_sigma_rad = person.prior_sigma_rad;
    s.starts = person.starts;
    s.train_predictions = person.fit.predictions;
    if (s.train_predictions.size() != train.trials.size()) {
      s.train_predictions = Predict(ctx.rig, person.fitted, person.fit.x, train, ctx.fit);
      sims += static_cast<int>(train.trials.size());
    }
    const Eigen::VectorXd r = StackResiduals(train, s.train_predictions);
    s.jacobian = person.fit.jacobian;
    // The Jacobian LM last formed may be at another point than the one kept.
    if (s.jacobian.rows() != r.size() || person.fit.jacobian_x != person.fit.x) {
      s.jacobian = ResidualJacobian(ctx.rig, person.fitted, person.fit.x, r, train, ctx.fit, &sims);
    }
    s.heldout_predictions =
        Predict(ctx.rig, person.fitted, person.fit.x, ctx.data.heldout, ctx.fit);
    sims += static_cast<int>(ctx.data.heldout.trials.size());
    *ctx.simulations += sims;
    return s;
  });
}

ReferenceResult Reference(const StageContext& ctx) {
  ctx.Report(0.25, "identifying the black-box reference");
  return ctx.cache.Get<ReferenceResult>(
      {"reference"}, [&] { return FitReference(ctx.data, ReferenceMethods(), ctx.fit.threads); });
}

}  // namespace fesim::diagnosis
