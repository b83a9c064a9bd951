#include "apps/matfile.h"

#include <unistd.h>

#include <cctype>
#include <cstdio>
#include <functional>
#include <memory>
#include <stdexcept>
#include <vector>

#include "apps/matfile_module.h"
#include "base/module.h"

namespace fesim {
namespace {

/// An open MAT 5 file at a temporary path that becomes `path` on Commit (removed otherwise),
/// written through the matio module (apps/matfile_module.h), loaded at the first write.
class MatWriter {
 public:
  explicit MatWriter(const std::string& path)
      : path_(path), temp_(path + ".tmp." + std::to_string(::getpid()) + "." + TempSuffixHost()) {
    MatFileFactory* create =
        ModuleFunction<MatFileFactory>(kMatModuleFile, kMatFactorySymbol, "MAT-file output");
    slot_ = RegisterTempFile(temp_);
    mat_.reset(create(temp_.c_str()));
    if (mat_ == nullptr) {
      UnregisterTempFile(slot_);
      throw std::runtime_error(path + ": cannot create the .mat file");
    }
  }
  ~MatWriter() {
    mat_.reset();
    if (!committed_) std::remove(temp_.c_str());
    UnregisterTempFile(slot_);
  }
  MatWriter(const MatWriter&) = delete;
  MatWriter& operator=(const MatWriter&) = delete;

  /// A rows × cols double matrix from column-major `data`.
  void Doubles(const std::string& name, std::size_t rows, std::size_t cols,
               const std::vector<double>& data) {
    Check(mat_->Doubles(name, rows, cols, data.data()));
  }
  void Text(const std::string& name, const std::string& text) { Check(mat_->Text(name, text)); }
  /// A rows × cols cell of strings from column-major `texts`.
  void Cell(const std::string& name, std::size_t rows, std::size_t cols,
            const std::vector<std::string>& texts) {
    Check(mat_->Cell(name, rows, cols, texts));
  }
  void Commit() {
    mat_->Close();
    if (std::rename(temp_.c_str(), path_.c_str()) != 0) {
      throw std::runtime_error(path_ + ": cannot write the .mat file");
    }
    committed_ = true;
  }

 private:
  void Check(bool ok) const {
    if (!ok) throw std::runtime_error(path_ + ": cannot write a variable of the .mat file");
  }

  std::string path_, temp_;
  int slot_ = -1;
  std::unique_ptr<MatFileOut> mat_;
  bool committed_ = false;
};

}  // namespace

void RequireMatOutput() {
  ModuleFunction<MatFileFactory>(kMatModuleFile, kMatFactorySymbol, "MAT-file output");
}

std::string MatVariableName(const std::string& column) {
  std::string out = column;
  for (char& c : out) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') c = '_';
  }
  if (out.empty() || !std::isalpha(static_cast<unsigned char>(out[0]))) out = "v_" + out;
  return out.substr(0, 63);  // MATLAB's namelengthmax
}

void WriteDiscreteModelMat(const identification::DiscreteModel& m, const std::string& path) {
  if (m.b.size() != m.inputs.size() || m.b.empty()) {
    throw std::invalid_argument(path + ": the model needs one B polynomial per input");
  }
  MatWriter w(path);
  w.Doubles("Ts", 1, 1, {m.sample_time_s});
  w.Doubles("A", 1, m.a.size(), m.a);
  std::size_t nb = 0;
  for (const auto& b : m.b) nb = std::max(nb, b.size());
  std::vector<double> b(m.b.size() * nb, 0.0);  // column-major, one row per input
  for (std::size_t i = 0; i < m.b.size(); ++i) {
    for (std::size_t k = 0; k < m.b[i].size(); ++k) b[k * m.b.size() + i] = m.b[i][k];
  }
  w.Doubles("B", m.b.size(), nb, b);
  w.Doubles("C", 1, 1, {1.0});
  w.Doubles("D", 1, 1, {1.0});
  w.Doubles("F", 1, m.f.size(), m.f);
  w.Cell("InputName", 1, m.inputs.size(), m.inputs);
  w.Cell("InputUnit", 1, m.input_units.size(), m.input_units);
  w.Text("OutputName", m.output);
  w.Text("OutputUnit", m.output_unit);
  if (!m.nonlinearity_u.empty()) {
    const auto& u = m.nonlinearity_u[0];
    const auto& f = m.nonlinearity_f[0];
    std::vector<double> bp;
    for (std::size_t k = 0; k < u.size(); ++k) bp.insert(bp.end(), {u[k], f[k]});
    w.Doubles("Breakpoints", 2, u.size(), bp);
  }
  w.Doubles("OutputOffset", 1, 1, {m.output_offset});
  w.Commit();
}

void WriteTrialMat(const Trial& trial, const std::string& path) {
  MatWriter w(path);
  w.Doubles("time", trial.size(), 1, trial.time);
  std::vector<std::string> names;
  for (std::size_t k = 0; k < trial.names.size(); ++k) {
    const std::string var = MatVariableName(trial.names[k]);
    if (var == "time" || var == "columns" || var == "metadata") {
      throw std::runtime_error(path + ": column " + trial.names[k] +
                               " would overwrite the variable '" + var + "'");
    }
    w.Doubles(var, trial.size(), 1, trial.columns[k]);
    names.insert(names.end(), {trial.names[k], var});
  }
  w.Cell("columns", 2, trial.names.size(), names);
  std::vector<std::string> keys, values;
  for (const auto& [k, v] : trial.metadata) {
    keys.push_back(k);
    values.push_back(v);
  }
  std::vector<std::string> md = keys;  // column-major K × 2: keys, then values
  md.insert(md.end(), values.begin(), values.end());
  w.Cell("metadata", keys.size(), 2, md);
  w.Commit();
}

}  // namespace fesim
