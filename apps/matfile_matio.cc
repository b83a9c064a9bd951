// The libmatio back end of apps/matfile.h, built as the plug-in module fesim_matio.so
// (apps/matfile_module.h, base/module.h): only this file links libmatio.
#include <matio.h>

#include <type_traits>

#include "apps/matfile_module.h"

namespace fesim {
namespace {

class MatioFile final : public MatFileOut {
 public:
  explicit MatioFile(mat_t* mat) : mat_(mat) {}
  ~MatioFile() override { Close(); }

  bool Doubles(const std::string& name, std::size_t rows, std::size_t cols,
               const double* data) override {
    std::size_t dims[2] = {rows, cols};
    // MAT_F_DONT_COPY_DATA unset: matio copies the data.
    return Write(Mat_VarCreate(name.c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims,
                               const_cast<double*>(data), 0));
  }
  bool Text(const std::string& name, const std::string& text) override {
    return Write(Chars(name.c_str(), text));
  }
  bool Cell(const std::string& name, std::size_t rows, std::size_t cols,
            const std::vector<std::string>& texts) override {
    std::size_t dims[2] = {rows, cols};
    matvar_t* cell = Mat_VarCreate(name.c_str(), MAT_C_CELL, MAT_T_CELL, 2, dims, nullptr, 0);
    for (std::size_t k = 0; k < texts.size(); ++k)
      Mat_VarSetCell(cell, k, Chars(nullptr, texts[k]));
    return Write(cell);
  }
  void Close() override {
    if (mat_ != nullptr) Mat_Close(mat_);
    mat_ = nullptr;
  }

 private:
  static matvar_t* Chars(const char* name, const std::string& text) {
    std::size_t dims[2] = {1, text.size()};
    return Mat_VarCreate(name, MAT_C_CHAR, MAT_T_UTF8, 2, dims, const_cast<char*>(text.data()), 0);
  }
  bool Write(matvar_t* v) {
    const int rc = v == nullptr ? -1 : Mat_VarWrite(mat_, v, MAT_COMPRESSION_NONE);
    if (v != nullptr) Mat_VarFree(v);
    return rc == 0;
  }

  mat_t* mat_ = nullptr;
};

}  // namespace
}  // namespace fesim

extern "C" fesim::MatFileOut* fesim_mat_create(const char* path) {
  mat_t* mat = Mat_CreateVer(path, nullptr, MAT_FT_MAT5);
  return mat == nullptr ? nullptr : new fesim::MatioFile(mat);
}
static_assert(std::is_same_v<decltype(fesim_mat_create), fesim::MatFileFactory>,
              "the module's factory must have the type apps/matfile_module.h declares");
