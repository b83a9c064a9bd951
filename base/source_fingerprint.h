// The identity of the code a build was made from, for the result caches (base/result_cache.h)
// of `fesim diagnose`, `fesim simulate` and `fesim benchmark`: a result computed by other code —
// another candidate range, prior, probe or integrator setting — is never read back as if this
// build had made it. The definition is generated at build time (cmake/source_fingerprint.cmake,
// target fesim_source_fingerprint in base/CMakeLists.txt) and changes whenever a source of the
// library folders or a CMake file does.
#pragma once

namespace fesim {

/// "<version>+<16 hex digits>": the project version and the SHA-256 over the paths and SHA-256s
/// of the library folders' sources and the CMake files this build was made from.
const char* BuildIdentity();

}  // namespace fesim
