// GLSL of the peeling renderer (peeling_renderer.cc), three programs:
// - peeling: draws the meshes; the uniform u_kind selects what a draw does
//   (kPass* below). The peel textures hold t, the distance from the eye
//   (camera or light) divided by u_far, so that the MDF offsets of Sec. 4.1
//   (d_f, d_b, in mm along the ray) add to them linearly. The depth buffer
//   keeps the projection's own depth: along one pixel's ray it orders
//   surfaces as t does, and leaving gl_FragDepth alone lets the depth and
//   stencil tests run before the fragment shader.
// - finishing: a full-screen pass that marks the pixels a front-face pass
//   found in the stencil, so that the peel passes themselves never write it.
// - resolve: shades each shown pixel once from the surface the view pass
//   left (deferred), per material: the BTF (Sec. 5) or the ambient term.
// Each program's source is kGlslVersion, then the shared code where it needs
// it, then its own.
#pragma once

namespace mesocap::render {

inline constexpr int kPassSurface = 0;          // BTF only: the nearest front face -> surface
inline constexpr int kPassBackPeel = 1;         // Fig. 7: nearest back face beyond Zpeel_now -> z_pb, z_pb - d_b
inline constexpr int kPassFrontPeel = 2;        // Fig. 7: front face with z_pf + d_f <= z_pb - d_b -> surface
inline constexpr int kPassShadowPlain = 3;      // shadow map of the reference surface
inline constexpr int kPassShadowFrontPeel = 4;  // Sec. 4.2: z(p_f) + s d_max / cos(theta_l), curved

inline constexpr const char* kGlslVersion = "#version 450 core\n";

// Direction lookups shared by the peeling pass (MDF) and the resolve pass
// (BTF, ambient term): directions as (theta, phi) and the blend tables.
inline constexpr const char* kDirectionGlsl = R"glsl(
const float PI = 3.14159265358979;

// (theta, phi) of a local direction, phi in [0, 2 pi).
vec2 Spherical(vec3 d) {
  float theta = acos(clamp(d.z / max(length(d), 1e-20), -1.0, 1.0));
  float phi = atan(d.y, d.x);
  if (phi < 0.0) phi += 2.0 * PI;
  return vec2(theta, phi);
}

// Neighbouring directions of the set and their weights (DirectionBlendTable).
// Directions below the local horizon (interpolated normals at grazing) read
// the last ring, as SamplingSet::Interpolate does.
void Blend(isampler2D index_table, sampler2D weight_table, vec2 angles, out ivec4 index, out vec4 weight) {
  ivec2 size = textureSize(index_table, 0);
  int ip = clamp(int(angles.y / (2.0 * PI) * float(size.x)), 0, size.x - 1);
  int it = clamp(int(angles.x / (0.5 * PI) * float(size.y)), 0, size.y - 1);
  index = texelFetch(index_table, ivec2(ip, it), 0);
  weight = texelFetch(weight_table, ivec2(ip, it), 0);
}

ivec2 Texel(vec2 t, ivec2 size) { return clamp(ivec2(fract(t) * vec2(size)), ivec2(0), size - 1); }
)glsl";

inline constexpr const char* kPeelingVertexShader = R"glsl(
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_texcoord;
layout(location = 3) in vec4 a_tangent;
layout(location = 4) in float a_scale;
uniform mat4 u_view_proj;
out vec3 v_position;
out vec3 v_normal;
out vec2 v_texcoord;
out vec4 v_tangent;
out float v_scale;
void main() {
  v_position = a_position;
  v_normal = a_normal;
  v_texcoord = a_texcoord;
  v_tangent = a_tangent;
  v_scale = a_scale;
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}
)glsl";

inline constexpr const char* kPeelingFragmentShader = R"glsl(
in vec3 v_position;
in vec3 v_normal;
in vec2 v_texcoord;
in vec4 v_tangent;
in float v_scale;
// Front faces of the view: out0 colour (plain surfaces; 0 under a material,
// which the resolve pass shades), out1 (coverage, shadow), out2 the surface
// (texture coordinates, irradiance or -1 in shadow, material + 1), out3 the
// local view and light directions as (theta, phi). Light passes and back
// faces: out0 and out1 as documented at their writes.
layout(location = 0) out vec4 out0;
layout(location = 1) out vec4 out1;
layout(location = 2) out vec4 out2;
layout(location = 3) out vec4 out3;

