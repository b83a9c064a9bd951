// Plug-in modules opened at run time (dlopen): the parts of fesim whose libraries are large and
// rarely needed — the OSMesa renderer (render/), the MAT-file writer (apps/, libmatio) and the
// MPI transport (cluster/, Open MPI) — are CMake MODULE libraries built beside the `fesim`
// executable, so that a command that does not use them does not load their libraries (LLVM,
// HDF5, Open MPI: ≈ 60 shared objects and 450 000 relocations at every start).
//
// A module exports one `extern "C"` factory named in the header of its folder, which returns an
// object of an abstract C++ interface declared there (a typed plug-in: the factory's type is
// checked at compile time on both sides). The module and fesim share libstdc++, so exceptions
// and std::string cross the boundary. A module, once opened, stays loaded for the life of the
// process (objects it made may still be alive; dlopen counts the opens, nothing is closed).
#pragma once

#include <string>

namespace fesim {

/// The directories searched for a module, in order: the directory of the executable or shared
/// object holding fesim's code (the `fesim` binary, a test, the Python module), then the build
/// tree's module directory (compiled in, for the tests and the Python module of a build tree).
std::string ModuleSearchPath();

/// Opens module `file_name` (e.g. "fesim_render_osmesa.so") from ModuleSearchPath() and returns
/// the address of its exported symbol `symbol`. `global`: the module's libraries resolve the
/// symbols of objects they load later themselves (RTLD_GLOBAL; Open MPI's components need it).
/// Throws std::runtime_error with one line naming the module, where it was looked for, what it
/// is needed for (`purpose`) and the loader's reason, when it is missing or lacks the symbol.
void* ModuleSymbol(const std::string& file_name, const char* symbol, const std::string& purpose,
                   bool global = false);

/// ModuleSymbol cast to the factory's type `Fn` (declared in the folder's module header).
template <class Fn>
Fn* ModuleFunction(const std::string& file_name, const char* symbol, const std::string& purpose,
                   bool global = false) {
  return reinterpret_cast<Fn*>(ModuleSymbol(file_name, symbol, purpose, global));
}

}  // namespace fesim
