#version 330 core
// rockdove thin-film feathers and Lambert body: vertex stage.
//
// Loaded by pipeline/rockdove/render/gl.py through pyrender's ShaderProgramCache; pyrender replaces the *_LOC
// names below by the attribute locations of the primitive's buffers (position is always 0).
// Attributes rockdove passes (docs/design.md "Conventions"):
//   position    world position, metres (parts are already in world space; M * inst_m is the identity
//               unless a caller poses the node)
//   normal      unit vertex normal
//   texcoord_0  USD primvars:st (t = 0 at the bottom of the texture)
//   texcoord_1  (thickness_nm, neckS): the film thickness primvar in nm and the neck coordinate in [0, 1]
//               (zeros for parts without a film)
// Paper step 5: feathers are flat polygon cards with the textures applied.

layout(location = 0) in vec3 position;
layout(location = NORMAL_LOC) in vec3 normal;
layout(location = TEXCOORD_0_LOC) in vec2 texcoord_0;
layout(location = TEXCOORD_1_LOC) in vec2 texcoord_1;
layout(location = INST_M_LOC) in mat4 inst_m;

uniform mat4 M;   // model (node pose)
uniform mat4 V;   // world -> camera
uniform mat4 P;   // projection

out vec3 frag_position_m;   // world position, metres
out vec3 frag_normal;       // world normal (unnormalised after interpolation)
out vec2 frag_st;           // texture coordinates
out vec2 frag_film;         // (thickness_nm, neckS)
out float frag_view_depth_m;  // distance along the camera's -Z axis, metres

void main()
{
    mat4 model = M * inst_m;
    vec4 world = model * vec4(position, 1.0);
    frag_position_m = world.xyz;
    frag_normal = mat3(transpose(inverse(model))) * normal;
    frag_st = texcoord_0;
    frag_film = texcoord_1;
    vec4 view = V * world;
    frag_view_depth_m = -view.z;
    gl_Position = P * view;
}
