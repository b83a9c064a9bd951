#include "apps/matfile.h"

#include <matio.h>
#include <unistd.h>

#include <cctype>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <vector>

namespace fesim {
namespace {

/// An open MAT 5 file at a temporary path that becomes `path` on Commit (removed otherwise).
class MatWriter {
 public:
  explicit MatWriter(const std::string& path)
      : path_(path), temp_(path + ".tmp." + std::to_string(::getpid()) + "." + TempSuffixHost()) {
    slot_ = RegisterTempFile(temp_);
    mat_ = Mat_CreateVer(temp_.c_str(), nullptr, MAT_FT_MAT5);
    if (mat_ == nullptr) {
      UnregisterTempFile(slot_);
      throw std::runtime_error(path + ": cannot create the .mat file");
    }
  }
  ~MatWriter() {
    if (mat_ != nullptr) Mat_Close(mat_);
    if (!committed_) std::remove(temp_.c_str());
    UnregisterTempFile(slot_);
  }
  MatWriter(const MatWriter&) = delete;
  MatWriter& operator=(const MatWriter&) = delete;

  /// A rows × cols double matrix from column-major `data`.
  void Doubles(const std::string& name, std::size_t rows, std::size_t cols,
               const std::vector<double>& data) {
    Write(Matrix(name.c_str(), rows, cols, data));
  }
  void Text(const std::string& name, const std::string& text) { Write(Chars(name.c_str(), text)); }
  /// A rows × cols cell of strings from column-major `texts`.
  void Cell(const std::string& name, std::size_t rows, std::size_t cols,
            const std::vector<std::string>& texts) {
    std::size_t dims[2] = {rows, cols};
    matvar_t* cell = Mat_VarCreate(name.c_str(), MAT_C_CELL, MAT_T_CELL, 2, dims, nullptr, 0);
    for (std::size_t k = 0; k < texts.size(); ++k)
      Mat_VarSetCell(cell, k, Chars(nullptr, texts[k]));
    Write(cell);
  }
  void Commit() {
    Mat_Close(mat_);
    mat_ = nullptr;
    if (std::rename(temp_.c_str(), path_.c_str()) != 0) {
      throw std::runtime_error(path_ + ": cannot write the .mat file");
    }
    committed_ = true;
  }

 private:
  static matvar_t* Matrix(const char* name, std::size_t rows, std::size_t cols,
                          const std::vector<double>& data) {
    std::size_t dims[2] = {rows, cols};
    // MAT_F_DONT_COPY_DATA unset: matio copies the data.
    return Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims,
                         const_cast<double*>(data.data()), 0);
  }
  static matvar_t* Chars(const char* name, const std::string& text) {
    std::size_t dims[2] = {1, text.size()};
    return Mat_VarCreate(name, MAT_C_CHAR, MAT_T_UTF8, 2, dims, const_cast<char*>(text.data()), 0);
  }
  void Write(matvar_t* v) {
    const int rc = v == nullptr ? -1 : Mat_VarWrite(mat_, v, MAT_COMPRESSION_NONE);
    if (v != nullptr) Mat_VarFree(v);
    if (rc != 0) throw std::runtime_error(path_ + ": cannot write a variable of the .mat file");
  }

  std::string path_, temp_;
  int slot_ = -1;
  mat_t* mat_ = nullptr;
  bool committed_ = false;
};

}  // namespace

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
