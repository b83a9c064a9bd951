// The MAT-file writer's plug-in interface (base/module.h). matfile.cc writes through a
// MatFileOut made by the module fesim_matio.so (matfile_matio.cc), the only part of fesim linked
// with libmatio — and through it HDF5, curl, TLS and Kerberos libraries, which would cost every
// fesim process their loading — so that only the commands that write .mat files load them.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace fesim {

/// One MAT 5 file open for writing (no compression). Each call returns false when matio fails.
class MatFileOut {
 public:
  virtual ~MatFileOut() = default;  ///< closes the file if Close was not called.
  /// A rows × cols double matrix from column-major `data` (rows · cols values).
  virtual bool Doubles(const std::string& name, std::size_t rows, std::size_t cols,
                       const double* data) = 0;
  /// A 1 × n char array (UTF-8).
  virtual bool Text(const std::string& name, const std::string& text) = 0;
  /// A rows × cols cell of strings from column-major `texts` (rows · cols of them).
  virtual bool Cell(const std::string& name, std::size_t rows, std::size_t cols,
                    const std::vector<std::string>& texts) = 0;
  /// Closes the file (afterwards only destruction).
  virtual void Close() = 0;
};

/// The module's file, beside the `fesim` executable.
inline constexpr char kMatModuleFile[] = "fesim_matio.so";
/// Its factory's exported name and type: a new MAT 5 file at `path` (the caller owns it), or
/// nullptr when matio cannot create it.
inline constexpr char kMatFactorySymbol[] = "fesim_mat_create";
using MatFileFactory = MatFileOut*(const char* path);

}  // namespace fesim
