// Validates glTF 2.0 files (.glb or .gltf) with the Khronos glTF validator.
//
//   npm install --prefix tools        (once)
//   node tools/validate_gltf.mjs out.glb [more.glb …]
//
// Prints one JSON line per file (errors, warnings, infos, the first messages) and exits with 1 when any
// file has an error, 2 when a file cannot be read.
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import validator from 'gltf-validator';

async function validate(file) {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 100,
    // A .glb carries everything; an external resource is itself a problem here.
    externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri}`)),
  });
  const issues = report.issues;
  return {
    file,
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    infos: issues.numInfos,
    hints: issues.numHints,
    messages: issues.messages.slice(0, 20).map((m) => `${m.severity} ${m.code} ${m.pointer ?? ''}: ${m.message}`),
    vertices: report.info?.totalVertexCount,
    triangles: report.info?.totalTriangleCount,
  };
}

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node tools/validate_gltf.mjs FILE.glb [FILE.glb …]');
  process.exit(2);
}
let failed = false;
for (const file of files) {
  try {
    const result = await validate(file);
    console.log(JSON.stringify(result));
    failed ||= result.errors > 0;
  } catch (e) {
    console.error(`${file}: ${e.message}`);
    process.exit(2);
  }
}
process.exit(failed ? 1 : 0);
