#include "base/module.h"

#include <dlfcn.h>
#include <unistd.h>

#include <stdexcept>
#include <vector>

#ifndef FESIM_MODULE_BUILD_DIR
#error "FESIM_MODULE_BUILD_DIR (the build tree's module directory) must be defined"
#endif

namespace fesim {
namespace {

/// The directory of the object (executable or shared library) that holds this function.
std::string DirectoryOfThisObject() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&DirectoryOfThisObject), &info) == 0 ||
      info.dli_fname == nullptr) {
    return "";
  }
  std::string path = info.dli_fname;
  if (path.empty() || path[0] != '/') {
    // The main executable is named as it was started (relative, or no directory): ask the kernel.
    char buffer[4096];
    const ssize_t n = readlink("/proc/self/exe", buffer, sizeof buffer - 1);
    if (n <= 0) return "";
    path.assign(buffer, static_cast<std::size_t>(n));
  }
  const std::size_t slash = path.rfind('/');
  return slash == 0 ? "/" : path.substr(0, slash);
}

/// The directories of ModuleSearchPath(), without repeats.
std::vector<std::string> SearchDirectories() {
  std::vector<std::string> dirs;
  for (const std::string& dir : {DirectoryOfThisObject(), std::string(FESIM_MODULE_BUILD_DIR)}) {
    if (!dir.empty() && (dirs.empty() || dirs.back() != dir)) dirs.push_back(dir);
  }
  return dirs;
}

}  // namespace

std::string ModuleSearchPath() {
  std::string out;
  for (const std::string& dir : SearchDirectories()) out += (out.empty() ? "" : ":") + dir;
  return out;
}

void* ModuleSymbol(const std::string& file_name, const char* symbol, const std::string& purpose,
                   bool global) {
  const int flags = RTLD_NOW | (global ? RTLD_GLOBAL : RTLD_LOCAL);
  std::string reasons;
  for (const std::string& dir : SearchDirectories()) {
    const std::string path = dir + "/" + file_name;
    // Opened again on every call: dlopen returns the loaded module and counts the open; it is
    // never closed (see module.h), so the handle needs no owner.
    void* handle = dlopen(path.c_str(), flags);
    if (handle == nullptr) {
      const char* why = dlerror();
      reasons += std::string(reasons.empty() ? "" : "; ") + (why != nullptr ? why : path);
      continue;
    }
    dlerror();
    void* address = dlsym(handle, symbol);
    if (address == nullptr) {
      throw std::runtime_error(purpose + ": module " + path + " has no symbol " + symbol +
                               " (a module of another fesim build?)");
    }
    return address;
  }
  throw std::runtime_error(purpose + ": cannot load the module " + file_name + " (searched " +
                           ModuleSearchPath() + "): " + reasons);
}

}  // namespace fesim
