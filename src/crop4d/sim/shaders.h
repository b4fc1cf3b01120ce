#pragma once

// GLSL 3.30 core sources of the renderer. Lighting is Lambertian with an ambient sky term; the
// sun's shadows come from a shadow map sampled with hardware depth comparison (2×2 PCF per
// tap); the soil is hex-tiled to hide its period.

namespace crop4d::sim::shaders {

// Shared uniforms and helpers of the lit passes.
inline constexpr const char* kLightingCommon = R"(
uniform vec3 u_sun_dir;        // unit vector towards the sun (world)
uniform vec3 u_sun_color;
uniform vec3 u_ambient_color;
uniform vec3 u_haze_color;
uniform vec3 u_camera_pos;
uniform float u_brightness;
uniform sampler2DShadow u_shadow_map;
uniform float u_shadow_enabled;

float ShadowFactor(vec4 shadow_pos) {
  vec3 p = shadow_pos.xyz / shadow_pos.w;
  if (u_shadow_enabled < 0.5 || p.x <= 0.0 || p.x >= 1.0 || p.y <= 0.0 || p.y >= 1.0 ||
      p.z >= 1.0) {
    return 1.0;
  }
  // One tap: the hardware compares and filters a 2×2 footprint (percentage-closer filtering).
  float s = texture(u_shadow_map, vec3(p.xy, p.z - 0.0004));
  // Fade out towards the border of the shadowed region.
  vec2 edge = min(p.xy, 1.0 - p.xy);
  return mix(1.0, s, smoothstep(0.0, 0.06, min(edge.x, edge.y)));
}

vec3 Haze(vec3 color, vec3 world) {
  float d = length(world - u_camera_pos);
  return mix(color, u_haze_color * u_brightness, 1.0 - exp(-d / 450.0));
}
)";

inline constexpr const char* kTerrainVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec4 a_normal;  // xyz normal; w = 1 for skirt vertices
uniform mat4 u_view_proj;
uniform mat4 u_shadow_matrix;
out vec3 v_world;
out vec3 v_normal;
out vec4 v_shadow;
void main() {
  vec3 p = a_position;
  p.z -= a_normal.w * 0.06;
  v_world = p;
  v_normal = a_normal.xyz;
  v_shadow = u_shadow_matrix * vec4(p + 0.01 * a_normal.xyz, 1.0);
  gl_Position = u_view_proj * vec4(p, 1.0);
}
)";

// The soil: a large procedural texture hex-tiled with random offsets per tile vertex
// (Mikkelsen, "Practical Real-Time Hex-Tiling", JCGT 11(2), 2022, after Heitz & Neyret,
// "High-Performance By-Example Noise using a Histogram-Preserving Blending Operator", 2018),
// times two large-scale variation layers at incommensurate scales; grass outside the field.
inline constexpr const char* kTerrainFragment = R"(
uniform sampler2D u_soil;
uniform sampler2D u_macro;
uniform float u_soil_extent;   // metres covered by the soil texture
uniform float u_soil_size;     // its texels per side
uniform uint u_soil_seed;
uniform vec4 u_field_box;      // min x, min y, max x, max y of the cultivated field
uniform float u_wet;           // 0 dry … 1 just rained
in vec3 v_world;
in vec3 v_normal;
in vec4 v_shadow;
layout(location = 0) out vec4 out_color;

uint HashU(uint x) {
  x ^= x >> 16; x *= 0x7feb352du; x ^= x >> 15; x *= 0x846ca68bu; x ^= x >> 16;
  return x;
}
vec2 Hash2(ivec2 p) {
  uint h = HashU(uint(p.x) * 73856093u ^ HashU(uint(p.y) ^ u_soil_seed));
  return vec2(float(h & 0xffffu), float(h >> 16)) / 65536.0;
}

void TriangleGrid(vec2 st, out vec3 w, out ivec2 v1, out ivec2 v2, out ivec2 v3) {
  st *= 3.4641016;  // 2 sqrt(3)
  vec2 skewed = vec2(st.x, -0.57735027 * st.x + 1.15470054 * st.y);
  ivec2 base = ivec2(floor(skewed));
  vec3 temp = vec3(fract(skewed), 0.0);
  temp.z = 1.0 - temp.x - temp.y;
  float s = step(0.0, -temp.z);
  float s2 = 2.0 * s - 1.0;
  w = vec3(-temp.z * s2, s - temp.y * s2, s - temp.x * s2);
  v1 = base + ivec2(int(s), int(s));
  v2 = base + ivec2(int(s), int(1.0 - s));
  v3 = base + ivec2(int(1.0 - s), int(s));
}

