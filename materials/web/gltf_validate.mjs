// Validate one glTF/GLB file with the Khronos glTF-Validator (npm package gltf-validator) and print its
// report as JSON on stdout. Usage: node gltf_validate.mjs FILE.glb   (run by rockdove.web.gltf.validate_glb)
import { readFileSync } from "node:fs";
import { basename } from "node:path";
import { createRequire } from "node:module";

const require = createRequire(import.meta.url);
const validator = require("gltf-validator");
const file = process.argv[2];
const report = await validator.validateBytes(new Uint8Array(readFileSync(file)), {
  uri: basename(file),
  maxIssues: 200,
  externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri}: a GLB must be self-contained`)),
});
process.stdout.write(JSON.stringify(report));
