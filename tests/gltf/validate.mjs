// Validates glTF files with the Khronos glTF validator; prints a line per file and exits
// non-zero if any file has an error. Usage: node validate.mjs FILE...
import validator from 'gltf-validator';
import fs from 'node:fs';
import path from 'node:path';

let failed = false;
for (const file of process.argv.slice(2)) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  // External buffers and images are read from the file's folder.
  const externalResourceFunction = (uri) =>
    Promise.resolve(new Uint8Array(fs.readFileSync(path.join(path.dirname(file), decodeURIComponent(uri)))));
  const r = await validator.validateBytes(bytes, { maxIssues: 100, uri: file, externalResourceFunction });
  const i = r.issues;
  console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints`);
  for (const m of i.messages.slice(0, 20)) {
    console.log(`  [${m.severity}] ${m.code} ${m.pointer ?? ''}: ${m.message}`);
  }
  failed ||= i.numErrors > 0;
}
process.exit(failed ? 1 : 0);
