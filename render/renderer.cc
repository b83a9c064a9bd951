#include "render/renderer.h"

#include <cmath>

#include "base/module.h"
#include "render/renderer_module.h"

namespace fesim::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3 Sub(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
double Dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 Cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Vec3 Normalized(const Vec3& a) {
  const double n = std::sqrt(Dot(a, a));
  const double s = 1.0 / n;  // as renderer_osmesa.cc: the same bits
  return n > 0 ? Vec3{a.x * s, a.y * s, a.z * s} : Vec3{0, 0, 0};
}

}  // namespace

struct OffscreenRenderer::Impl {
  int width = 0;
  int height = 0;
  std::unique_ptr<RendererBackend> backend;
};

ImagePoint ProjectToImage(const CameraPose& pose, int width_px, int height_px, const Vec3& p_WP) {
  const Vec3 fwd = Normalized(Sub(pose.target, pose.eye));
  const Vec3 s = Normalized(Cross(fwd, pose.up));
  const Vec3 up = Cross(s, fwd);
  const Vec3 r = Sub(p_WP, pose.eye);
  const double depth = Dot(r, fwd);
  ImagePoint out;
  if (!(depth > 0)) return out;
  const double f = 1.0 / std::tan(pose.fov_y_deg * kPi / 360.0);
  const double aspect = static_cast<double>(width_px) / height_px;
  const double ndc_x = f / aspect * Dot(r, s) / depth;  // −1 left … +1 right
  const double ndc_y = f * Dot(r, up) / depth;          // −1 bottom … +1 top
  out.x_px = (ndc_x + 1) * 0.5 * width_px;
  out.y_px = (1 - ndc_y) * 0.5 * height_px;
  out.in_front = true;
  return out;
}

OffscreenRenderer::OffscreenRenderer(int width_px, int height_px)
    : impl_(std::make_unique<Impl>()) {
  RendererFactory* create = ModuleFunction<RendererFactory>(
      kRendererModuleFile, kRendererFactorySymbol, "render (OSMesa off-screen renderer)");
  impl_->width = width_px;
  impl_->height = height_px;
  impl_->backend.reset(create(width_px, height_px));
}
OffscreenRenderer::~OffscreenRenderer() = default;
OffscreenRenderer::OffscreenRenderer(OffscreenRenderer&& other) noexcept = default;
OffscreenRenderer& OffscreenRenderer::operator=(OffscreenRenderer&& other) noexcept = default;

int OffscreenRenderer::width() const { return impl_->width; }
int OffscreenRenderer::height() const { return impl_->height; }

Image OffscreenRenderer::Render(const Scene& scene, const Camera& camera) {
  Image image;
  impl_->backend->Render(scene, camera, &image);
  return image;
}

void OffscreenRenderer::Render(const Scene& scene, const Camera& camera, Image* out) {
  impl_->backend->Render(scene, camera, out);
}

}  // namespace fesim::render
