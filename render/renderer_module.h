// The renderer's plug-in interface (base/module.h). OffscreenRenderer (renderer.h) draws through
// a RendererBackend made by the module fesim_render_osmesa.so (renderer_osmesa.cc), the only
// part of fesim linked with OSMesa — and through it Mesa's llvmpipe and LLVM, whose loading
// costs every process that links them ≈ 10 ms — so that only the commands that draw load them.
#pragma once

#include "render/image.h"
#include "render/scene.h"

namespace fesim::render {

/// One OSMesa context and its framebuffer (see OffscreenRenderer).
class RendererBackend {
 public:
  virtual ~RendererBackend() = default;
  /// As OffscreenRenderer::Render.
  virtual void Render(const Scene& scene, const Camera& camera, Image* out) = 0;
};

/// The module's file, beside the `fesim` executable.
inline constexpr char kRendererModuleFile[] = "fesim_render_osmesa.so";
/// Its factory's exported name and type: a new width × height backend (the caller owns it).
/// Throws std::runtime_error as OffscreenRenderer's constructor does.
inline constexpr char kRendererFactorySymbol[] = "fesim_render_create_backend";
using RendererFactory = RendererBackend*(int width_px, int height_px);

}  // namespace fesim::render
