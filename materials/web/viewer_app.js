// rockdove viewer: pigeon.glb in three.js, orbit with the mouse, a slider that turns the light about the
// vertical axis, and a switch between (a) the paper's baked-LUT shading (thinfilm_webgl.vert/.frag, our
// GLSL ported to WebGL2, reading the float LUT) and (b) three.js's own KHR_materials_iridescence shading.
// Data (window.ROCKDOVE_DATA, viewer_data.js): the GLB (base64), the float LUT, the shaders, the start camera
// and light. Also used headless by pipeline/rockdove/hosts/web.py through window.rockdoveRender (linear float pixels).
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { installPlayer } from "./motion_player.js";

const D = window.ROCKDOVE_DATA;
const canvas = document.getElementById("view");
const status = document.getElementById("status");
const slider = document.getElementById("light");

function bytesOf(b64) {
  const s = atob(b64);
  const out = new Uint8Array(s.length);
  for (let i = 0; i < s.length; i++) { out[i] = s.charCodeAt(i); }
  return out;
}

// Multisampled canvas (antialias); the cards' alpha cut-out by alpha-to-coverage (each material's alphaToCoverage).
// The verification's float render targets (renderView) are single-sampled: coverage does not apply there, and the
// cut-out is the discard at the threshold as before.
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true, alpha: false });
renderer.setPixelRatio(1);
renderer.toneMapping = THREE.NoToneMapping;
renderer.outputColorSpace = THREE.SRGBColorSpace;
const BACKGROUND = new THREE.Color(0.05, 0.05, 0.055);
// Ambient of the interactive view, a fraction of the light's radiance: the side away from the light is dark grey,
// not black (the LUT shader adds colour * u_ambient; the physical modes scale the white environment by it).
// Verification renders (renderView) use none in the LUT mode and the unit environment in the physical one.
const AMBIENT = 0.15;

const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(D.camera.yfov_deg, 1, 0.005, 20);
camera.position.fromArray(D.camera.eye_m);
const controls = new OrbitControls(camera, canvas);
controls.target.fromArray(D.camera.target_m);
controls.enableDamping = false;
controls.update();

// Light: a directional light fixed in the world; the slider sets its azimuth about +Y (degrees), keeping its
// elevation. Radiance convention: our shaders use colour * light * N.L; three.js's Lambert is colour / pi *
// intensity * N.L, so the physical mode's light has intensity pi for the same light.
const light = new THREE.DirectionalLight(0xffffff, Math.PI);
scene.add(light, light.target);
const L0 = new THREE.Vector3().fromArray(D.light.direction).normalize();
const elevation = Math.asin(L0.y);
function lightDirection(azimuthDeg) {
  const a = THREE.MathUtils.degToRad(azimuthDeg), c = Math.cos(elevation);
  return new THREE.Vector3(c * Math.sin(a), Math.sin(elevation), c * Math.cos(a));
}
slider.value = String(Math.round(THREE.MathUtils.radToDeg(Math.atan2(L0.x, L0.z))));

// Uniform white environment of unit radiance (the physical mode's surroundings, and the web host's
// "view_angle" lobe: the smooth film's mirror reflection of it).
const envData = new Float32Array(16 * 8 * 4).fill(1.0);
const envTexture = new THREE.DataTexture(envData, 16, 8, THREE.RGBAFormat, THREE.FloatType);
envTexture.mapping = THREE.EquirectangularReflectionMapping;
envTexture.colorSpace = THREE.LinearSRGBColorSpace;
envTexture.needsUpdate = true;

// The float LUT (rows: thickness, row 0 thinnest; columns: angle), RGBA32F, fetched texel by texel.
const lutRGB = new Float32Array(bytesOf(D.lut.rgb_f32).buffer);
const [nA, nT] = [D.lut.n_angle, D.lut.n_thickness];
const lutRGBA = new Float32Array(nA * nT * 4);
for (let i = 0; i < nA * nT; i++) {
  lutRGBA.set(lutRGB.subarray(3 * i, 3 * i + 3), 4 * i);
  lutRGBA[4 * i + 3] = 1;
}
const lutTexture = new THREE.DataTexture(lutRGBA, nA, nT, THREE.RGBAFormat, THREE.FloatType);
lutTexture.minFilter = lutTexture.magFilter = THREE.NearestFilter;
lutTexture.needsUpdate = true;

