#!/usr/bin/env node
// Runs the Khronos glTF-Validator (npm package gltf-validator) on each file given; prints a one-line summary
// per file and every message; exits 1 if any file has an error or a warning, 2 if the validator is missing.
// Usage: node validate_gltf.js [--validator DIR] FILE...
'use strict';
const fs = require('fs');
const path = require('path');

let args = process.argv.slice(2);
let validatorDir = process.env.FURROW_GLTF_VALIDATOR_DIR || '';
if (args[0] === '--validator') { validatorDir = args[1]; args = args.slice(2); }
let validator;
try {
  validator = require(validatorDir ? path.join(validatorDir, 'node_modules', 'gltf-validator') : 'gltf-validator');
} catch (e) {
  console.error('Error: gltf-validator is not installed (run .ci/install-deps): ' + e.message);
  process.exit(2);
}

const severities = ['error', 'warning', 'info', 'hint'];

async function validate(file) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 100,
    externalResourceFunction: (uri) => new Promise((resolve, reject) => {
      const p = path.resolve(path.dirname(file), decodeURIComponent(uri));
      fs.readFile(p, (err, data) => err ? reject(err.toString()) : resolve(new Uint8Array(data)));
    }),
  });
  const n = report.issues;
  console.log(`${file}: ${n.numErrors} errors, ${n.numWarnings} warnings, ${n.numInfos} infos, ${n.numHints} hints`);
  for (const m of n.messages) {
    if (m.severity <= 1)
      console.log(`  ${severities[m.severity]} ${m.code} ${m.pointer || ''}: ${m.message}`);
  }
  return n.numErrors === 0 && n.numWarnings === 0;
}

(async () => {
  if (args.length === 0) { console.error('usage: validate_gltf.js FILE...'); process.exit(2); }
  let ok = true;
  for (const f of args) {
    try { ok = (await validate(f)) && ok; } catch (e) { console.log(`${f}: validator failed: ${e}`); ok = false; }
  }
  process.exit(ok ? 0 : 1);
})();
