#pragma once

// A headless OpenGL 3.3 core context on EGL's surfaceless Mesa platform (DESIGN.md §6):
// eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA), eglBindAPI(EGL_OPENGL_API), a 3.3
// core context made current without a surface. Rendering goes into framebuffer objects.

#include <string>

namespace crop4d::sim {

class GlContext {
 public:
  // Throws std::runtime_error with a clear message when EGL or OpenGL 3.3 is unavailable.
  GlContext();
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  // Makes the context current on the calling thread.
  void MakeCurrent();
  // GL_RENDERER and GL_VERSION, e.g. "llvmpipe (LLVM 15.0.6, 256 bits), 4.5 (Core Profile)".
  const std::string& description() const { return description_; }
  // Whether a GL extension is supported.
  bool HasExtension(const std::string& name) const;

 private:
  void* display_ = nullptr;  // EGLDisplay
  void* context_ = nullptr;  // EGLContext
  std::string description_;
};

}  // namespace crop4d::sim
