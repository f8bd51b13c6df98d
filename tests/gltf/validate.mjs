// Validates glTF files with the Khronos glTF validator; prints a line per file and exits
// non-zero if any file has an error. Usage: node validate.mjs FILE...
import validator from 'gltf-validator';
import fs from 'node:fs';

let failed = false;
for (const file of process.argv.slice(2)) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const r = await validator.validateBytes(bytes, { maxIssues: 100 });
  const i = r.issues;
  console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints`);
  for (const m of i.messages.slice(0, 20)) {
    console.log(`  [${m.severity}] ${m.code} ${m.pointer ?? ''}: ${m.message}`);
  }
  failed ||= i.numErrors > 0;
}
process.exit(failed ? 1 : 0);
