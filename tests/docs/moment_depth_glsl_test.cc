// The GLSL `OcclusionFraction` of docs/moment_depth_maps.md ("For renderer authors") runs on
// Mesa's llvmpipe (a software OpenGL ES 3.1 implementation, no GPU needed) in a compute shader,
// and gives what the C++ functions give: OcclusionFraction on 128-bit texels,
// OcclusionFractionOptimized64 on 64-bit codes. The shader is taken from the page itself, so the
// documented code is the tested code.
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl31.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iostream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "transient/reconstruct/moment_quantization.h"
#include "transient/reconstruct/power_moments.h"

namespace transient {
namespace {

// The first ```glsl block of the moment depth map page.
std::string DocumentedGlsl() {
  std::ifstream file(TRANSIENT_MOMENT_DEPTH_DOC);
  const std::string text((std::istreambuf_iterator<char>(file)), {});
  const std::string open = "```glsl\n";
  const size_t begin = text.find(open);
  if (begin == std::string::npos) return "";
  const size_t end = text.find("```", begin + open.size());
  if (end == std::string::npos) return "";
  return text.substr(begin + open.size(), end - begin - open.size());
}

// An OpenGL ES 3.1 context without a window (EGL_MESA_platform_surfaceless).
class GlContext {
 public:
  GlContext() {
    auto get_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (get_display == nullptr) {
      error_ = "no eglGetPlatformDisplayEXT";
      return;
    }
    display_ = get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    EGLint major = 0, minor = 0;
    if (display_ == EGL_NO_DISPLAY || !eglInitialize(display_, &major, &minor)) {
      error_ = "eglInitialize failed on the surfaceless platform";
      return;
    }
    eglBindAPI(EGL_OPENGL_ES_API);
    const EGLint attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 1,
                                 EGL_NONE};
    context_ = eglCreateContext(display_, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attributes);
    if (context_ == EGL_NO_CONTEXT ||
        !eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_)) {
      error_ = "no OpenGL ES 3.1 context";
    }
  }
  ~GlContext() {
    if (display_ != EGL_NO_DISPLAY) {
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
      eglTerminate(display_);
    }
  }
  const std::string& error() const { return error_; }

 private:
  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
  std::string error_;
};

// Inputs: per query a vec4 (b1..b4, or the four 16-bit codes as floats) and z_f. Output: the
// shader's occlusion fraction per query. `optimized` decodes the codes first.
constexpr char kShaderHead[] = R"(#version 310 es
precision highp float;
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Moments { vec4 moments[]; };
layout(std430, binding = 1) readonly buffer Queries { float zf[]; };
layout(std430, binding = 2) writeonly buffer Results { float occlusion[]; };
uniform uint count;
uniform bool optimized;
)";
constexpr char kShaderMain[] = R"(
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= count) return;
  if (optimized) {
    occlusion[i] = OcclusionFraction(DecodeOptimizedMoments(moments[i] / 65535.0), zf[i],
                                     6e-5, 0.628);
  } else {
    occlusion[i] = OcclusionFraction(moments[i], zf[i], 1e-5, 0.375);
  }
}
)";

// Compiles the page's functions into the compute program; the info log on failure.
GLuint BuildProgram(const std::string& functions, std::string* log) {
  const std::string source = std::string(kShaderHead) + functions + kShaderMain;
  const char* text = source.c_str();
  const GLuint shader = glCreateShader(GL_COMPUTE_SHADER);
  glShaderSource(shader, 1, &text, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char buffer[4096] = {};
    glGetShaderInfoLog(shader, sizeof(buffer), nullptr, buffer);
    *log = buffer;
    return 0;
  }
  const GLuint program = glCreateProgram();
  glAttachShader(program, shader);
  glLinkProgram(program);
  glDeleteShader(shader);
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char buffer[4096] = {};
    glGetProgramInfoLog(program, sizeof(buffer), nullptr, buffer);
    *log = buffer;
    return 0;
  }
  return program;
}

GLuint Buffer(GLuint binding, const void* data, size_t bytes) {
  GLuint buffer = 0;
  glGenBuffers(1, &buffer);
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, buffer);
  glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(bytes), data, GL_STATIC_DRAW);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, binding, buffer);
  return buffer;
}

std::vector<float> RunShader(GLuint program, const std::vector<float>& moments,
                             const std::vector<float>& z_f, bool optimized) {
  const size_t count = z_f.size();
  std::vector<float> out(count, -1.0f);
  const GLuint buffers[3] = {Buffer(0, moments.data(), moments.size() * sizeof(float)),
                             Buffer(1, z_f.data(), count * sizeof(float)),
                             Buffer(2, out.data(), count * sizeof(float))};
  glUseProgram(program);
  glUniform1ui(glGetUniformLocation(program, "count"), static_cast<GLuint>(count));
  glUniform1i(glGetUniformLocation(program, "optimized"), optimized ? 1 : 0);
  glDispatchCompute(static_cast<GLuint>((count + 63) / 64), 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, buffers[2]);
  const void* mapped = glMapBufferRange(GL_SHADER_STORAGE_BUFFER, 0,
                                        static_cast<GLsizeiptr>(count * sizeof(float)),
                                        GL_MAP_READ_BIT);
  if (mapped != nullptr) std::copy_n(static_cast<const float*>(mapped), count, out.begin());
  glUnmapBuffer(GL_SHADER_STORAGE_BUFFER);
  glDeleteBuffers(3, buffers);
  return out;
}

