// Validates glTF / GLB files with the Khronos glTF-Validator (npm package `gltf-validator`).
// Usage: node scripts/validate-gltf.mjs FILE... (scripts/validate-gltf.sh installs the package
// first). Prints each file's error/warning counts and its errors; exits 1 if any file has
// errors, 2 on usage or I/O problems.
import { readFile } from 'node:fs/promises';
import { createRequire } from 'node:module';
import path from 'node:path';

const require = createRequire(import.meta.url);
let validator;
try {
  validator = require(process.env.GLTF_VALIDATOR_PATH || 'gltf-validator');
} catch (e) {
  console.error(`cannot load gltf-validator (${e.message}); run scripts/validate-gltf.sh, which installs it`);
  process.exit(2);
}

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: validate-gltf.mjs FILE.gltf|FILE.glb...');
  process.exit(2);
}

let failed = false;
for (const file of files) {
  let data;
  try {
    data = new Uint8Array(await readFile(file));
  } catch (e) {
    console.error(`${file}: cannot read: ${e.message}`);
    process.exit(2);
  }
  const dir = path.dirname(file);
  const report = await validator.validateBytes(data, {
    uri: path.basename(file),
    maxIssues: 100,
    externalResourceFunction: (uri) =>
      readFile(path.join(dir, decodeURIComponent(uri))).then((b) => new Uint8Array(b)),
  });
  const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
  console.log(`${file}: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos, ${numHints} hints`);
  for (const m of messages) {
    if (m.severity <= 1 || process.env.VERBOSE) {
      const kind = ['error', 'warning', 'info', 'hint'][m.severity] ?? m.severity;
      console.log(`  ${kind} ${m.code} at ${m.pointer ?? '-'}: ${m.message}`);
    }
  }
  if (numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