void main() {
  vec2 uv = v_world.xy / u_soil_extent;
  // Mip level from the continuous coordinates (the hashed offsets jump between tiles).
  vec2 dx = dFdx(uv) * u_soil_size, dy = dFdy(uv) * u_soil_size;
  float lod = 0.5 * log2(max(dot(dx, dx), dot(dy, dy)));
  vec3 w;
  ivec2 v1, v2, v3;
  TriangleGrid(uv, w, v1, v2, v3);
  vec3 c1 = textureLod(u_soil, uv + Hash2(v1), lod).rgb;
  vec3 c2 = textureLod(u_soil, uv + Hash2(v2), lod).rgb;
  vec3 c3 = textureLod(u_soil, uv + Hash2(v3), lod).rgb;
  w = pow(w, vec3(7.0));  // sharpen the blend to keep the contrast
  w /= (w.x + w.y + w.z);
  vec3 soil = w.x * c1 + w.y * c2 + w.z * c3;

  vec4 m1 = texture(u_macro, v_world.xy / 61.7);
  vec2 q = mat2(0.8, 0.6, -0.6, 0.8) * v_world.xy / 17.3 + vec2(0.37, 0.71);
  vec4 m2 = texture(u_macro, q);
  vec3 tint = (m1.rgb * 1.275) * (0.88 + 0.12 * m2.rgb * 1.275);
  float moisture = max(m1.a, 0.7 * m2.a);
  vec3 albedo = soil * tint * (1.0 - 0.12 * moisture);

  // Grass beyond the cultivated field.
  vec2 d = max(u_field_box.xy - v_world.xy, v_world.xy - u_field_box.zw);
  float outside = length(max(d, 0.0)) + min(max(d.x, d.y), 0.0);
  float grass = smoothstep(0.0, 2.5, outside + 1.5 * (m2.a - 0.5));
  float luma = dot(soil, vec3(0.3, 0.55, 0.15));
  vec3 grass_color = vec3(0.24, 0.36, 0.12) * (0.4 + 1.3 * luma) * tint;
  albedo = mix(albedo, grass_color, grass);
  albedo *= mix(1.0, 0.58 + 0.1 * (1.0 - moisture), u_wet * (1.0 - grass));

  vec3 n = normalize(v_normal);
  float ndl = max(dot(n, u_sun_dir), 0.0);
  float shadow = ShadowFactor(v_shadow);
  vec3 light = u_ambient_color * (0.75 + 0.25 * n.z) + u_sun_color * ndl * shadow;
  out_color = vec4(Haze(albedo * light * u_brightness, v_world), 1.0);
}
)";

inline constexpr const char* kPlantVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec4 a_normal;
layout(location = 2) in vec4 a_color;
uniform mat4 u_view_proj;
uniform mat4 u_shadow_matrix;
out vec3 v_world;
out vec3 v_normal;
out vec4 v_color;
out vec4 v_shadow;
void main() {
  v_world = a_position;
  v_normal = a_normal.xyz;
  v_color = a_color;
  v_shadow = u_shadow_matrix * vec4(a_position, 1.0);
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}
)";

// Two-sided leaves: the normal faces the camera; the underside is paler and some sunlight
// shines through a leaf lit from behind.
inline constexpr const char* kPlantFragment = R"(
in vec3 v_world;
in vec3 v_normal;
in vec4 v_color;
in vec4 v_shadow;
layout(location = 0) out vec4 out_color;
void main() {
  vec3 n = normalize(v_normal);
  bool back = dot(n, u_camera_pos - v_world) < 0.0;
  if (back) n = -n;
  float blade = v_color.a;
  vec3 albedo = v_color.rgb;
  if (back) albedo *= mix(vec3(1.0), vec3(1.2, 1.15, 1.05), blade);
  float ndl = dot(n, u_sun_dir);
  float shadow = ShadowFactor(v_shadow);
  float direct = max(ndl, 0.0) + blade * 0.3 * max(-ndl, 0.0);
  vec3 light = u_ambient_color * (0.55 + 0.3 * n.z) + u_sun_color * direct * shadow;
  out_color = vec4(Haze(albedo * light * u_brightness, v_world), 1.0);
}
)";

