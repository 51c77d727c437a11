// rockdove: structural colour of rock dove neck feathers by thin-film interference, and Lambert parts.
// materials/glsl/thinfilm.frag ported to WebGL2 (GLSL ES 3.00); the method and the conventions are the same
// (docs/design.md "Conventions"):
//   cos_theta = dot(L, H), H = normalize(L + V) (the paper's light/view half-angle);
//   LUT lookup: x = pow(clamp(cos_theta, 0, 1), 1 / gamma), y = clamp((d - lo) / (hi - lo), 0, 1),
//     u = (x (N - 1) + 0.5) / N, v = (y (M - 1) + 0.5) / M, bilinear, clamp-to-edge (ThinFilmLUT.sample);
//     done here with texelFetch on the float LUT, because WebGL2 filters float textures only with the optional
//     OES_texture_float_linear;
//   colour = mix(base_rgb, structural, mask); radiance = colour * (light_rgb * max(dot(N, L), 0) + ambient);
//   two-sided cards (N flipped toward the viewer); the alpha cut-out at u_alpha_threshold is sharpened to one
//   pixel (as three.js's own materials with alphaToCoverage): on a multisampled canvas the output alpha is the
//   share of samples covered, on a single-sampled target only alpha below the threshold is discarded.
// Output: linear radiance, or its sRGB encoding (IEC 61966-2-1) when u_encode_srgb == 1 (the screen).
precision highp float;
precision highp sampler2D;

in vec3 frag_position_m;
in vec3 frag_normal;
in vec2 frag_st;
in float frag_thickness_nm;

out vec4 out_colour;

uniform int u_kind;               // 0: Lambert with base colour; 1: thin-film feather card
uniform vec3 cameraPosition;      // three.js: camera position, world metres
uniform vec3 u_light_dir;         // unit, world, from the surface toward the light
uniform vec3 u_light_rgb;         // linear lin_rec709; D65 white = (1, 1, 1)
uniform int u_has_base_tex;
uniform sampler2D u_base_tex;     // sRGB texture (decoded by the GL), A = silhouette alpha
uniform vec3 u_base_colour;       // linear, when there is no base texture
uniform int u_has_mask_tex;
uniform sampler2D u_mask_tex;     // R: structural-colour mask, raw
uniform float u_alpha_threshold;
uniform sampler2D u_lut;          // RGBA32F, width n_angle, height n_thickness, row 0 = thinnest
uniform vec2 u_lut_size;          // (n_angle, n_thickness)
uniform float u_lut_gamma;        // angle-axis warp: cos_theta = x ** gamma
uniform vec2 u_lut_range_nm;      // (lo, hi)
uniform int u_encode_srgb;
uniform float u_ambient;          // the interactive view's ambient (a fraction of white); 0 in verification renders

vec3 lut_fetch(int i, int j)
{
    ivec2 hi = ivec2(u_lut_size) - 1;
    return texelFetch(u_lut, clamp(ivec2(i, j), ivec2(0), hi), 0).rgb;
}

vec3 lut_sample(float cos_theta, float thickness_nm)
{
    float x = pow(clamp(cos_theta, 0.0, 1.0), 1.0 / u_lut_gamma);
    float span = u_lut_range_nm.y - u_lut_range_nm.x;
    float y = span > 0.0 ? clamp((thickness_nm - u_lut_range_nm.x) / span, 0.0, 1.0) : 0.0;
    // texel-centre coordinates of (u, v) = ((x (N - 1) + 0.5) / N, (y (M - 1) + 0.5) / M): x (N - 1), y (M - 1)
    vec2 p = vec2(x * (u_lut_size.x - 1.0), y * (u_lut_size.y - 1.0));
    vec2 p0 = floor(p);
    vec2 f = p - p0;
    int i = int(p0.x), j = int(p0.y);
    return mix(mix(lut_fetch(i, j), lut_fetch(i + 1, j), f.x), mix(lut_fetch(i, j + 1), lut_fetch(i + 1, j + 1), f.x), f.y);
}

vec3 srgb_encode(vec3 c)
{
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}

void main()
{
    vec4 base = u_has_base_tex == 1 ? texture(u_base_tex, frag_st) : vec4(u_base_colour, 1.0);
    float coverage = u_alpha_threshold > 0.0
        ? smoothstep(u_alpha_threshold, u_alpha_threshold + max(fwidth(base.a), 1e-4), base.a) : base.a;
    if (coverage <= 0.0 && u_alpha_threshold > 0.0) {
        discard;
    }
    vec3 N = normalize(frag_normal);
    vec3 V = normalize(cameraPosition - frag_position_m);
    vec3 L = normalize(u_light_dir);
    vec3 colour = base.rgb;
    if (u_kind == 1) {
        if (dot(N, V) < 0.0) {
            N = -N;  // two-sided card: the normal faces the viewer
        }
        vec3 L_plus_V = L + V;
        vec3 H = length(L_plus_V) > 1e-6 ? normalize(L_plus_V) : N;
        float cos_theta = max(dot(L, H), 0.0);
        vec3 structural = lut_sample(cos_theta, frag_thickness_nm);
        float mask = u_has_mask_tex == 1 ? texture(u_mask_tex, frag_st).r : 1.0;
        colour = mix(base.rgb, structural, mask);
    }
    vec3 radiance = colour * (u_light_rgb * max(dot(N, L), 0.0) + vec3(u_ambient));
    out_colour = vec4(u_encode_srgb == 1 ? srgb_encode(radiance) : radiance, coverage);
}
