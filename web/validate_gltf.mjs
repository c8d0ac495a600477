// Runs the Khronos glTF validator (npm gltf-validator) on files: prints one JSON line per file
// {"file", "errors", "warnings", "infos", "messages": [...]} and exits 1 when any has an error or
// a warning. Used by tests/render/test_gltf_browser.cpp from the build tree (web/viewer.cmake
// copies it next to node_modules). Usage: node validate_gltf.mjs FILE.glb...
import fs from 'fs';
import validator from 'gltf-validator';

let bad = false;
for (const file of process.argv.slice(2)) {
  const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), { maxIssues: 100 });
  const { numErrors, numWarnings, numInfos, messages } = report.issues;
  bad = bad || numErrors > 0 || numWarnings > 0;
  console.log(JSON.stringify({
    file, errors: numErrors, warnings: numWarnings, infos: numInfos,
    messages: messages.map((m) => `${m.severity} ${m.code} ${m.pointer || ''} ${m.message}`),
  }));
}
process.exit(bad ? 1 : 0);
