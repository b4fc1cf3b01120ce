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

// The shadow-map coordinates and the weight of the shadow come from the vertex shader
// (ShadowCoordinates below).
in vec4 v_shadow;  // not centroid: exact shadow edges
centroid in float v_shadow_weight;
float ShadowFactor() {
  // One tap: the hardware compares and filters a 2×2 footprint (percentage-closer filtering).
  float s = texture(u_shadow_map, vec3(v_shadow.xy, v_shadow.z - 0.0004));
  return mix(1.0, s, v_shadow_weight);
}

// Aerial perspective; the weight comes from the vertex shader (HazeWeight below).
centroid in float v_haze;
vec3 Haze(vec3 color) { return mix(color, u_haze_color * u_brightness, v_haze); }
)";

// Shared by the vertex shaders of the lit surfaces. What varies smoothly over a surface is
// computed per vertex, not per pixel: on llvmpipe (the renderer's usual target: the CPU) the
// fragment shaders are most of a frame, and vertices are few next to pixels. Such outputs are
// interpolated at the `centroid`: with multisampling a pixel centre may lie outside the
// triangle it shades, where plain interpolation extrapolates (negative sunlight at leaf edges).
inline constexpr const char* kLitVertexCommon = R"(
uniform vec3 u_sun_dir;        // unit vector towards the sun (world)
uniform vec3 u_sun_color;
uniform vec3 u_ambient_color;
uniform float u_brightness;
uniform vec3 u_camera_pos;
uniform mat4 u_shadow_matrix;
uniform float u_shadow_enabled;
centroid out float v_haze;
out vec4 v_shadow;  // not centroid: exact shadow edges
centroid out float v_shadow_weight;

// Aerial perspective: the haze weight of a point (smooth: exp(-d / 450 m)).
float HazeWeight(vec3 world) { return 1.0 - exp(-length(world - u_camera_pos) / 450.0); }

// Shadow-map coordinates (an orthographic light: w = 1) and the weight of the shadow, which
// fades out towards the border of the shadowed square and is 0 outside it, beyond the light's
// far plane, or with shadows off.
void ShadowCoordinates(vec3 world) {
  v_shadow = u_shadow_matrix * vec4(world, 1.0);
  vec2 edge = min(v_shadow.xy, 1.0 - v_shadow.xy);
  v_shadow_weight = u_shadow_enabled * smoothstep(0.0, 0.06, min(edge.x, edge.y)) *
                    step(v_shadow.z, 0.9999);
}
)";

inline constexpr const char* kTerrainVertex = R"(
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec4 a_normal;  // xyz normal; w = 1 for skirt vertices
layout(location = 2) in vec4 a_macro1;  // the soil macro texture, layer 1 (kMacroPeriod1)
layout(location = 3) in vec4 a_macro2;  // … and layer 2 (kMacroPeriod2, rotated)
uniform mat4 u_view_proj;
uniform vec4 u_field_box;      // min x, min y, max x, max y of the cultivated field
uniform float u_wet;           // 0 dry … 1 just rained
out vec3 v_world;  // not centroid: the soil's mip level comes from its derivatives
centroid out vec3 v_soil_tint;   // the soil's albedo factor: large-scale colour, moisture, wetness
centroid out vec3 v_grass_tint;  // the same for the grass beyond the field
centroid out float v_grass;      // 0 soil … 1 grass
centroid out vec3 v_ambient;     // sky light reaching the surface
centroid out vec3 v_sun;         // sunlight reaching it where unshadowed
void main() {
  vec3 p = a_position;
  p.z -= a_normal.w * 0.06;
  v_world = p;
  // Two large-scale variation layers at incommensurate scales (the soil macro texture,
  // sampled per vertex: it is smooth over metres).
  vec4 m1 = a_macro1, m2 = a_macro2;
  vec3 tint = (m1.rgb * 1.275) * (0.88 + 0.12 * m2.rgb * 1.275);
  float moisture = max(m1.a, 0.7 * m2.a);
  // Grass beyond the cultivated field.
  vec2 d = max(u_field_box.xy - p.xy, p.xy - u_field_box.zw);
  float outside = length(max(d, 0.0)) + min(max(d.x, d.y), 0.0);
  v_grass = smoothstep(0.0, 2.5, outside + 1.5 * (m2.a - 0.5));
  float wet = mix(1.0, 0.58 + 0.1 * (1.0 - moisture), u_wet * (1.0 - v_grass));
  v_soil_tint = tint * (1.0 - 0.12 * moisture) * wet;
  v_grass_tint = tint * wet;
  // The terrain is smooth at its grid's scale: Gouraud shading.
  vec3 n = normalize(a_normal.xyz);
  v_ambient = u_ambient_color * (0.75 + 0.25 * n.z) * u_brightness;
  v_sun = u_sun_color * max(dot(n, u_sun_dir), 0.0) * u_brightness;
  v_haze = HazeWeight(p);
  ShadowCoordinates(p + 0.01 * n);
  gl_Position = u_view_proj * vec4(p, 1.0);
}
)";

