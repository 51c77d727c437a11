// rockdove film panel: the neck's film edited live (sliders and fields with the build configuration's keys, the
// presets), re-baked in the page by film_bake.js, and window.rockdove, the page's scripting API (docs/viewer.md):
//
//   window.rockdove.setFilm(film) -> Promise of {rgb, angles, thicknesses, thicknessRangeNm, angleWarpGamma,
//                                                colourSpace, ms}
//     film: an object with any of the keys cauchy_a, cauchy_b_nm2, k, n_incident, n_substrate (the configuration's
//     film.* keys) and base_nm: [lo, hi], top_nm: [lo, hi] (thickness.*, nm), without their section; missing keys
//     keep their values. The page re-places each feather card's thickness for the ranges exactly as a build with
//     them would (rockdove.geometry.thickness.place_thickness_nm on the card's recorded thickness field), bakes the
//     film's LUT over the range of those thicknesses (whole nm, as the build's LUT) and draws the bird with it.
//     rgb: Float32Array of thicknesses x angles x 3, linear Rec.709 (colourSpace "lin_rec709"), the EXR's layout:
//     rgb[(i * angles + j) * 3 + c] is thickness lo + (hi - lo) i / (thicknesses - 1) over thicknessRangeNm = [lo,
//     hi] (one row at lo when lo == hi) and cos theta_j = (j / (angles - 1)) ** angleWarpGamma. ms: the bake's
//     milliseconds. A bad film (an unknown key, a wrong type, NaN, a value outside the schema's range, lo > hi)
//     rejects with a message naming the key, and the page keeps its film.
//   window.rockdove.film() -> the current film, an object with all seven keys.
//   window.rockdove.command() -> the `rockdove build --set ...` line that builds the current film, with every other
//     key the asset records as built; each argument quoted for a POSIX shell.
// Values are data: the panel writes them with textContent and input values, never as HTML or script.
(function () {
  "use strict";
  const D = window.ROCKDOVE_DATA, F = D.film, Bake = window.RockdoveFilmBake;
  const FILM_KEYS = ["cauchy_a", "cauchy_b_nm2", "k", "n_incident", "n_substrate"], RANGES = ["base_nm", "top_nm"];
  const STEPS = { cauchy_a: 0.001, cauchy_b_nm2: 10, k: 0.001, n_incident: 0.001, n_substrate: 0.001, base_nm: 1, top_nm: 1 };
  let tables = null, field = null, film = copy(F.asset), last = null;

  function copy(f) {
    const out = {};
    for (const k of FILM_KEYS) { out[k] = f[k]; }
    for (const k of RANGES) { out[k] = f[k] ? [f[k][0], f[k][1]] : null; }
    return out;
  }
  function show(v) {
    if (typeof v === "number") { return String(v); }
    let s;
    try { s = JSON.stringify(v); } catch (e) { s = undefined; }
    s = s === undefined ? String(v) : s;
    return s.length > 60 ? s.slice(0, 57) + "..." : s;
  }
  function section(key) { return (RANGES.includes(key) ? "thickness." : "film.") + key; }

  // The film `f` (all keys) after the keys of `change`, checked; Error naming the first bad key.
  function checked(change, f) {
    if (change === null || typeof change !== "object" || Array.isArray(change)) {
      throw new Error(`film must be an object with any of the keys ${FILM_KEYS.concat(RANGES).join(", ")}, got ${show(change)}`);
    }
    const next = copy(f);
    for (const key of Object.keys(change)) {
      if (!(key in F.limits)) {
        throw new Error(`${show(key)} is not a film key; the keys are ${FILM_KEYS.concat(RANGES).join(", ")}`);
      }
      const [lo, hi] = F.limits[key], unit = F.units[key] ? " " + F.units[key] : "", v = change[key];
      const name = `${key} (${section(key)})`, ok = (x) => typeof x === "number" && Number.isFinite(x) && x >= lo && x <= hi;
      if (RANGES.includes(key)) {
        if (!Array.isArray(v) || v.length !== 2 || !v.every(ok)) {
          throw new Error(`${name} must be [lo, hi], two numbers from ${lo} to ${hi}${unit}, got ${show(v)}`);
        }
        if (v[0] > v[1]) { throw new Error(`${name}: lo ${v[0]} is above hi ${v[1]}`); }
        if (!field) {
          throw new Error(`${name}: this asset records no thickness field (build it with this rockdove to edit the ranges)`);
        }
        next[key] = [v[0], v[1]];
      } else if (!ok(v)) {
        throw new Error(`${name} must be a number from ${lo} to ${hi}${unit}, got ${show(v)}`);
      } else {
        next[key] = v;
      }
    }
    return next;
  }

  // Each feather vertex's thickness for the ranges (rockdove.geometry.thickness.place_thickness_nm, in float32 as
  // the build stores it) and their range in whole nm (the build's thickness_range stage).
  function place(f) {
    const n = field.length / 3, d = new Float32Array(n);
    let lo = Infinity, hi = -Infinity;
    const [b0, b1] = f.base_nm, [t0, t1] = f.top_nm;
    for (let v = 0; v < n; v++) {
      const t = Math.min(Math.max(field[3 * v], 0), 1), g = t * t * (3 - 2 * t);  // smoothstep of the neck height
      const l = b0 + g * (t0 - b0), h = b1 + g * (t1 - b1);
      d[v] = Math.min(Math.max(0.5 * (l + h) + 0.5 * (h - l) * field[3 * v + 1] + field[3 * v + 2], l), h);
      lo = Math.min(lo, d[v]);
      hi = Math.max(hi, d[v]);
    }
    return { d, range: [Math.floor(lo), Math.ceil(hi)] };
  }

  function upload(V, res, placed) {
    const { THREE } = V, nA = res.angles, nT = res.thicknesses;
    const rgba = new Float32Array(nA * nT * 4);
    for (let i = 0; i < nA * nT; i++) {
      rgba[4 * i] = res.rgb[3 * i]; rgba[4 * i + 1] = res.rgb[3 * i + 1]; rgba[4 * i + 2] = res.rgb[3 * i + 2];
      rgba[4 * i + 3] = 1;
    }
    const tex = new THREE.DataTexture(rgba, nA, nT, THREE.RGBAFormat, THREE.FloatType);
    tex.minFilter = tex.magFilter = THREE.NearestFilter;
    tex.needsUpdate = true;
    const old = V.parts.length ? V.parts[0].lut.uniforms.u_lut.value : null;
    const ior = f550(film), N = D.ramp_texels, [lo, hi] = placed ? placed.range : [0, 0];
    for (const p of V.parts) {
      const u = p.lut.uniforms;
      u.u_lut.value = tex;
      u.u_lut_size.value.set(nA, nT);
      u.u_lut_gamma.value = res.angleWarpGamma;
      u.u_lut_range_nm.value.set(res.thicknessRangeNm[0], res.thicknessRangeNm[1]);
      if (!p.feather) { continue; }
      p.physical.iridescenceIOR = ior;  // three.js's own thin film (the "physical" mode): one index, at 550 nm
      p.physical.ior = film.n_substrate;
      if (!placed) { continue; }
      const uv1 = p.mesh.geometry.attributes.uv1;
      for (let v = 0; v < uv1.count; v++) {  // the glb's thickness ramp coordinate (rockdove.web.gltf)
        uv1.setX(v, (0.5 + (hi > lo ? (placed.d[v] - lo) / (hi - lo) : 0) * (N - 1)) / N);
      }
      uv1.needsUpdate = true;
      u.u_thickness_range_nm.value.set(lo, hi);
      p.physical.iridescenceThicknessMinimum = lo;
      p.physical.iridescenceThicknessMaximum = hi;
    }
    if (old && old !== V.lutTexture) { old.dispose(); }
  }
  function f550(f) { return f.cauchy_a + f.cauchy_b_nm2 / (550 * 550); }

  // Bake and show `next` (checked); the result of setFilm.
  function apply(next) {
    const V = window.rockdoveViewer;
    const placed = field && next.base_nm ? place(next) : null;
    const range = placed ? placed.range : D.lut.thickness_range_nm;
    const rows = range[0] === range[1] ? 1 : F.lut.thicknesses;
    const res = Bake.bake(tables, next, { angles: F.lut.angles, thicknesses: rows, thicknessRangeNm: range,
                                          angleWarpGamma: F.lut.angle_warp_gamma });
    film = next;
    upload(V, res, placed);
    V.draw();
    last = res;
    return { rgb: res.rgb, angles: res.angles, thicknesses: res.thicknesses, thicknessRangeNm: res.thicknessRangeNm,
             angleWarpGamma: res.angleWarpGamma, colourSpace: F.lut.colour_space, ms: res.ms };
  }

  function shellQuote(s) { return /^[A-Za-z0-9_.,:=+\-\/@%]+$/.test(s) ? s : "'" + s.replace(/'/g, "'\\''") + "'"; }
  function command() {
    const args = ["rockdove", "build"];
    for (const k of FILM_KEYS) { args.push("--set", `film.${k}=${film[k]}`); }
    for (const k of RANGES) { if (film[k]) { args.push("--set", `thickness.${k}=[${film[k][0]}, ${film[k][1]}]`); } }
    for (const [k, v] of F.sets) { args.push("--set", `${k}=${v}`); }
    return args.map(shellQuote).join(" ");
  }

  // ------------------------------------------------------------------------------------------------- the panel
  const inputs = {};  // key (or key:0 / key:1 for a range's ends) -> [slider, number field]
  let status = null, commandLine = null;
  function el(tag, props, ...children) {
    const e = document.createElement(tag);
    Object.assign(e, props || {});
    for (const c of children) { e.append(c); }
    return e;
  }
  function refresh(message, error) {
    for (const [id, [slider, number]] of Object.entries(inputs)) {
      const [key, end] = id.split(":");
      const v = end === undefined ? film[key] : (film[key] || [NaN, NaN])[Number(end)];
      slider.value = String(v);
      number.value = String(v);
    }
    commandLine.textContent = command();
    status.textContent = message;
    status.className = error ? "error" : "";
  }
  function edit(change) {
    try {
      const res = apply(checked(change, film));
      refresh(`LUT ${res.angles} x ${res.thicknesses}, ${res.thicknessRangeNm[0]}-${res.thicknessRangeNm[1]} nm, ` +
              `baked in ${res.ms.toFixed(1)} ms (${last.method})`);
    } catch (e) {
      refresh(e.message, true);
    }
  }
  function row(id, label) {
    const [key, end] = id.split(":");
    const [lo, hi] = F.limits[key];
    const slider = el("input", { type: "range", min: String(lo), max: String(hi), step: String(STEPS[key]) });
    const number = el("input", { type: "number", min: String(lo), max: String(hi), step: "any" });
    slider.setAttribute("aria-label", label);
    number.setAttribute("aria-label", label);
    const changeOf = (v) => {
      if (end === undefined) { return { [key]: v }; }
      const pair = [...film[key]];
      pair[Number(end)] = v;  // a slider pushes the other end along, a field is taken as typed
      return { [key]: pair };
    };
    slider.addEventListener("input", () => {
      const c = changeOf(Number(slider.value));
      if (end !== undefined) { c[key] = end === "0" ? [c[key][0], Math.max(c[key][0], c[key][1])] : [Math.min(c[key][0], c[key][1]), c[key][1]]; }
      edit(c);
    });
    number.addEventListener("change", () => edit(changeOf(number.value.trim() === "" ? NaN : Number(number.value))));
    inputs[id] = [slider, number];
    const unit = F.units[key] ? ` (${F.units[key]})` : "";
    return el("label", { className: "film-row" }, el("span", { textContent: label + unit }), slider, number);
  }

  function build() {
    const panel = document.getElementById("panel");
    const details = el("details", { id: "film" }, el("summary", { textContent: "film" }));
    const grid = el("div", { className: "film-grid" });
    for (const k of FILM_KEYS) { grid.append(row(k, `film.${k}`)); }
    for (const k of RANGES) {
      for (const end of ["0", "1"]) { grid.append(row(`${k}:${end}`, `thickness.${k} ${end === "0" ? "lo" : "hi"}`)); }
    }
    const presets = el("div", { className: "film-presets" }, el("span", { textContent: "presets:" }));
    for (const [name, f] of [["asset", F.asset], ...Object.entries(F.presets)]) {
      const b = el("button", { type: "button", textContent: name === "asset" ? "this asset's film" : name });
      b.addEventListener("click", () => edit(field && f.base_nm ? copy(f) : Object.fromEntries(FILM_KEYS.map((k) => [k, f[k]]))));
      presets.append(b);
    }
    status = el("span", { id: "film-status" });
    commandLine = el("code", { id: "film-command" });
    details.append(grid, presets, el("div", { className: "film-command" }, el("span", { textContent: "build it: " }), commandLine), status);
    details.addEventListener("toggle", () => window.rockdoveViewer.draw());
    panel.append(details);
    if (!field) {
      for (const [id, [s, n]] of Object.entries(inputs)) { if (id.includes(":")) { s.disabled = n.disabled = true; } }
    }
    refresh(field ? "" : "this asset records no thickness field: the film's index can change, not its ranges");
  }

  const ready = window.rockdoveReady.then(() => {
    tables = new Bake.Tables(F.tables);
    if (F.field) {
      const bytes = Uint8Array.from(atob(F.field), (c) => c.charCodeAt(0));
      field = new Float32Array(bytes.buffer);
      const feathers = window.rockdoveViewer.parts.filter((p) => p.feather);
      if (feathers.length !== 1 || feathers[0].mesh.geometry.attributes.uv1.count !== field.length / 3) { field = null; }
    }
    if (!field) { film = Object.assign(copy(F.asset), { base_nm: null, top_nm: null }); }
    build();
  });

  window.rockdove = {
    setFilm(change) {
      return ready.then(() => {
        const res = apply(checked(change, film));
        if (status) { refresh(`set by window.rockdove.setFilm: baked in ${res.ms.toFixed(1)} ms`); }
        return res;
      });
    },
    film() { return copy(film); },
    command,
  };
})();
