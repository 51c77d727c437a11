// rockdove viewer: the motion player. pigeon.glb's animations (one per USD `motion` variant: idle, walk; written
// by pipeline/rockdove/web/gltf_skin.py) played by three.js's AnimationMixer, with a motion switch and a play/pause
// button in the panel. The page opens at rest (the asset's default motion): nothing moves until a motion is chosen.
// three.js skins its own materials; the viewer's LUT material is a RawShaderMaterial, which three.js does not touch,
// so skinRawShader adds its skinning chunks to that vertex shader. The camera follows the walk's root motion
// (the pelvis), so the bird stays in view. window.rockdoveMotion(name, seconds) poses it for tests.
import * as THREE from "three";

const C = THREE.ShaderChunk;

// Skin a RawShaderMaterial's vertex shader that reads `in vec3 position; in vec3 normal;` in `void main()`: its main
// runs on the skinned position and normal (three.js's own skinning chunks, linear blend, the bone texture and bind
// matrices that the renderer uploads for every SkinnedMesh).
function skinRawShader(material) {
  material.onBeforeCompile = (shader) => {
    const source = shader.vertexShader;
    const at = source.search(/void\s+main\s*\(/);
    if (at < 0) { throw new Error("rockdove viewer: the LUT vertex shader has no main() to skin"); }
    shader.vertexShader = source.slice(0, at) + "#define USE_SKINNING\nin vec4 skinIndex;\nin vec4 skinWeight;\n" +
      C.skinning_pars_vertex + "\nvec3 rd_position;\nvec3 rd_normal;\nvoid rd_skin() {\n" +
      "vec3 transformed = position;\nvec3 objectNormal = normal;\n" + C.skinbase_vertex + "\n" +
      C.skinnormal_vertex + "\n" + C.skinning_vertex + "\nrd_position = transformed;\nrd_normal = objectNormal;\n}\n" +
      "#define position rd_position\n#define normal rd_normal\n" +
      source.slice(at).replace(/void\s+main\s*\(/, "void rd_main(") +
      "\n#undef position\n#undef normal\nvoid main() { rd_skin(); rd_main(); }\n";
  };
  material.needsUpdate = true;
}

export function installPlayer({ gltf, parts, draw, camera, controls, panel }) {
  const clips = gltf.animations || [];
  if (!clips.length) { return null; }
  for (const p of parts) {
    if (p.mesh.isSkinnedMesh) {
      skinRawShader(p.lut);
      p.mesh.frustumCulled = false;  // its bounds are the rest pose's; the walk leaves them
    }
  }
  const mixer = new THREE.AnimationMixer(gltf.scene);
  const rest = [];  // every node's rest transform, restored when the motion is "rest"
  gltf.scene.traverse((o) => rest.push([o, o.position.clone(), o.quaternion.clone(), o.scale.clone()]));
  const root = gltf.scene.getObjectByName("pelvis") || gltf.scene;
  const follow = new THREE.Vector3(), last = new THREE.Vector3(), now = new THREE.Vector3();
  let motion = "rest", action = null, playing = false, clock = null;

  // the controls, built as elements (a motion's name is the asset's data: text, never markup)
  const el = (tag, props, ...children) => {
    const e = Object.assign(document.createElement(tag), props);
    e.append(...children);
    return e;
  };
  const select = el("select", { id: "motion" }, ...["rest", ...clips.map((c) => c.name)].map(
    (n) => el("option", { value: n, textContent: n })));
  const button = el("button", { id: "play", type: "button", disabled: true, textContent: "play" });
  const label = el("span", { id: "motion-time" });
  label.style.cssText = "display: inline-block; min-width: 4.5em";  // the panel keeps its layout as it plays
  panel.insertBefore(el("span", {}, el("label", {}, "motion ", select), " ", button, " ", label),
                     document.getElementById("status"));

  function followRoot() {  // the camera moves with the pelvis (the root motion), so the bird stays framed
    gltf.scene.updateMatrixWorld(true);
    root.getWorldPosition(now);
    const d = now.clone().sub(last);
    camera.position.add(d);
    controls.target.add(d);
    follow.add(d);
    last.copy(now);
    controls.update();
  }

  function choose(name) {
    mixer.stopAllAction();
    action = null;
    motion = name;
    for (const [o, p, q, s] of rest) { o.position.copy(p); o.quaternion.copy(q); o.scale.copy(s); }
    gltf.scene.updateMatrixWorld(true);
    camera.position.sub(follow);  // back to where the user left the camera at rest
    controls.target.sub(follow);
    follow.set(0, 0, 0);
    root.getWorldPosition(last);
    const clip = clips.find((c) => c.name === name);
    if (clip) {
      action = mixer.clipAction(clip);
      action.play();
      mixer.setTime(0);
      followRoot();
    } else {
      pause();
      controls.update();
    }
    button.disabled = !clip;
    select.value = name;
    show();
  }

  function show() {
    label.textContent = action ? `${mixer.time.toFixed(2)} s` : "";
    draw();
  }

  function tick() {
    if (!playing) { return; }
    const t = performance.now();
    mixer.update(Math.min((t - clock) / 1000, 0.1));
    clock = t;
    followRoot();
    show();
    requestAnimationFrame(tick);
  }

  function play() {
    if (!action || playing) { return; }
    playing = true;
    button.textContent = "pause";
    clock = performance.now();
    requestAnimationFrame(tick);
  }

  function pause() {
    playing = false;
    button.textContent = "play";
  }

  select.addEventListener("change", () => { choose(select.value); if (action) { play(); } });
  button.addEventListener("click", () => { if (playing) { pause(); } else { play(); } });

  // Tests: pose `name` ("rest", "idle", "walk") at `seconds`, paused; returns the motion, its time and where
  // three.js's skinning (on the CPU, as the GPU does) puts vertex `vertex` of each mesh (metres, world).
  window.rockdoveMotion = (name, seconds, vertex = 0) => {
    if (name !== "rest" && !clips.some((c) => c.name === name)) { throw new Error(`no motion ${name}`); }
    choose(name);
    pause();
    if (action) { mixer.setTime(seconds); followRoot(); }
    show();
    const at = (m) => m.getVertexPosition(vertex, new THREE.Vector3()).applyMatrix4(m.matrixWorld).toArray();
    return { motion, time: action ? mixer.time : 0,
             vertices: Object.fromEntries(parts.map((p) => [p.mesh.name, at(p.mesh)])) };
  };
  return { choose, play, pause };
}