const parts = [];  // {mesh, physical, lut}
function lutMaterial(physical, isFeather) {
  const ir = physical.iridescence > 0 ? physical : null;
  return new THREE.RawShaderMaterial({
    glslVersion: THREE.GLSL3,
    vertexShader: D.shaders.vert,
    fragmentShader: D.shaders.frag,
    side: isFeather ? THREE.DoubleSide : THREE.FrontSide,
    alphaToCoverage: physical.alphaTest > 0,
    uniforms: {
      u_kind: { value: isFeather ? 1 : 0 },
      u_light_dir: { value: new THREE.Vector3(0, 1, 0) },
      u_light_rgb: { value: new THREE.Vector3(1, 1, 1) },
      u_has_base_tex: { value: physical.map ? 1 : 0 },
      u_base_tex: { value: physical.map },
      u_base_colour: { value: new THREE.Vector3(physical.color.r, physical.color.g, physical.color.b) },
      u_has_mask_tex: { value: ir && ir.iridescenceMap ? 1 : 0 },
      u_mask_tex: { value: ir ? ir.iridescenceMap : null },
      u_alpha_threshold: { value: physical.alphaTest > 0 ? physical.alphaTest : 0.0 },
      u_lut: { value: lutTexture },
      u_lut_size: { value: new THREE.Vector2(nA, nT) },
      u_lut_gamma: { value: D.lut.angle_warp_gamma },
      u_lut_range_nm: { value: new THREE.Vector2(D.lut.thickness_range_nm[0], D.lut.thickness_range_nm[1]) },
      u_thickness_range_nm: { value: new THREE.Vector2(ir ? ir.iridescenceThicknessMinimum : 0,
                                                       ir ? ir.iridescenceThicknessMaximum : 0) },
      u_ambient: { value: AMBIENT },
      u_ramp_texels: { value: D.ramp_texels },
      u_encode_srgb: { value: 1 },
    },
  });
}

// Modes: "lut" (our GLSL), "physical" (KHR_materials_iridescence: the glb's thin_film variant), "preview" (the
// glb's default material, what a glTF viewer without the extension shows), "plain" (the same meshes with a plain
// textured material: the baseline of the frame-time benchmark).
let mode = "lut";
function applyMode(m) {
  mode = m;
  for (const p of parts) { p.mesh.material = p[m]; }
  scene.environment = m === "physical" || m === "preview" ? envTexture : null;
  scene.environmentIntensity = AMBIENT;
}

function setLight(azimuthDeg) {
  const L = lightDirection(azimuthDeg);
  light.position.copy(L);
  light.target.position.set(0, 0, 0);
  for (const p of parts) { p.lut.uniforms.u_light_dir.value.copy(L); }
  document.getElementById("light-deg").textContent = String(Math.round(azimuthDeg));
}

function resize() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== w || canvas.height !== h) { renderer.setSize(w, h, false); }
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
}

function draw() {
  resize();
  renderer.setRenderTarget(null);
  renderer.setClearColor(BACKGROUND, 1);
  for (const p of parts) { p.lut.uniforms.u_encode_srgb.value = 1; }
  renderer.render(scene, camera);
}

const gltf = await new Promise((resolve, reject) => new GLTFLoader().parse(bytesOf(D.glb).buffer, "", resolve, reject));
// KHR_materials_variants: the glb's default feather material is the preview atlas; the film is the variant
// "thin_film" (three.js's GLTFLoader keeps the extension in userData, the app selects a variant)
const variants = (gltf.userData.gltfExtensions?.KHR_materials_variants?.variants || []).map((v) => v.name);
const meshes = [];
gltf.scene.traverse((o) => { if (o.isMesh) { meshes.push(o); } });
for (const o of meshes) {
  const mapping = (o.userData.gltfExtensions?.KHR_materials_variants?.mappings || [])
    .find((m) => m.variants.includes(variants.indexOf("thin_film")));
  const physical = mapping ? await gltf.parser.getDependency("material", mapping.material) : o.material;
  const isFeather = physical.iridescence > 0;
  const plain = new THREE.MeshBasicMaterial({ map: physical.map, color: physical.color, alphaTest: physical.alphaTest,
                                              side: physical.side });
  for (const m of [physical, o.material, plain]) { m.alphaToCoverage = m.alphaTest > 0; }
  parts.push({ mesh: o, physical, preview: o.material, plain, lut: lutMaterial(physical, isFeather),
               feather: isFeather });
}
// the start view frames the whole bird: the start camera's direction, at the distance where the bird's bounding
// sphere fills the narrower field of view
const sphere = new THREE.Box3().setFromObject(gltf.scene).getBoundingSphere(new THREE.Sphere());
const startDirection = new THREE.Vector3().fromArray(D.camera.eye_m)
  .sub(new THREE.Vector3().fromArray(D.camera.target_m)).normalize();
function frameBird() {
  const aspect = canvas.clientWidth / Math.max(canvas.clientHeight, 1);
  const half = THREE.MathUtils.degToRad(D.camera.yfov_deg) / 2;
  const narrow = Math.min(half, Math.atan(Math.tan(half) * aspect));
  controls.target.copy(sphere.center);
  camera.position.copy(sphere.center).addScaledVector(startDirection, 1.05 * sphere.radius / Math.sin(narrow));
  controls.update();
}
frameBird();
scene.add(gltf.scene);
slider.addEventListener("input", () => { setLight(Number(slider.value)); draw(); });
for (const r of document.querySelectorAll('input[name="mode"]')) {
  r.addEventListener("change", () => { if (r.checked) { applyMode(r.value); draw(); } });
}
controls.addEventListener("change", draw);
window.addEventListener("resize", draw);
installPlayer({ gltf, parts, draw, camera, controls, panel: document.getElementById("panel") });  // at rest
applyMode("lut");
setLight(Number(slider.value));
draw();
status.textContent = `${D.asset_name}: drag to orbit, wheel to zoom` +
  (D.lut.verification_only ? " (the asset has no LUT: the LUT mode shows a verification-only LUT)" : "");