// Footprints of 1..4 surfaces with random weights in [-1, 1] (as a filtered texel holds), and
// queries anywhere in [-1.2, 1.2], also right at a surface.
struct Cases {
  std::vector<PowerMomentsF> moments;
  std::vector<float> z_f;
};
Cases RandomCases(int count) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> depth(-1.0, 1.0), weight(0.05, 1.0),
      query(-1.2, 1.2);
  Cases cases;
  for (int i = 0; i < count; ++i) {
    PowerMoments b{};
    double total = 0.0, first = 0.0;
    for (int l = 0; l <= i % 4; ++l) {
      const double z = depth(rng), w = weight(rng);
      if (l == 0) first = z;
      double power = 1.0;
      for (int j = 0; j < kPowerMomentCount; ++j, power *= z) b[j] += w * power;
      total += w;
    }
    PowerMomentsF f;
    for (int j = 0; j < kPowerMomentCount; ++j) f[j] = static_cast<float>(b[j] / total);
    cases.moments.push_back(f);
    cases.z_f.push_back(static_cast<float>(i % 7 == 0 ? first : query(rng)));
  }
  return cases;
}

// llvmpipe evaluates the same IEEE single-precision operations, but without the C++ code's
// fused multiply-adds and with its own sqrt and division: the two may round differently.
// Measured over these cases: at most 2.5e-4 apart. Mistakes in the GLSL move results by far
// more; checked by breaking it on purpose: the upper root instead of the lower (worst difference
// 1.0), b1 b2 for b1² in the variance (0.98), a sign in the decoded b3 (1.0, 64-bit), b4 scaled
// by 1.01 (0.73).
constexpr float kTolerance = 1e-3f;

TEST(MomentDepthGlsl, OcclusionFractionOnLlvmpipeMatchesTheCppFunctions) {
  const std::string functions = DocumentedGlsl();
  ASSERT_FALSE(functions.empty()) << "no ```glsl block in " << TRANSIENT_MOMENT_DEPTH_DOC;
  GlContext context;
  ASSERT_EQ(context.error(), "") << "OpenGL ES 3.1 through EGL on Mesa (llvmpipe) is needed";
  std::string log;
  const GLuint program = BuildProgram(functions, &log);
  ASSERT_NE(program, 0u) << log;

  const Cases cases = RandomCases(4000);
  const size_t n = cases.z_f.size();
  std::vector<float> moments(4 * n), codes(4 * n);
  std::vector<float> expected(n), expected_optimized(n);
  for (size_t i = 0; i < n; ++i) {
    const PowerMomentsF& b = cases.moments[i];
    for (int k = 0; k < 4; ++k) moments[4 * i + k] = b[k + 1];
    expected[i] = OcclusionFraction(b, cases.z_f[i]);
    QuantizedMoments64 q;
    EncodeOptimized64({b[0], b[1], b[2], b[3], b[4]}, &q);
    for (int k = 0; k < 4; ++k) codes[4 * i + k] = q.channel[k];
    expected_optimized[i] = OcclusionFractionOptimized64(q, cases.z_f[i]);
  }
  const std::vector<float> got = RunShader(program, moments, cases.z_f, false);
  const std::vector<float> got_optimized = RunShader(program, codes, cases.z_f, true);
  glDeleteProgram(program);

  float worst = 0.0f, worst_optimized = 0.0f;
  int intermediate = 0;
  for (size_t i = 0; i < n; ++i) {
    ASSERT_TRUE(std::isfinite(got[i]) && std::isfinite(got_optimized[i])) << "case " << i;
    EXPECT_NEAR(got[i], expected[i], kTolerance) << "case " << i << ", z_f " << cases.z_f[i];
    EXPECT_NEAR(got_optimized[i], expected_optimized[i], kTolerance) << "64-bit case " << i;
    worst = std::max(worst, std::abs(got[i] - expected[i]));
    worst_optimized = std::max(worst_optimized, std::abs(got_optimized[i] - expected_optimized[i]));
    intermediate += expected[i] > 0.05f && expected[i] < 0.95f;
  }
  // The cases exercise the partial-occlusion branch, not only 0 and 1.
  EXPECT_GT(intermediate, static_cast<int>(n / 10));
  RecordProperty("worst_difference_128", std::to_string(worst));
  RecordProperty("worst_difference_64", std::to_string(worst_optimized));
  std::cout << "GLSL vs C++ on " << n << " queries: worst difference " << worst
            << " (128-bit), " << worst_optimized << " (64-bit)\n";
}

}  // namespace
}  // namespace transient