inline constexpr const char* kShadowVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
uniform mat4 u_light_view_proj;
void main() { gl_Position = u_light_view_proj * vec4(a_position, 1.0); }
)";

// Masks pixels at the near plane (window depth 0): nothing drawn later passes the depth test.
inline constexpr const char* kMaskVertex = R"(#version 330 core
layout(location = 0) in vec2 a_position;
void main() { gl_Position = vec4(a_position, -1.0, 1.0); }
)";

inline constexpr const char* kShadowFragment = R"(#version 330 core
void main() {}
)";

inline constexpr const char* kSkyVertex = R"(#version 330 core
void main() {
  vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
  gl_Position = vec4(p, 1.0, 1.0);  // on the far plane
}
)";

// Sky: a gradient from the horizon haze to the zenith, the sun's disc and glow, and clouds
// from value noise on a plane above the field.
inline constexpr const char* kSkyFragment = R"(
uniform mat3 u_world_from_camera;
uniform vec4 u_intrinsics;  // fx, fy, cx, cy of the undistorted render
uniform vec2 u_cloud_offset;
uniform float u_cloudiness;
layout(location = 0) out vec4 out_color;

float Hash(vec2 p) { return fract(sin(dot(p, vec2(127.1, 311.7))) * 43758.5453); }
float Noise(vec2 p) {
  vec2 i = floor(p), f = fract(p);
  vec2 u = f * f * (3.0 - 2.0 * f);
  return mix(mix(Hash(i), Hash(i + vec2(1, 0)), u.x), mix(Hash(i + vec2(0, 1)), Hash(i + vec2(1, 1)), u.x), u.y);
}
float Fbm(vec2 p) {
  float s = 0.0, a = 0.5;
  for (int i = 0; i < 5; ++i) { s += a * Noise(p); p = p * 2.03 + vec2(1.7, 9.2); a *= 0.5; }
  return s;
}
void main() {
  vec2 pixel = gl_FragCoord.xy - 0.5;
  vec3 ray = vec3((pixel.x - u_intrinsics.z) / u_intrinsics.x,
                  (pixel.y - u_intrinsics.w) / u_intrinsics.y, 1.0);
  vec3 d = normalize(u_world_from_camera * ray);
  float e = d.z;
  vec3 zenith = vec3(0.20, 0.40, 0.78);
  vec3 sky = mix(u_haze_color, zenith, pow(clamp(e, 0.0, 1.0), 0.45));
  if (e > 0.0) {
    vec2 p = d.xy / (e + 0.06) * 1.2 + u_cloud_offset;
    float c = smoothstep(0.48, 0.78, Fbm(p)) * u_cloudiness * smoothstep(0.0, 0.08, e);
    sky = mix(sky, vec3(0.93, 0.94, 0.96) * (0.8 + 0.2 * e), c);
  }
  float s = max(dot(d, u_sun_dir), 0.0);
  sky += u_sun_color * (pow(s, 3000.0) * 8.0 + pow(s, 16.0) * 0.12);
  out_color = vec4(sky * u_brightness, 1.0);
}
)";

inline constexpr const char* kTreeVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec2 a_uv;
layout(location = 2) in vec3 a_normal;
uniform mat4 u_view_proj;
out vec3 v_world;
out vec2 v_uv;
out vec3 v_normal;
void main() {
  v_world = a_position;
  v_uv = a_uv;
  v_normal = a_normal;
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}
)";

inline constexpr const char* kTreeFragment = R"(
uniform sampler2D u_foliage;
in vec3 v_world;
in vec2 v_uv;
in vec3 v_normal;
layout(location = 0) out vec4 out_color;
void main() {
  vec3 albedo = texture(u_foliage, v_uv).rgb;
  float ndl = abs(dot(normalize(v_normal), u_sun_dir));
  vec3 light = 0.9 * u_ambient_color + 0.6 * u_sun_color * ndl;
  out_color = vec4(Haze(albedo * light * u_brightness, v_world), 1.0);
}
)";

}  // namespace crop4d::sim::shaders