/**
 * Render one verification view into a float target and return its linear radiance.
 * view: {camera_to_world: 16 numbers, row-major (OpenGL camera, looks down -Z), yfov_rad, width, height,
 *        light_direction: [3], light_rgb: [3]}; mode: "lut" (the paper's half-angle lobe) or "physical"
 *        (three.js KHR_materials_iridescence: no light, base colour black, uniform white environment of unit
 *        radiance: the smooth film's mirror lobe).
 * Returns {width, height, rgb_f32: base64 of float32 RGB, rows top first}.
 */
function renderView(view, renderMode) {
  const m = new THREE.Matrix4().fromArray(view.camera_to_world).transpose();
  const cam = new THREE.PerspectiveCamera(THREE.MathUtils.radToDeg(view.yfov_rad), view.width / view.height, 0.005, 20);
  m.decompose(cam.position, cam.quaternion, cam.scale);
  cam.updateMatrixWorld(true);
  const target = new THREE.WebGLRenderTarget(view.width, view.height, { type: THREE.FloatType, format: THREE.RGBAFormat,
    colorSpace: THREE.LinearSRGBColorSpace, depthBuffer: true });
  const saved = { mode, intensity: light.intensity, colours: parts.map((p) => p.physical.color.clone()) };
  applyMode(renderMode);
  const L = new THREE.Vector3().fromArray(view.light_direction).normalize();
  light.position.copy(L);
  light.color.setRGB(...view.light_rgb, THREE.LinearSRGBColorSpace);
  for (const p of parts) {
    p.lut.uniforms.u_light_dir.value.copy(L);
    p.lut.uniforms.u_light_rgb.value.fromArray(view.light_rgb);
    p.lut.uniforms.u_encode_srgb.value = 0;
    p.lut.uniforms.u_ambient.value = 0;
  }
  if (renderMode === "physical") {
    scene.environmentIntensity = 1;
    light.intensity = 0;
    for (const p of parts) { p.physical.color.setRGB(0, 0, 0); }
  }
  renderer.setRenderTarget(target);
  renderer.setClearColor(0x000000, 0);
  renderer.clear();
  renderer.render(scene, cam);
  const rgba = new Float32Array(view.width * view.height * 4);
  renderer.readRenderTargetPixels(target, 0, 0, view.width, view.height, rgba);
  renderer.setRenderTarget(null);
  target.dispose();
  // restore the interactive state
  light.intensity = saved.intensity;
  light.color.setRGB(1, 1, 1);
  parts.forEach((p, i) => {
    p.physical.color.copy(saved.colours[i]);
    p.lut.uniforms.u_light_rgb.value.set(1, 1, 1);
    p.lut.uniforms.u_ambient.value = AMBIENT;
  });
  applyMode(saved.mode);
  setLight(Number(slider.value));
  draw();
  const rgb = new Float32Array(view.width * view.height * 3);
  for (let y = 0; y < view.height; y++) {  // GL rows are bottom first
    const src = (view.height - 1 - y) * view.width;
    for (let x = 0; x < view.width; x++) {
      rgb.set(rgba.subarray(4 * (src + x), 4 * (src + x) + 3), 3 * (y * view.width + x));
    }
  }
  const bytes = new Uint8Array(rgb.buffer);
  let s = "";
  for (let i = 0; i < bytes.length; i += 0x8000) { s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000)); }
  return { width: view.width, height: view.height, rgb_f32: btoa(s) };
}
window.rockdoveRender = renderView;
// Frame time of the interactive view in one mode: `frames` draws at the canvas's size, each waited for (a 1-pixel
// read-back), after one warm-up draw (shader compilation); milliseconds per frame (rockdove bench viewer).
window.rockdoveFrameTime = (benchMode, frames) => {
  const gl = renderer.getContext(), px = new Uint8Array(4);
  const saved = mode;
  applyMode(benchMode);
  draw();
  gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
  const t0 = performance.now();
  for (let i = 0; i < frames; i++) {
    draw();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
  }
  const ms = (performance.now() - t0) / frames;
  applyMode(saved);
  draw();
  return ms;
};
// The film panel (film_panel.js) swaps the LUT and re-places the feathers' thickness through this.
window.rockdoveViewer = { THREE, parts, draw, lutTexture };
window.rockdoveSetLight = (deg) => { slider.value = String(deg); slider.dispatchEvent(new Event("input")); };

export const ready = { parts: parts.length, feathers: parts.filter((p) => p.feather).length, webgl2: renderer.capabilities.isWebGL2 !== false };
