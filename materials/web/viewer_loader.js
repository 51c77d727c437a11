// rockdove viewer: load the ES modules that arrived as strings (window.ROCKDOVE_MODULES, filled by the classic
// scripts beside viewer.html) as blob: URLs, rewriting each import specifier to its dependency's blob URL.
// A file:// page can neither fetch files nor load module scripts from disk in Chromium; blob: URLs it makes
// itself are same-origin. Order: dependencies first.
(function () {
  "use strict";
  const MODULES = window.ROCKDOVE_MODULES || {};
  const SPECIFIERS = {  // specifier as written in the sources -> module name, dependencies first
    "./three.core.js": "three.core.js", "three": "three.module.js",
    "../utils/BufferGeometryUtils.js": "BufferGeometryUtils.js", "../utils/SkeletonUtils.js": "SkeletonUtils.js",
    "three/addons/loaders/GLTFLoader.js": "GLTFLoader.js", "three/addons/controls/OrbitControls.js": "OrbitControls.js",
    "./motion_player.js": "motion_player.js",
  };
  const urls = {};
  for (const name of Object.values(SPECIFIERS).concat("viewer_app.js")) {
    if (!(name in MODULES)) { throw new Error(`rockdove viewer: module ${name} is missing beside viewer.html`); }
    const source = MODULES[name].replace(/(\bfrom\s*|\bimport\s*)(['"])([^'"]+)\2/g, (all, head, q, spec) => {
      const dep = SPECIFIERS[spec];
      // unknown specifiers, and a module naming itself (in a doc comment), stay as written
      if (dep === undefined || !(dep in urls)) { return all; }
      return head + q + urls[dep] + q;
    });
    urls[name] = URL.createObjectURL(new Blob([source], { type: "text/javascript" }));
  }
  window.rockdoveReady = import(urls["viewer_app.js"]).then((m) => m.ready);
  window.rockdoveReady.catch((e) => {
    const s = document.getElementById("status");
    if (s) { s.textContent = "error: " + e.message; s.className = "error"; }
    console.error(e);
  });
})();
