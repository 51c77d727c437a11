// rockdove thin-film feathers and Lambert parts, vertex stage: materials/glsl/thinfilm.vert ported to WebGL2
// (GLSL ES 3.00) for three.js's RawShaderMaterial over the meshes of pigeon.glb.
// Differences from the desktop shader, all forced by the glTF: texcoords follow glTF (v = 1 - t, so textures
// are sampled as uploaded, flipY = false), and the film thickness arrives as TEXCOORD_1 (three.js `uv1`) into
// the thickness ramp of pigeon.glb (pipeline/rockdove/web/gltf.py): u = (0.5 + g (N - 1)) / N, g = (d - lo) / (hi - lo),
// decoded here exactly instead of sampling the 8-bit ramp.
precision highp float;

in vec3 position;
in vec3 normal;
in vec2 uv;
in vec2 uv1;

uniform mat4 modelMatrix;
uniform mat4 viewMatrix;
uniform mat4 projectionMatrix;
uniform vec2 u_thickness_range_nm;  // (iridescenceThicknessMinimum, iridescenceThicknessMaximum)
uniform float u_ramp_texels;         // N

out vec3 frag_position_m;
out vec3 frag_normal;
out vec2 frag_st;
out float frag_thickness_nm;

void main()
{
    vec4 world = modelMatrix * vec4(position, 1.0);
    frag_position_m = world.xyz;
    frag_normal = mat3(modelMatrix) * normal;  // the glTF nodes carry no scale
    frag_st = uv;
    float g = clamp((uv1.x * u_ramp_texels - 0.5) / (u_ramp_texels - 1.0), 0.0, 1.0);
    frag_thickness_nm = mix(u_thickness_range_nm.x, u_thickness_range_nm.y, g);
    gl_Position = projectionMatrix * viewMatrix * world;
}
