// Validates one glTF or GLB file with the Khronos glTF validator and prints its report as
// JSON on stdout. Exit code 0 when the report has no errors, 1 when it has errors, 2 when the
// file cannot be read or the validator refuses it.
//
//   node tools/gltf-validator/validate.js part.glb
//
// Install the pinned validator first: npm ci --prefix tools/gltf-validator
"use strict";
const fs = require("fs");
const path = require("path");
const validator = require("gltf-validator");

const file = process.argv[2];
if (!file) {
  console.error("usage: node validate.js FILE.glb");
  process.exit(2);
}
let bytes;
try {
  bytes = fs.readFileSync(file);
} catch (e) {
  console.error(`${file}: ${e.message}`);
  process.exit(2);
}
validator
  .validateBytes(new Uint8Array(bytes), {
    uri: path.basename(file),
    maxIssues: 0, // report every issue
    // A GLB made by moldgate holds everything; any external reference is an error.
    externalResourceFunction: (uri) => Promise.reject(`external resource ${uri}`),
  })
  .then(
    (report) => {
      console.log(JSON.stringify(report, null, 2));
      process.exit(report.issues.numErrors > 0 ? 1 : 0);
    },
    (error) => {
      console.error(`${file}: validator refused the file: ${error}`);
      process.exit(2);
    }
  );
