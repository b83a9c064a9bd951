#include "diagnosis/reference.h"

#include <cmath>
#include <cstdio>
#include <exception>
#include <map>

#include "base/parallel.h"
#include "diagnosis/reduced_model.h"

namespace fesim::diagnosis {

std::vector<identification::MethodEntry> ReferenceMethods() { return ReducedModelMethods(); }

ReferenceResult FitReference(const MeasuredData& data,
                             const std::vector<identification::MethodEntry>& methods, int threads) {
  std::map<std::string, double> u_ref;
  const std::vector<Trial> train = ReducedTrainingTrials(data.train, data.channels, &u_ref);
  // The held-out trials whole, gaps filled for the methods that read their initial output.
  DataView whole = data.heldout;
  for (std::size_t t = 0; t < whole.use.size(); ++t) whole.use[t].assign(whole.use[t].size(), 1);
  const std::vector<Trial> held_inputs = ReducedTrainingTrials(whole, data.channels, &u_ref);
  struct Outcome {
    std::vector<double> nrmse;
    std::string error;
  };
  std::vector<Outcome> outcomes(methods.size());
  ParallelFor(methods.size(), threads, [&](std::size_t m) {
    try {
      const identification::FittedSimulator fitted = methods[m].fit_simulator(train, nullptr);
      std::vector<Trial> pred;
      for (const auto& tr : held_inputs) pred.push_back(fitted.simulate(tr));
      outcomes[m].nrmse = ViewNrmsePerOutput(data.heldout, pred);
    } catch (const std::exception& e) {
      outcomes[m].error = e.what();
    }
  });
  ReferenceResult out;
  for (std::size_t m = 0; m < methods.size(); ++m) {
    const Outcome& o = outcomes[m];
    if (!o.error.empty()) {
      out.tried.emplace_back(methods[m].name, "failed: " + o.error);
      continue;
    }
    double mean = 0.0;
    for (double v : o.nrmse) mean += v;
    mean /= static_cast<double>(std::max<std::size_t>(1, o.nrmse.size()));
    char buf[64];
    std::snprintf(buf, sizeof buf, "held-out NRMSE %.4f", mean);
    out.tried.emplace_back(methods[m].name, buf);
    if (std::isfinite(mean) && (out.method.empty() || mean < out.heldout_nrmse)) {
      out.method = methods[m].name;
      out.heldout_nrmse = mean;
      out.heldout_nrmse_per_output = o.nrmse;
    }
  }
  return out;
}

}  // namespace fesim::diagnosis