uniform int u_kind;
uniform vec3 u_eye;
uniform float u_far;
uniform sampler2D u_peel_now;  // Zpeel_now
uniform sampler2D u_zbo;       // z_pb - d_b of this layer

uniform bool u_has_material;
uniform int u_material;            // index into the scene's materials
uniform vec3 u_albedo;
uniform sampler2DArray u_mdf;      // layer = view; -1 = no hit
uniform isampler2D u_view_index;
uniform sampler2D u_view_weight;
uniform float u_d_max;

uniform vec3 u_light_position;
uniform float u_light_intensity;
uniform float u_ambient_scale;
uniform float u_exposure;
uniform mat4 u_light_view_proj;
uniform float u_light_far;
uniform float u_shadow_texel;  // shadow-map texel size per mm of distance from the light
uniform sampler2D u_shadow_map;
uniform bool u_shadow_at_mesostructure;  // Sec. 4.2: test p' = p + s D(v) v instead of p

vec3 g_normal;
vec3 g_tangent;
vec3 g_bitangent;
// Screen derivatives of position and normal, taken in main() before any
// discard (derivatives need the whole 2x2 quad).
vec3 g_dpx, g_dpy, g_dnx, g_dny;

// Surface coordinates (a, b) of a tangent offset delta in the screen
// derivatives of position, delta ~= a dp/dx + b dp/dy, by least squares.
// Conditioning: when the two derivatives are (nearly) parallel (a triangle
// seen edge-on) there is no fit and the result is false.
bool ScreenCoordinates(vec3 delta, out vec2 ab) {
  float a11 = dot(g_dpx, g_dpx), a12 = dot(g_dpx, g_dpy), a22 = dot(g_dpy, g_dpy);
  float det = a11 * a22 - a12 * a12;
  ab = vec2(0.0);
  if (det <= 1e-6 * a11 * a22) return false;
  float b1 = dot(g_dpx, delta), b2 = dot(g_dpy, delta);
  ab = vec2(b1 * a22 - b2 * a12, a11 * b2 - a12 * b1) / det;
  return true;
}

// The interpolated normal of the reference surface under a point q near
// p, extrapolated from the normal's screen derivatives: the attached-shadow
// test of the mesostructure point p' = p + s D v uses the surface it hangs
// from, not p's (they differ by the surface's curvature over s D sin(theta_v)).
// Edge-on triangles keep p's normal.
vec3 NormalUnder(vec3 q) {
  vec3 delta = q - v_position;
  vec2 ab;
  if (!ScreenCoordinates(delta - g_normal * dot(g_normal, delta), ab)) return g_normal;
  return normalize(v_normal + ab.x * g_dnx + ab.y * g_dny);
}

// The normal curvature of the reference surface at p along the tangent part
// of `ray`, from the normal's screen derivatives (> 0 convex); 0 when the ray
// is along the normal or the triangle is seen edge-on.
float CurvatureAlong(vec3 ray) {
  vec3 along = ray - g_normal * dot(ray, g_normal);
  vec2 ab;
  if (length(along) <= 1e-4 || !ScreenCoordinates(normalize(along), ab)) return 0.0;
  return dot(ab.x * g_dnx + ab.y * g_dny, normalize(along));
}

// Length of the path of a ray entering the mesostructure slab at p (cosine c
// to the normal) down to depth h. On a flat slab it is h / c, which Sec. 4.1
// and 4.2 use; on a curved one it is longer on convex parts and shorter on
// concave ones, which matters where rays graze (silhouettes, terminators).
// With the normal curvature k along the ray the slab is locally a shell of
// radius 1/k and the path solves |p + L ray - centre| = 1/k - h:
// L = h (2 - k h) / (c + sqrt(c^2 - k h (2 - k h))), h / c at k = 0 (this
// form has no cancellation as k -> 0). Negative when the ray never gets that
// deep: it leaves a convex shell again first.
float PathToDepth(float c, float k, float h) {
  float disc = c * c - k * h * (2.0 - k * h);
  if (disc < 0.0) return -1.0;
  return h * (2.0 - k * h) / (c + sqrt(disc));
}

