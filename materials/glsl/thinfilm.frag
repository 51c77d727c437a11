#version 330 core
// rockdove: structural colour of rock dove neck feathers by thin-film interference, and Lambert parts.
//
// The method (the source paper, summarised in reference/method.md; conventions in docs/design.md):
//   step 1-2  Airy reflectance of a keratin film of thickness d, integrated against the CIE 1931 2 degree
//             colour-matching functions under D65 into linear RGB: done offline, not here;
//   step 3    the colour is baked into a texture indexed by the angle of incidence -- here a 2-D
//             ThinFilmLUT over (cos_theta, thickness_nm), the paper's "future work" -- plus a base colour
//             texture (alpha = card silhouette) and a mask whose white part (the tip) shows the
//             structural colour;
//   step 4    Lambertian shading  I = C * I_light * max(N . L, 0), no ambient term;
//   step 5    feathers are flat two-sided cards.
//
// Angle (docs/design.md "Conventions"): the paper's "angle between incident and reflected light".
//   u_angle_mode == 0 (physical, default): cos_theta = dot(L, H), H = normalize(L + V), i.e.
//                      cos_theta = sqrt((1 + L.V) / 2); the green/purple flip at 90 degrees between light
//                      and view is theta = 45 degrees.
//   u_angle_mode == 1 (MaterialX baked): cos_theta = |dot(N, V)|, the view-only approximation the baked
//                      MaterialX network must use because pattern graphs cannot see lights; selectable so
//                      the two definitions can be compared in renders.
// LUT lookup (pipeline/rockdove/lut/table.py): x = pow(clamp(cos_theta, 0, 1), 1 / gamma),
//   y = clamp((d - lo) / (hi - lo), 0, 1) (0 when lo == hi), u = (x (N - 1) + 0.5) / N,
//   v = (y (M - 1) + 0.5) / M, linear filtering, clamp-to-edge: exactly ThinFilmLUT.sample.
// Shading: colour = mix(base_rgb, structural, mask); radiance = colour * light_rgb * max(dot(N, L), 0);
//   fragments with base alpha < u_alpha_threshold (USD opacityThreshold, 0.5) are discarded (verification), or
//   with u_alpha_to_coverage the alpha edge becomes the fragment's sample coverage (multisampled pictures).
// Textures are uploaded as float data already decoded to linear (sRGB EOTF applied on the CPU).
//
// Outputs (float render targets, read back by pipeline/rockdove/render/gl.py):
//   0  (radiance_r, radiance_g, radiance_b, coverage)            linear lin_rec709, coverage 1 (or alpha-to-coverage's)
//   1  (part_id, view_depth_m, cos_theta, thickness_nm)          part id = index + 1; 0 = background
//   2  (n_dot_l, mask, s, t)                                     shading inputs, for verification

in vec3 frag_position_m;
in vec3 frag_normal;
in vec2 frag_st;
in vec2 frag_film;
in float frag_view_depth_m;

layout(location = 0) out vec4 out_radiance;
layout(location = 1) out vec4 out_aux;
layout(location = 2) out vec4 out_inputs;

uniform int u_kind;               // 0: Lambert with base colour; 1: thin-film feather card
uniform int u_two_sided;          // 1: a card (feathers, doubleSided meshes): the normal faces the viewer
uniform int u_angle_mode;         // 0: cos_theta = dot(L, H); 1: cos_theta = |dot(N, V)|
uniform float u_part_id;
uniform vec3 u_eye_m;             // camera position, world metres
uniform vec3 u_light_dir;         // unit, world, from the surface toward the light
uniform vec3 u_light_rgb;         // linear lin_rec709; D65 white = (1, 1, 1)

uniform int u_has_base_tex;
uniform sampler2D u_base_tex;     // RGBA linear float; A = silhouette alpha
uniform vec3 u_base_colour;       // linear, when there is no base texture
uniform int u_has_mask_tex;
uniform sampler2D u_mask_tex;     // R: structural-colour mask, raw
uniform float u_alpha_threshold;
uniform int u_alpha_to_coverage;  // 1 in multisampled pictures (never the verification): coverage from alpha

uniform sampler2D u_lut;          // GL_RGB32F, width n_angle, height n_thickness, row 0 = thinnest
uniform vec2 u_lut_size;          // (n_angle, n_thickness)
uniform float u_lut_gamma;        // angle-axis warp: cos_theta = x ** gamma
uniform vec2 u_lut_range_nm;      // (lo, hi)

vec2 lut_texcoords(float cos_theta, float thickness_nm)
{
    float x = pow(clamp(cos_theta, 0.0, 1.0), 1.0 / u_lut_gamma);
    float span = u_lut_range_nm.y - u_lut_range_nm.x;
    float y = span > 0.0 ? clamp((thickness_nm - u_lut_range_nm.x) / span, 0.0, 1.0) : 0.0;
    return vec2((x * (u_lut_size.x - 1.0) + 0.5) / u_lut_size.x,
                (y * (u_lut_size.y - 1.0) + 0.5) / u_lut_size.y);
}

void main()
{
    vec4 base = u_has_base_tex == 1 ? texture(u_base_tex, frag_st) : vec4(u_base_colour, 1.0);
    float coverage = 1.0;
    if (u_alpha_to_coverage == 1) {
        // anti-aliased alpha test: the cut-out's edge spread over one pixel (alpha-to-coverage turns it into the
        // share of samples covered); a soft opacity (threshold 0) is its own coverage
        coverage = u_alpha_threshold > 0.0
            ? clamp((base.a - u_alpha_threshold) / max(fwidth(base.a), 1e-4) + 0.5, 0.0, 1.0) : base.a;
    }
    if (u_alpha_to_coverage == 1 ? coverage <= 0.0 : base.a < u_alpha_threshold) {
        discard;
    }
    vec3 N = normalize(frag_normal);
    vec3 V = normalize(u_eye_m - frag_position_m);
    vec3 L = normalize(u_light_dir);
    vec3 colour = base.rgb;
    float cos_theta = 0.0;
    float mask = 0.0;
    float thickness_nm = 0.0;
    if (u_two_sided == 1 && dot(N, V) < 0.0) {
        N = -N;  // two-sided card: the normal faces the viewer
    }
    if (u_kind == 1) {
        vec3 L_plus_V = L + V;  // zero only for light exactly opposite the eye (then theta = 90 deg)
        vec3 H = length(L_plus_V) > 1e-6 ? normalize(L_plus_V) : N;
        cos_theta = u_angle_mode == 0 ? max(dot(L, H), 0.0) : abs(dot(N, V));
        thickness_nm = frag_film.x;
        vec3 structural = texture(u_lut, lut_texcoords(cos_theta, thickness_nm)).rgb;
        mask = u_has_mask_tex == 1 ? texture(u_mask_tex, frag_st).r : 1.0;
        colour = mix(base.rgb, structural, mask);
    }
    float n_dot_l = max(dot(N, L), 0.0);
    out_radiance = vec4(colour * u_light_rgb * n_dot_l, coverage);
    out_aux = vec4(u_part_id, frag_view_depth_m, cos_theta, thickness_nm);
    out_inputs = vec4(n_dot_l, mask, frag_st);
}
