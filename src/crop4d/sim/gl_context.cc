#include "crop4d/sim/gl_context.h"

#define GL_GLEXT_PROTOTYPES
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <cstdio>
#include <stdexcept>

namespace crop4d::sim {
namespace {

std::string EglErrorText(const char* what) {
  char buffer[160];
  std::snprintf(buffer, sizeof(buffer), "%s failed (EGL error 0x%04x)", what, eglGetError());
  return buffer;
}

[[noreturn]] void Fail(const std::string& detail) {
  throw std::runtime_error(
      "renderer: no headless OpenGL 3.3 available (EGL surfaceless Mesa platform): " + detail +
      ". Install Mesa's EGL and llvmpipe driver (libegl-mesa0, libgl1-mesa-dri).");
}

}  // namespace

GlContext::GlContext() {
  const char* client_extensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (client_extensions == nullptr ||
      std::string(client_extensions).find("EGL_MESA_platform_surfaceless") == std::string::npos) {
    Fail("EGL_MESA_platform_surfaceless is not supported");
  }
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display == nullptr) Fail("eglGetPlatformDisplayEXT is missing");
  EGLDisplay display =
      get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (display == EGL_NO_DISPLAY) Fail(EglErrorText("eglGetPlatformDisplayEXT"));
  EGLint major = 0, minor = 0;
  if (!eglInitialize(display, &major, &minor)) Fail(EglErrorText("eglInitialize"));
  if (!eglBindAPI(EGL_OPENGL_API)) Fail(EglErrorText("eglBindAPI(EGL_OPENGL_API)"));
  const EGLint attributes[] = {EGL_CONTEXT_MAJOR_VERSION,
                               3,
                               EGL_CONTEXT_MINOR_VERSION,
                               3,
                               EGL_CONTEXT_OPENGL_PROFILE_MASK,
                               EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                               EGL_NONE};
  EGLContext context = eglCreateContext(display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attributes);
  if (context == EGL_NO_CONTEXT) Fail(EglErrorText("eglCreateContext(OpenGL 3.3 core)"));
  display_ = display;
  context_ = context;
  MakeCurrent();
  const char* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const char* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  description_ = std::string(renderer ? renderer : "?") + ", " + (version ? version : "?");
}

GlContext::~GlContext() {
  if (context_ != nullptr) {
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display_, context_);
  }
  // The display is shared by every context of the process: not terminated here.
}

void GlContext::MakeCurrent() {
  if (eglGetCurrentContext() == context_) return;
  if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_)) {
    throw std::runtime_error("renderer: " + EglErrorText("eglMakeCurrent"));
  }
}

bool GlContext::HasExtension(const std::string& name) const {
  GLint count = 0;
  glGetIntegerv(GL_NUM_EXTENSIONS, &count);
  for (GLint i = 0; i < count; ++i) {
    const char* extension = reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, i));
    if (extension != nullptr && name == extension) return true;
  }
  return false;
}

}  // namespace crop4d::sim
