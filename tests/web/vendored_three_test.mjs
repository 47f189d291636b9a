// The three.js files vendored in web/vendor/three are those of the pinned
// npm package (package-lock.json), byte for byte, so that the page runs the
// library the BVH test checked and web/README.md's version is true.
//
//   node vendored_three_test.mjs NODE_MODULES   (ctest: web_vendored_three_matches_its_package)
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const vendored = fileURLToPath(new URL('../../web/vendor/three/', import.meta.url));
const packaged = path.join(process.argv[2], 'three');
const files = {
  'three.module.min.js': 'build/three.module.min.js',
  'addons/controls/OrbitControls.js': 'examples/jsm/controls/OrbitControls.js',
  'addons/loaders/BVHLoader.js': 'examples/jsm/loaders/BVHLoader.js',
  // Not used by the page: gltf_loader_test imports them from its origin in
  // Chromium to read the service's glTF.
  'addons/loaders/GLTFLoader.js': 'examples/jsm/loaders/GLTFLoader.js',
  'addons/utils/BufferGeometryUtils.js': 'examples/jsm/utils/BufferGeometryUtils.js',
  LICENSE: 'LICENSE',
};
for (const [ours, theirs] of Object.entries(files)) {
  assert.ok(fs.readFileSync(path.join(vendored, ours)).equals(fs.readFileSync(path.join(packaged, theirs))),
            `web/vendor/three/${ours} differs from three's ${theirs}`);
}
const { version } = JSON.parse(fs.readFileSync(path.join(packaged, 'package.json'), 'utf8'));
const readme = fs.readFileSync(fileURLToPath(new URL('../../web/README.md', import.meta.url)), 'utf8');
assert.ok(readme.includes(`three ${version}`), `web/README.md does not name three ${version}`);
console.log(`web/vendor/three holds three ${version}'s files unchanged`);