// The light's path through the slab at p down to its base at depth h (the
// shadow map's Sec. 4.2 offset), or the chord 2 c / k of a convex shell the
// ray passes above the base of. c is clamped at 0.05 (87 degrees) so grazing
// light does not push the base to infinity on flat and concave parts.
float SlabPathLength(vec3 ray, float h) {
  float c = max(dot(-ray, g_normal), 0.05);
  float k = CurvatureAlong(ray);
  float path = PathToDepth(c, k, h);
  return path >= 0.0 ? path : 2.0 * c / k;
}

vec3 ToLocal(vec3 d) { return vec3(dot(d, g_tangent), dot(d, g_bitangent), dot(d, g_normal)); }

// D(x, y, d) in mm for the local direction d (pointing away from the
// surface); -1 for no hit. Neighbouring views are blended; when half or more
// of the weight says no hit, the blend is no hit (a distance and "no hit" do
// not average).
float MdfDistance(vec2 t, vec3 d) {
  ivec4 index;
  vec4 weight;
  Blend(u_view_index, u_view_weight, Spherical(d), index, weight);
  ivec2 texel = Texel(t, textureSize(u_mdf, 0).xy);
  float sum = 0.0, total = 0.0, no_hit = 0.0;
  for (int k = 0; k < 4; ++k) {
    if (weight[k] <= 0.0) continue;
    float value = texelFetch(u_mdf, ivec3(texel, index[k]), 0).r;
    if (value < 0.0) {
      no_hit += weight[k];
    } else {
      sum += weight[k] * value;
      total += weight[k];
    }
  }
  if (no_hit >= 0.5 || total <= 0.0) return -1.0;
  return sum / total;
}

// Macroscale shadow of point q from the shadow map. The bias covers the
// depth change across one shadow-map texel on a surface tilted away from the
// light (slope-scaled, capped at 10 texels for grazing light).
bool InShadow(vec3 q) {
  vec4 clip = u_light_view_proj * vec4(q, 1.0);
  if (clip.w <= 0.0) return false;
  vec2 ndc = clip.xy / clip.w;
  if (any(greaterThan(abs(ndc), vec2(1.0)))) return false;
  float stored = texture(u_shadow_map, ndc * 0.5 + 0.5).r;
  vec3 to_light = u_light_position - q;
  float distance_to_light = length(to_light);
  float c = abs(dot(g_normal, to_light / distance_to_light));
  float texel = distance_to_light * u_shadow_texel;
  float bias = texel * (1.0 + min(sqrt(max(1.0 - c * c, 0.0)) / max(c, 1e-3), 10.0));
  return distance_to_light > (stored * u_light_far) + bias;
}

// The front-face point p (the reference surface) seen along `ray` (from the
// eye) as the resolve pass needs it, shadow and irradiance decided here;
// d = D(x, y, v) in mm (< 0: no hit) places the mesostructure point
// p' = p + s D ray for the shadow test (Sec. 4.2). Plain surfaces are shaded
// here: they cost no more than writing their surface.
void WriteSurface(vec3 ray, float d) {
  vec3 v = ToLocal(-ray);
  vec3 q = v_position;
  if (u_shadow_at_mesostructure && d > 0.0) {
    // On the flat slab p' lies at depth s D cos(theta_v); on the curved one
    // the ray reaches that depth after PathToDepth (flat where it never does).
    float c = dot(-ray, g_normal);
    float path = c > 0.0 ? PathToDepth(c, CurvatureAlong(ray), v_scale * d * c) : -1.0;
    q += ray * (path >= 0.0 ? path : v_scale * d);
  }
  vec3 to_light = u_light_position - q;
  float r2 = dot(to_light, to_light);
  vec3 l_world = to_light * inversesqrt(r2);
  vec3 l = ToLocal(l_world);
  // Facing away from the light is a macroscale (attached) shadow.
  float facing = u_shadow_at_mesostructure ? dot(NormalUnder(q), l_world) : l.z;
  bool shadowed = facing <= 0.0 || InShadow(q);
  float irradiance = max(l.z, 0.0) * (u_light_intensity / r2);
  if (u_has_material) {
    out0 = vec4(0.0);
    out2 = vec4(v_texcoord, shadowed ? -1.0 : irradiance, float(u_material + 1));
    out3 = vec4(Spherical(v), Spherical(l));
  } else {
    // A plain Lambertian surface: T = albedo / pi, La = albedo.
    vec3 radiance = shadowed ? u_ambient_scale * u_albedo : u_albedo / PI * irradiance;
    out0 = vec4(u_exposure * radiance, 1.0);
    out2 = vec4(0.0);
    out3 = vec4(0.0);
  }
  out1 = vec4(1.0, shadowed ? 1.0 : 0.0, 0.0, 1.0);
}