// The soil: a large procedural texture hex-tiled with random offsets per tile vertex
// (Mikkelsen, "Practical Real-Time Hex-Tiling", JCGT 11(2), 2022, after Heitz & Neyret,
// "High-Performance By-Example Noise using a Histogram-Preserving Blending Operator", 2018),
// times the large-scale variation, or grass outside the field (kTerrainVertex).
inline constexpr const char* kTerrainFragment = R"(
uniform sampler2D u_soil;
uniform float u_soil_extent;   // metres covered by the soil texture
uniform float u_soil_size;     // its texels per side
uniform uint u_soil_seed;
in vec3 v_world;
centroid in vec3 v_soil_tint;
centroid in vec3 v_grass_tint;
centroid in float v_grass;
centroid in vec3 v_ambient;
centroid in vec3 v_sun;
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

  float luma = dot(soil, vec3(0.3, 0.55, 0.15));
  vec3 grass = vec3(0.24, 0.36, 0.12) * (0.4 + 1.3 * luma) * v_grass_tint;
  vec3 albedo = mix(soil * v_soil_tint, grass, v_grass);
  out_color = vec4(Haze(albedo * (v_ambient + v_sun * ShadowFactor())), 1.0);
}
)";

inline constexpr const char* kPlantVertex = R"(
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec4 a_normal;
layout(location = 2) in vec4 a_color;  // rgb albedo; a = 1 on leaf blades
uniform mat4 u_view_proj;
// Wind: x = sway amplitude (m), y and z = the current phases of two gust waves (rad).
uniform vec4 u_sway;
centroid out vec3 v_ambient;  // reflected sky light
centroid out vec3 v_sun;      // reflected (and transmitted) sunlight where unshadowed
// Two-sided leaves: the normal faces the camera; the underside is paler and some sunlight
// shines through a leaf lit from behind. Lit per vertex (leaves are small next to pixels).
void main() {
  // Leaf blades sway in the wind: two gust waves of ≈1 m wavelength travel over the field, so
  // nearby leaves move together; stems stay put. Amplitude 0: the position is unchanged.
  vec3 position = a_position;
  position.xy += u_sway.x * a_color.a *
                 vec2(sin(dot(a_position.xy, vec2(5.3, 3.1)) + u_sway.y),
                      sin(dot(a_position.xy, vec2(-2.7, 6.1)) + u_sway.z));
  vec3 n = normalize(a_normal.xyz);
  bool back = dot(n, u_camera_pos - position) < 0.0;
  if (back) n = -n;
  float blade = a_color.a;
  vec3 albedo = a_color.rgb;
  if (back) albedo *= mix(vec3(1.0), vec3(1.2, 1.15, 1.05), blade);
  float ndl = dot(n, u_sun_dir);
  float direct = max(ndl, 0.0) + blade * 0.3 * max(-ndl, 0.0);
  v_ambient = albedo * u_ambient_color * (0.55 + 0.3 * n.z) * u_brightness;
  v_sun = albedo * u_sun_color * direct * u_brightness;
  v_haze = HazeWeight(position);
  ShadowCoordinates(position);
  gl_Position = u_view_proj * vec4(position, 1.0);
}
)";

inline constexpr const char* kPlantFragment = R"(
centroid in vec3 v_ambient;
centroid in vec3 v_sun;
layout(location = 0) out vec4 out_color;
void main() { out_color = vec4(Haze(v_ambient + v_sun * ShadowFactor()), 1.0); }
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

inline constexpr const char* kTreeVertex = R"(
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec2 a_uv;
layout(location = 2) in vec3 a_normal;
uniform mat4 u_view_proj;
out vec2 v_uv;  // not centroid: the foliage's mip level comes from its derivatives
centroid out vec3 v_light;
void main() {
  v_uv = a_uv;
  float ndl = abs(dot(normalize(a_normal), u_sun_dir));
  v_light = (0.9 * u_ambient_color + 0.6 * u_sun_color * ndl) * u_brightness;
  v_haze = HazeWeight(a_position);
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}
)";

inline constexpr const char* kTreeFragment = R"(
uniform sampler2D u_foliage;
in vec2 v_uv;
centroid in vec3 v_light;
layout(location = 0) out vec4 out_color;
void main() { out_color = vec4(Haze(texture(u_foliage, v_uv).rgb * v_light), 1.0); }
)";

}  // namespace crop4d::sim::shaders
