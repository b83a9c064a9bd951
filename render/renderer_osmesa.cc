// The OSMesa back end of OffscreenRenderer (render/renderer.h), built as the plug-in module
// fesim_render_osmesa.so (render/renderer_module.h, base/module.h): only this file links OSMesa
// (and through it Mesa's llvmpipe and LLVM), so that commands that draw nothing never load them.
#include <type_traits>

#include "render/renderer.h"
#include "render/renderer_module.h"

// clang-format off
#include <GL/osmesa.h>
#include <GL/gl.h>
// clang-format on

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace fesim::render {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kCapsuleSlices = 32;         ///< vertices around the axis.
constexpr int kHemisphereRings = 8;        ///< latitude steps from pole to equator.
constexpr double kPadLift_m = 0.0005;      ///< pads drawn this far out along their normal, m.
constexpr int kMaxGridLinesPerSide = 200;  ///< cap on grid lines each side of the target.
constexpr double kFloorHalfSize_m = 25;    ///< floor plane half size, m (grid lines stop nearer).
constexpr float kOpaqueAlpha = 0.999f;     ///< alpha at or above this is drawn opaque.

Vec3 Add(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 Sub(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 Scale(const Vec3& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
double Dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 Cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double Norm(const Vec3& a) { return std::sqrt(Dot(a, a)); }
Vec3 Normalized(const Vec3& a) {
  const double n = Norm(a);
  return n > 0 ? Scale(a, 1.0 / n) : Vec3{0, 0, 0};
}

/// A unit vector perpendicular to unit w.
Vec3 AnyPerpendicular(const Vec3& w) {
  const Vec3 helper = std::abs(w.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  return Normalized(Cross(helper, w));
}

void SetColour(const Rgba& c) { glColor4f(c.r, c.g, c.b, c.a); }

class OsMesaBackend final : public RendererBackend {
 public:
  int width = 0;
  int height = 0;
  OSMesaContext context = nullptr;
  std::vector<std::uint8_t> framebuffer;  ///< OSMesa colour buffer, RGBA, bottom-up.
  std::vector<std::uint8_t> readback;     ///< glReadPixels target, RGBA, bottom-up.
  std::vector<GLuint> capsule_indices;    ///< triangle list over the capsule vertex grid.
  std::vector<GLfloat> capsule_vertices;  ///< scratch: interleaved normal (3) + position (3).

  OsMesaBackend(int w, int h) : width(w), height(h) {
    if (w <= 0 || h <= 0 || w > kMaxImageSidePx || h > kMaxImageSidePx) {
      throw std::runtime_error("render: image size " + std::to_string(w) + "x" + std::to_string(h) +
                               " is invalid (each side must be 1-" +
                               std::to_string(kMaxImageSidePx) + " pixels)");
    }
    framebuffer.assign(4 * static_cast<std::size_t>(w) * h, 0);
    BuildCapsuleIndices();
    context = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, nullptr);
    if (context == nullptr) {
      throw std::runtime_error("render: OSMesaCreateContextExt failed (is libosmesa6 installed?)");
    }
    if (!MakeCurrent()) {
      OSMesaDestroyContext(context);
      throw std::runtime_error("render: OSMesaMakeCurrent failed for a " + std::to_string(w) + "x" +
                               std::to_string(h) + " buffer");
    }
  }

  ~OsMesaBackend() override {
    if (context != nullptr) OSMesaDestroyContext(context);
  }

  bool MakeCurrent() {
    return OSMesaMakeCurrent(context, framebuffer.data(), GL_UNSIGNED_BYTE, width, height) ==
           GL_TRUE;
  }

  static constexpr int kRings = 2 * (kHemisphereRings + 1);  // equator ring doubled
  static constexpr int kRingVertices = kCapsuleSlices + 1;   // seam vertex doubled

  void BuildCapsuleIndices() {
    capsule_indices.clear();
    for (int i = 0; i + 1 < kRings; ++i) {
      for (int j = 0; j < kCapsuleSlices; ++j) {
        const GLuint a = i * kRingVertices + j;
        const GLuint b = a + 1;
        const GLuint c = a + kRingVertices + 1;
        const GLuint d = a + kRingVertices;
        // Counter-clockwise seen from outside: (θ, φ) grid with dθ × dφ pointing outwards.
        capsule_indices.insert(capsule_indices.end(), {a, b, c, a, c, d});
      }
    }
    capsule_vertices.resize(static_cast<std::size_t>(kRings) * kRingVertices * 6);
  }

  /// Fills capsule_vertices for one capsule: rings from the p0 pole (φ = −90°) to the p1 pole.
  void TessellateCapsule(const Capsule& c) {
    const Vec3 axis = Sub(c.p1, c.p0);
    const double length = Norm(axis);
    const Vec3 w = length > 0 ? Scale(axis, 1.0 / length) : Vec3{0, 1, 0};
    const Vec3 u = AnyPerpendicular(w);
    const Vec3 v = Cross(w, u);  // u × v = w
    std::size_t k = 0;
    for (int i = 0; i < kRings; ++i) {
      const bool top = i > kHemisphereRings;
      const int step = top ? i - (kHemisphereRings + 1) : i;
      // Bottom hemisphere φ = −90°…0 around p0, top hemisphere φ = 0…90° around p1.
      const double phi = (kPi / 2) * step / kHemisphereRings - (top ? 0.0 : kPi / 2);
      const Vec3& centre = top ? c.p1 : c.p0;
      for (int j = 0; j < kRingVertices; ++j) {
        const double theta = 2 * kPi * (j % kCapsuleSlices) / kCapsuleSlices;
        const Vec3 radial = Add(Scale(u, std::cos(theta)), Scale(v, std::sin(theta)));
        const Vec3 n = Add(Scale(radial, std::cos(phi)), Scale(w, std::sin(phi)));
        const Vec3 p = Add(centre, Scale(n, c.radius_m));
        capsule_vertices[k++] = static_cast<GLfloat>(n.x);
        capsule_vertices[k++] = static_cast<GLfloat>(n.y);
        capsule_vertices[k++] = static_cast<GLfloat>(n.z);
        capsule_vertices[k++] = static_cast<GLfloat>(p.x);
        capsule_vertices[k++] = static_cast<GLfloat>(p.y);
        capsule_vertices[k++] = static_cast<GLfloat>(p.z);
      }
    }
  }

  void DrawCapsule(const Capsule& c) {
    TessellateCapsule(c);
    SetColour(c.colour);
    glInterleavedArrays(GL_N3F_V3F, 0, capsule_vertices.data());
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(capsule_indices.size()), GL_UNSIGNED_INT,
                   capsule_indices.data());
  }

  // Not const although it touches no member: it changes the state of the GL context this object
  // owns.
  void SetUpCamera(const CameraPose& pose) {  // NOLINT(readability-make-member-function-const)
    const double aspect = static_cast<double>(width) / height;
    const double distance = Norm(Sub(pose.target, pose.eye));
    const double z_near = std::max(0.01, 0.02 * distance);
    const double z_far = distance + 80.0;
    const double f = 1.0 / std::tan(pose.fov_y_deg * kPi / 360.0);
    // Column-major perspective matrix (as gluPerspective).
    const GLdouble projection[16] = {f / aspect,
                                     0,
                                     0,
                                     0,
                                     0,
                                     f,
                                     0,
                                     0,
                                     0,
                                     0,
                                     (z_far + z_near) / (z_near - z_far),
                                     -1,
                                     0,
                                     0,
                                     2 * z_far * z_near / (z_near - z_far),
                                     0};
    glMatrixMode(GL_PROJECTION);
    glLoadMatrixd(projection);

    // View matrix (as gluLookAt): rows s, u, −f; translation −R·eye.
    const Vec3 fwd = Normalized(Sub(pose.target, pose.eye));
    const Vec3 s = Normalized(Cross(fwd, pose.up));
    const Vec3 up = Cross(s, fwd);
    const GLdouble view[16] = {s.x,
                               up.x,
                               -fwd.x,
                               0,
                               s.y,
                               up.y,
                               -fwd.y,
                               0,
                               s.z,
                               up.z,
                               -fwd.z,
                               0,
                               -Dot(s, pose.eye),
                               -Dot(up, pose.eye),
                               Dot(fwd, pose.eye),
                               1};
    glMatrixMode(GL_MODELVIEW);
    glLoadIdentity();
    // Lights are fixed to the camera: set with the identity model-view (eye coordinates).
    const GLfloat key_direction[4] = {-0.35f, 0.55f, 0.75f, 0.0f};
    const GLfloat key_diffuse[4] = {0.72f, 0.72f, 0.70f, 1.0f};
    const GLfloat key_specular[4] = {0.25f, 0.25f, 0.25f, 1.0f};
    const GLfloat fill_direction[4] = {0.5f, -0.2f, 0.6f, 0.0f};
    const GLfloat fill_diffuse[4] = {0.25f, 0.26f, 0.30f, 1.0f};
    const GLfloat none[4] = {0, 0, 0, 1};
    const GLfloat ambient[4] = {0.28f, 0.28f, 0.30f, 1.0f};
    glLightfv(GL_LIGHT0, GL_POSITION, key_direction);
    glLightfv(GL_LIGHT0, GL_DIFFUSE, key_diffuse);
    glLightfv(GL_LIGHT0, GL_SPECULAR, key_specular);
    glLightfv(GL_LIGHT0, GL_AMBIENT, none);
    glLightfv(GL_LIGHT1, GL_POSITION, fill_direction);
    glLightfv(GL_LIGHT1, GL_DIFFUSE, fill_diffuse);
    glLightfv(GL_LIGHT1, GL_SPECULAR, none);
    glLightfv(GL_LIGHT1, GL_AMBIENT, none);
    glLightModelfv(GL_LIGHT_MODEL_AMBIENT, ambient);
    glLightModeli(GL_LIGHT_MODEL_TWO_SIDE, GL_FALSE);
    glEnable(GL_LIGHT0);
    glEnable(GL_LIGHT1);
    const GLfloat specular[4] = {0.3f, 0.3f, 0.3f, 1.0f};
    glMaterialfv(GL_FRONT_AND_BACK, GL_SPECULAR, specular);
    glMaterialf(GL_FRONT_AND_BACK, GL_SHININESS, 24.0f);
    glColorMaterial(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE);
    glEnable(GL_COLOR_MATERIAL);
    glLoadMatrixd(view);
  }

  void DrawFloor(const Scene& scene, const CameraPose& pose) {
    const double step = scene.grid_step_m;
    const double distance = Norm(Sub(pose.target, pose.eye));
    const int n = std::min(kMaxGridLinesPerSide,
                           static_cast<int>(std::ceil(std::max(3.0, 3.0 * distance) / step)));
    const double half = n * step;
    const double floor_half = std::max(kFloorHalfSize_m, half);
    const double cx = std::round(pose.target.x / step) * step;
    const double cz = std::round(pose.target.z / step) * step;
    const double y = scene.floor_y_m;
    glEnable(GL_LIGHTING);
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.0f, 1.0f);
    glColor4f(0.95f, 0.95f, 0.93f, 1.0f);
    glBegin(GL_QUADS);
    glNormal3f(0, 1, 0);
    glVertex3d(cx - floor_half, y, cz - floor_half);
    glVertex3d(cx - floor_half, y, cz + floor_half);
    glVertex3d(cx + floor_half, y, cz + floor_half);
    glVertex3d(cx + floor_half, y, cz - floor_half);
    glEnd();
    glDisable(GL_POLYGON_OFFSET_FILL);
    glDisable(GL_LIGHTING);
    glLineWidth(1.0f);
    glColor4f(0.60f, 0.61f, 0.63f, 1.0f);
    glBegin(GL_LINES);
    for (int i = -n; i <= n; ++i) {
      const double o = i * step;
      glVertex3d(cx + o, y, cz - half);
      glVertex3d(cx + o, y, cz + half);
      glVertex3d(cx - half, y, cz + o);
      glVertex3d(cx + half, y, cz + o);
    }
    glEnd();
  }

  void DrawPad(const Pad& pad) {
    const Vec3 n = Normalized(pad.normal);
    Vec3 u = Sub(pad.u_axis, Scale(n, Dot(pad.u_axis, n)));
    u = Norm(u) > 1e-12 ? Normalized(u) : AnyPerpendicular(n);
    const Vec3 v = Cross(n, u);
    const Vec3 c = Add(pad.centre, Scale(n, kPadLift_m));
    const Vec3 du = Scale(u, pad.half_u_m);
    const Vec3 dv = Scale(v, pad.half_v_m);
    const Vec3 corners[4] = {Sub(Sub(c, du), dv), Sub(Add(c, du), dv), Add(Add(c, du), dv),
                             Add(Sub(c, du), dv)};
    glEnable(GL_LIGHTING);
    SetColour(pad.colour);
    glBegin(GL_QUADS);
    glNormal3d(n.x, n.y, n.z);
    for (const Vec3& p : corners) glVertex3d(p.x, p.y, p.z);
    glEnd();
    glDisable(GL_LIGHTING);
    glLineWidth(1.0f);
    glColor4f(pad.colour.r * 0.4f, pad.colour.g * 0.4f, pad.colour.b * 0.4f, pad.colour.a);
    glBegin(GL_LINE_LOOP);
    for (const Vec3& p : corners) glVertex3d(p.x, p.y, p.z);
    glEnd();
  }

  void DrawPolyline(const Polyline& line) {
    if (line.points.size() < 2) return;
    const bool blend = line.colour.a < kOpaqueAlpha;
    if (blend) glEnable(GL_BLEND);
    SetColour(line.colour);
    glLineWidth(line.width_px);
    glBegin(GL_LINE_STRIP);
    for (const Vec3& p : line.points) glVertex3d(p.x, p.y, p.z);
    glEnd();
    // Square points at the joints fill the notches between wide segments.
    if (line.width_px > 2 && !blend) {
      glPointSize(line.width_px);
      glBegin(GL_POINTS);
      for (const Vec3& p : line.points) glVertex3d(p.x, p.y, p.z);
      glEnd();
    }
    if (blend) glDisable(GL_BLEND);
  }

  void Render(const Scene& scene, const Camera& camera, Image* out) override {
    ValidateScene(scene);
    const CameraPose pose = PoseAt(camera, scene.time_s);
    if (!MakeCurrent()) throw std::runtime_error("render: OSMesaMakeCurrent failed");
    while (glGetError() != GL_NO_ERROR) {
    }

    glViewport(0, 0, width, height);
    glClearColor(scene.background.r, scene.background.g, scene.background.b, 1.0f);
    glClearDepth(1.0);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LEQUAL);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glShadeModel(GL_SMOOTH);
    glDisable(GL_CULL_FACE);
    glDisable(GL_DITHER);
    SetUpCamera(pose);

    if (scene.draw_floor) DrawFloor(scene, pose);

    // Opaque capsules.
    glEnable(GL_LIGHTING);
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glFrontFace(GL_CCW);
    for (const Capsule& c : scene.capsules) {
      if (c.colour.a >= kOpaqueAlpha) DrawCapsule(c);
    }
    glDisable(GL_CULL_FACE);

    // Pads pulled towards the viewer so they win against the skin they lie on.
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(-1.0f, -2.0f);
    for (const Pad& p : scene.pads) DrawPad(p);
    glDisable(GL_POLYGON_OFFSET_FILL);

    glDisable(GL_LIGHTING);
    for (const Polyline& l : scene.polylines) {
      if (!l.draw_on_top) DrawPolyline(l);
    }

    // Translucent capsules: back to front by distance of the axis midpoint from the eye.
    std::vector<std::size_t> ghosts;
    for (std::size_t i = 0; i < scene.capsules.size(); ++i) {
      if (scene.capsules[i].colour.a < kOpaqueAlpha) ghosts.push_back(i);
    }
    if (!ghosts.empty()) {
      std::vector<double> depth(scene.capsules.size(), 0.0);
      for (std::size_t i : ghosts) {
        const Capsule& c = scene.capsules[i];
        depth[i] = Norm(Sub(Scale(Add(c.p0, c.p1), 0.5), pose.eye));
      }
      std::stable_sort(ghosts.begin(), ghosts.end(),
                       [&depth](std::size_t a, std::size_t b) { return depth[a] > depth[b]; });
      glEnable(GL_LIGHTING);
      glEnable(GL_BLEND);
      glDepthMask(GL_FALSE);
      glEnable(GL_CULL_FACE);
      for (std::size_t i : ghosts) DrawCapsule(scene.capsules[i]);
      glDisable(GL_CULL_FACE);
      glDepthMask(GL_TRUE);
      glDisable(GL_BLEND);
      glDisable(GL_LIGHTING);
    }

    glDisable(GL_DEPTH_TEST);
    for (const Polyline& l : scene.polylines) {
      if (l.draw_on_top) DrawPolyline(l);
    }
    glEnable(GL_DEPTH_TEST);

    ReadPixels(out);
    const GLenum error = glGetError();
    if (error != GL_NO_ERROR) {
      throw std::runtime_error("render: OpenGL error 0x" + ToHex(error) + " while drawing");
    }
    DrawOverlay(out, scene.overlay, scene.time_s);
  }

  void ReadPixels(Image* out) {
    // RGBA matches the framebuffer format (a plain copy inside Mesa); dropping alpha and flipping
    // rows here is cheaper than asking glReadPixels for GL_RGB.
    const std::size_t row = 4 * static_cast<std::size_t>(width);
    readback.resize(row * height);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, readback.data());
    out->width = width;
    out->height = height;
    out->rgb.resize(3 * static_cast<std::size_t>(width) * height);
    std::uint8_t* dst = out->rgb.data();
    for (int y = 0; y < height; ++y) {  // OpenGL rows are bottom-up; Image rows top-down.
      const std::uint8_t* src = &readback[row * (height - 1 - y)];
      for (int x = 0; x < width; ++x, src += 4, dst += 3) {
        dst[0] = src[0];
        dst[1] = src[1];
        dst[2] = src[2];
      }
    }
  }

  static std::string ToHex(unsigned value) {
    static constexpr char kDigits[] = "0123456789abcdef";
    std::string s;
    do {
      s.insert(s.begin(), kDigits[value & 0xF]);
      value >>= 4;
    } while (value != 0);
    return s;
  }
};

}  // namespace

}  // namespace fesim::render

extern "C" fesim::render::RendererBackend* fesim_render_create_backend(int width_px,
                                                                       int height_px) {
  return new fesim::render::OsMesaBackend(width_px, height_px);
}
static_assert(std::is_same_v<decltype(fesim_render_create_backend), fesim::render::RendererFactory>,
              "the module's factory must have the type render/renderer_module.h declares");