void main() {
  g_dpx = dFdx(v_position);
  g_dpy = dFdy(v_position);
  g_dnx = dFdx(v_normal);
  g_dny = dFdy(v_normal);
  g_normal = normalize(v_normal);
  g_tangent = normalize(v_tangent.xyz - g_normal * dot(g_normal, v_tangent.xyz));
  g_bitangent = v_tangent.w * cross(g_normal, g_tangent);
  vec3 from_eye = v_position - u_eye;
  float distance_from_eye = length(from_eye);
  vec3 ray = from_eye / distance_from_eye;
  float t = distance_from_eye / u_far;
  if (u_kind == 0) {  // kPassSurface
    WriteSurface(ray, u_has_material && u_shadow_at_mesostructure ? MdfDistance(v_texcoord, ToLocal(-ray)) : 0.0);
    return;
  }
  if (u_kind == 3) {  // kPassShadowPlain
    out0 = vec4(t);
    return;
  }
  // Peeling: only layers beyond the previous one.
  if (t <= texelFetch(u_peel_now, ivec2(gl_FragCoord.xy), 0).r) discard;
  if (u_kind == 1) {  // kPassBackPeel
    // At p_b the ray leaves the object: the outgoing direction points away
    // from the surface, and D along its reverse is the distance from p_b back
    // to the mesostructure (Sec. 4.1, d_b = s_b D(x_b, y_b, v_b)).
    float d = u_has_material ? MdfDistance(v_texcoord, ToLocal(ray)) : 0.0;
    float d_b = d < 0.0 ? 1e30 : v_scale * d;
    out0 = vec4(t);
    out1 = vec4(t - d_b / u_far);
    return;
  }
  // Front faces (the depth test already keeps z_pf < z_pb).
  float d = u_has_material ? MdfDistance(v_texcoord, ToLocal(-ray)) : 0.0;
  if (d < 0.0) discard;  // the ray leaves the slab through a hole: no hit in this layer
  float z_pb_minus_d_b = texelFetch(u_zbo, ivec2(gl_FragCoord.xy), 0).r;
  if (t + v_scale * d / u_far > z_pb_minus_d_b) discard;  // passes beside the mesostructure
  if (u_kind == 4) {  // kPassShadowFrontPeel
    // Depth of the blocker's mesostructure base (Sec. 4.2): z(p_f) plus the
    // light's path through the slab, s d_max / cos(theta_l) on a flat base;
    // 5% more, because grooves at the full depth sit exactly at the base and
    // the curvature is estimated (without it, large shadow maps show acne).
    out0 = vec4(t + 1.05 * SlabPathLength(ray, v_scale * u_d_max) / u_far);
    out1 = vec4(1.0, 0.0, 0.0, 1.0);  // found: the finishing pass closes the pixel
    return;
  }
  WriteSurface(ray, d);
}
)glsl";

// A triangle that covers the viewport, for the finishing and resolve passes.
inline constexpr const char* kFullScreenVertexShader = R"glsl(
void main() {
  vec2 corner = vec2((gl_VertexID & 1) * 4 - 1, (gl_VertexID & 2) * 2 - 1);
  gl_Position = vec4(corner, 0.0, 1.0);
}
)glsl";

// Finishing: passes (and lets the stencil record the pass) where the front
// faces of this pass found the mesostructure (coverage set).
inline constexpr const char* kFinishingFragmentShader = R"glsl(
uniform sampler2D u_found;  // the sweep's masks: x = 1 where a layer was found
void main() {
  if (texelFetch(u_found, ivec2(gl_FragCoord.xy), 0).x == 0.0) discard;
}
)glsl";

