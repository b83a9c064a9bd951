#include "diagnosis/stage_cache.h"

#include <stdexcept>

namespace fesim::diagnosis {

Json StageCache::GetJson(const std::vector<std::string>& stage,
                         const std::function<Json()>& compute) const {
  std::vector<std::string> parts = prefix_;
  parts.insert(parts.end(), stage.begin(), stage.end());
  Json value;
  if (cache_ != nullptr && cache_->Load(parts, &value)) {
    const std::lock_guard<std::mutex> lock(mutex_);  // stages may run on several threads
    if (cached_ != nullptr) ++*cached_;
    return value;
  }
  value = Json::Parse(compute().Dump(0));
  if (cache_ != nullptr) cache_->Store(parts, value);
  return value;
}

const Json& Member(const Json& j, const std::string& key) {
  const Json* m = j.Find(key);
  if (m == nullptr) throw std::runtime_error("diagnose: cached result without '" + key + "'");
  return *m;
}

std::string VectorKey(const std::string& name, const Eigen::VectorXd& x) {
  std::string text = name + "=";
  for (Eigen::Index k = 0; k < x.size(); ++k) text += ExactNumberText(x(k)) + ",";
  return text;
}

Json ToJson(const Eigen::VectorXd& v) {
  return {std::vector<double>(v.data(), v.data() + v.size())};
}

void FromJson(const Json& j, Eigen::VectorXd* v) {
  v->resize(static_cast<Eigen::Index>(j.Items().size()));
  for (Eigen::Index k = 0; k < v->size(); ++k) (*v)(k) = j.Items()[k].AsNumber();
}

Json ToJson(const Eigen::MatrixXd& m) {
  Json j = Json::Object();
  j.Set("rows", static_cast<long>(m.rows())).Set("cols", static_cast<long>(m.cols()));
  j.Set("column_major", std::vector<double>(m.data(), m.data() + m.size()));
  return j;
}

void FromJson(const Json& j, Eigen::MatrixXd* m) {
  const auto rows = static_cast<Eigen::Index>(Member(j, "rows").AsNumber());
  const auto cols = static_cast<Eigen::Index>(Member(j, "cols").AsNumber());
  Eigen::VectorXd data;
  FromJson(Member(j, "column_major"), &data);
  if (rows < 0 || cols < 0 || data.size() != rows * cols) {
    throw std::runtime_error("diagnose: cached matrix has the wrong size");
  }
  *m = Eigen::Map<const Eigen::MatrixXd>(data.data(), rows, cols);
}

Json ToJson(const FitResult& f) {
  Json j = Json::Object();
  j.Set("x", ToJson(f.x)).Set("ci95", ToJson(f.ci95)).Set("cost", f.cost);
  j.Set("map_cost", f.map_cost).Set("residuals", f.residuals).Set("simulations", f.simulations);
  j.Set("converged", f.converged);
  return j;
}

void FromJson(const Json& j, FitResult* f) {
  FromJson(Member(j, "x"), &f->x);
  FromJson(Member(j, "ci95"), &f->ci95);
  f->cost = Member(j, "cost").AsNumber();
  f->map_cost = Member(j, "map_cost").AsNumber();
  f->residuals = static_cast<long>(Member(j, "residuals").AsNumber());
  f->simulations = static_cast<int>(Member(j, "simulations").AsNumber());
  f->converged = Member(j, "converged").AsBool();
}

Json ToJson(const std::vector<Trial>& trials) { return TrialsToJson(trials); }

void FromJson(const Json& j, std::vector<Trial>* trials) { *trials = TrialsFromJson(j, "cache"); }

}  // namespace fesim::diagnosis
