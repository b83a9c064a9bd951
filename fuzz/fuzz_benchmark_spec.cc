// libFuzzer target: the benchmark study file loader (scenarios/benchmark_spec.h
// ParseBenchmarkSpec). Any input must either load or throw std::runtime_error whose message
// starts with the file name; anything else (crash, sanitizer report, other exception type, hang,
// runaway memory) is a finding. A loaded spec has at least one section, every section has at
// least one method and resolved study paths, and budgets within their documented ranges.
#include <sys/stat.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <string>

#include "base/trial.h"
#include "scenarios/benchmark_spec.h"

namespace {

// The study files the seeds name, created once in a private directory so that the loader's
// existence checks pass and the fuzzer reaches the keys behind them.
std::string& Dir() {
  static std::string dir;
  return dir;
}

void CheckSection(const std::optional<fesim::BenchmarkSection>& s) {
  if (!s) return;
  if (s->methods.empty() || s->study_path.empty() || s->quick_study_path.empty()) std::abort();
  // A quick sparse scenario only beside a sparse one (reaching).
  if (s->sparse_path.empty() != s->quick_sparse_path.empty()) std::abort();
}

void CheckBudget(const fesim::FullModelBudget& m) {
  if (m.keep < 1 || m.keep > 39 || m.starts < 1 || m.starts > 100 || m.max_iterations < 1 ||
      m.max_iterations > 1000 || !(m.integrator_tolerance >= 1e-8) ||
      !(m.integrator_tolerance <= 1e-2) || !(m.fd_relative_step >= 1e-8) ||
      !(m.fd_relative_step <= 0.1) || !(m.relative_tolerance >= 1e-12) ||
      !(m.relative_tolerance <= 0.1)) {
    std::abort();
  }
}

void CheckIndependent(const fesim::IndependentCohort& c) {
  if (c.participants < 0 || c.participants > 100 || c.seed > 1000000000u) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  char tmpl[] = "/tmp/fesim-fuzz-spec-XXXXXX";
  if (::mkdtemp(tmpl) == nullptr) std::abort();
  Dir() = tmpl;
  for (const char* name :
       {"study.yaml", "bench_hand_array.yaml", "bench_hand_array_quick.yaml", "bench_elbow.yaml",
        "bench_elbow_quick.yaml", "bench_tremor.yaml", "bench_tremor_quick.yaml",
        "bench_shoulder.yaml", "bench_shoulder_quick.yaml", "bench_reaching.yaml",
        "bench_reaching_quick.yaml", "bench_reaching_sparse.yaml",
        "bench_reaching_sparse_quick.yaml"}) {
    fesim::WriteFileAtomic(Dir() + "/" + name, "# fuzz placeholder\n");
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string path = Dir() + "/fuzz.yaml";
  try {
    const fesim::BenchmarkSpec b = fesim::ParseBenchmarkSpec(text, path);
    if (!b.hand_array && !b.elbow_tests && !b.tremor_wrist && !b.shoulder && !b.reaching) {
      std::abort();  // at least one section is required
    }
    for (const auto* s :
         {&b.hand_array, &b.elbow_tests, &b.tremor_wrist, &b.shoulder, &b.reaching}) {
      CheckSection(*s);
    }
    CheckBudget(b.full_model);
    CheckBudget(b.quick_full_model);
    CheckIndependent(b.independent);
    CheckIndependent(b.quick_independent);
    if (b.assumption_participants < 0 || b.assumption_participants > 1000) std::abort();
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind(path, 0) != 0) std::abort();  // message must name the file
  }
  return 0;
}