// Resolve: the radiance of one material's pixels from the view's surface.
inline constexpr const char* kResolveFragmentShader = R"glsl(
layout(location = 0) out vec4 out0;

uniform int u_material;                 // shades the pixels of this material
uniform sampler2D u_surface;            // texture coordinates, irradiance (-1: shadow), material + 1
uniform sampler2D u_directions;         // view (theta, phi), light (theta, phi)
uniform sampler2DArray u_rows;          // paper: layer k * Nlight + light; per_view: k * Nview + view; else k
uniform sampler2D u_columns;            // x = view (paper), light (per_view) or view * Nlight + light;
                                        // y = k (clustered: cluster * rank + k; per_view: view * rank + k)
uniform sampler2D u_clusters;           // clustered: each texel's cluster
uniform sampler2DArray u_ambient;       // layer = view
uniform isampler2D u_view_index;
uniform sampler2D u_view_weight;
uniform isampler2D u_light_index;
uniform sampler2D u_light_weight;
uniform int u_rank;
uniform int u_light_count;
uniform int u_view_count;
uniform int u_layout;                   // 0 paper, 1 per_texel, 2 clustered, 3 per_view
uniform mat3 u_factored_to_rgb;
uniform float u_ambient_scale;
uniform float u_exposure;

// T(x, y, v, l) from the factors (v, l as (theta, phi)), blended over 4 x 4 neighbouring directions.
vec3 Btf(vec2 t, vec2 v, vec2 l) {
  ivec4 vi, li;
  vec4 vw, lw;
  Blend(u_view_index, u_view_weight, v, vi, vw);
  Blend(u_light_index, u_light_weight, l, li, lw);
  ivec2 texel = Texel(t, textureSize(u_rows, 0).xy);
  int first_column_row = u_layout == 2 ? int(texelFetch(u_clusters, texel, 0).r) * u_rank : 0;
  vec3 sum = vec3(0.0);
  for (int a = 0; a < 4; ++a) {
    if (vw[a] <= 0.0) continue;
    for (int b = 0; b < 4; ++b) {
      if (lw[b] <= 0.0) continue;
      vec3 value = vec3(0.0);
      for (int k = 0; k < u_rank; ++k) {
        if (u_layout == 3) {
          value += texelFetch(u_rows, ivec3(texel, k * u_view_count + vi[a]), 0).rgb *
                   texelFetch(u_columns, ivec2(li[b], vi[a] * u_rank + k), 0).rgb;
        } else if (u_layout != 0) {
          value += texelFetch(u_rows, ivec3(texel, k), 0).rgb *
                   texelFetch(u_columns, ivec2(vi[a] * u_light_count + li[b], first_column_row + k), 0).rgb;
        } else {
          value += texelFetch(u_rows, ivec3(texel, k * u_light_count + li[b]), 0).rgb *
                   texelFetch(u_columns, ivec2(vi[a], k), 0).rgb;
        }
      }
      sum += vw[a] * lw[b] * value;
    }
  }
  return u_factored_to_rgb * sum;
}

vec3 AmbientTerm(vec2 t, vec2 v) {
  ivec4 index;
  vec4 weight;
  Blend(u_view_index, u_view_weight, v, index, weight);
  ivec2 texel = Texel(t, textureSize(u_ambient, 0).xy);
  vec3 sum = vec3(0.0);
  for (int k = 0; k < 4; ++k) {
    if (weight[k] > 0.0) sum += weight[k] * texelFetch(u_ambient, ivec3(texel, index[k]), 0).rgb;
  }
  return sum;
}

void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec4 surface = texelFetch(u_surface, pixel, 0);
  if (int(surface.w) != u_material + 1) discard;
  vec4 directions = texelFetch(u_directions, pixel, 0);
  vec3 radiance = surface.z < 0.0 ? u_ambient_scale * AmbientTerm(surface.xy, directions.xy)
                                  : Btf(surface.xy, directions.xy, directions.zw) * surface.z;
  out0 = vec4(u_exposure * radiance, 1.0);
}
)glsl";

}  // namespace mesocap::render
