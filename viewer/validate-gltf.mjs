// Validate every .glb under a tileset folder with the Khronos glTF validator (npm gltf-validator).
// Usage: node validate-gltf.mjs TILESET_DIR  → prints one JSON object: files, errors, warnings,
// infos, the issue codes met (with counts) and the first messages of each file with errors.
// External images are resolved relative to each .glb, so a missing texture file is an error.
import { readFile, readdir } from "node:fs/promises";
import path from "node:path";
import validator from "gltf-validator";

async function* glbFiles(dir) {
  for (const entry of await readdir(dir, { withFileTypes: true })) {
    const full = path.join(dir, entry.name);
    if (entry.isDirectory()) yield* glbFiles(full);
    else if (entry.name.endsWith(".glb")) yield full;
  }
}

const root = process.argv[2];
const summary = { files: 0, errors: 0, warnings: 0, infos: 0, codes: {}, failures: [] };
for await (const file of glbFiles(root)) {
  const report = await validator.validateBytes(new Uint8Array(await readFile(file)), {
    uri: path.basename(file),
    maxIssues: 0,
    externalResourceFunction: (uri) =>
      readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))).then((data) => new Uint8Array(data)),
  });
  summary.files += 1;
  summary.errors += report.issues.numErrors;
  summary.warnings += report.issues.numWarnings;
  summary.infos += report.issues.numInfos;
  for (const message of report.issues.messages) {
    const key = `${["error", "warning", "info", "hint"][message.severity]}:${message.code}`;
    summary.codes[key] = (summary.codes[key] || 0) + 1;
  }
  if (report.issues.numErrors > 0 && summary.failures.length < 5) {
    summary.failures.push({ file: path.relative(root, file),
      messages: report.issues.messages.filter((m) => m.severity === 0).slice(0, 5) });
  }
}
console.log(JSON.stringify(summary, null, 1));
