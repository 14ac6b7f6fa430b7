// Validate a glTF/GLB with the Khronos glTF validator (npm gltf-validator, installed in xr_client/).
//
//   node tools/validate_gltf.mjs scene.glb     # or "-" to read the bytes from stdin
//
// Prints the validator's report as JSON on stdout (no timestamp, every issue listed) and exits 0 when the
// report has no errors, 1 when it has, 2 when the input cannot be read or validated at all.
// tests/gltf_validate.py drives it; humans can run it on any generated file.
import { readFileSync } from 'node:fs';
import { createRequire } from 'node:module';

// The validator lives in the client's node_modules, not beside this script: resolve it from there.
const require = createRequire(new URL('../xr_client/package.json', import.meta.url));
const validator = require('gltf-validator');

const arg = process.argv[2];
if (!arg) {
  process.stderr.write('usage: node tools/validate_gltf.mjs <file.glb|file.gltf|->\n');
  process.exit(2);
}

let bytes;
try {
  bytes = new Uint8Array(readFileSync(arg === '-' ? 0 : arg));
} catch (err) {
  process.stderr.write(`cannot read ${arg}: ${err.message}\n`);
  process.exit(2);
}

try {
  const report = await validator.validateBytes(bytes, {
    uri: arg === '-' ? 'stdin' : arg,
    maxIssues: 0, // 0 = unlimited: a test failure should list every problem
    writeTimestamp: false,
  });
  process.stdout.write(JSON.stringify(report));
  process.exit(report.issues.numErrors > 0 ? 1 : 0);
} catch (err) {
  process.stderr.write(`validation failed: ${err}\n`);
  process.exit(2);
}
